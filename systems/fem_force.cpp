// FEM internal force system (components/fem.hpp for the equations): linear or corotated linear
// elasticity on the tet mesh, explicit, lumped mass. Replaces dilatation + elastic_force when the
// scene's model.solver is fem_linear or fem_corotated.
//   pass 1 (parallel over tets):     corner forces of every tet into fem.corner_force
//   pass 2 (parallel over vertices): gather the incident corners in the CSR's fixed order
// Each output is written by one task and summed in a fixed order: bit-identical for any thread count.
// The rotation R of the corotated model is the polar factor of F, by Higham's scaled Newton
// iteration R ← ½(ζR + ζ⁻¹R⁻ᵀ) (exact in one step for a pure rotation), with an SVD fallback for
// inverted or near-singular elements (reflection removed so det R = +1).
// Reads: position.   Writes: internal_force (and the per-tet scratch fem.corner_force).
#include <Eigen/LU>
#include <Eigen/SVD>
#include <cmath>

#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {
namespace {

Mat3 rotation_by_svd(const Mat3& F) {
  Eigen::JacobiSVD<Mat3> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 u = svd.matrixU();
  const Mat3& v = svd.matrixV();
  if ((u * v.transpose()).determinant() < 0.0) u.col(2) *= -1.0;
  return u * v.transpose();
}

Mat3 deformation_gradient(const WorldState& w, const std::vector<Vec3>& y, std::size_t t) {
  const auto& v = w.mesh.tets[t];
  Mat3 ds;
  ds.col(0) = y[v[1]] - y[v[0]];
  ds.col(1) = y[v[2]] - y[v[0]];
  ds.col(2) = y[v[3]] - y[v[0]];
  return ds * w.fem.dm_inverse[t];
}

// Small-strain tensor of the (unrotated) element and its rotation.
void element_strain(const WorldState& w, const std::vector<Vec3>& y, std::size_t t, Mat3& rotation, Mat3& eps) {
  const Mat3 F = deformation_gradient(w, y, t);
  if (w.fem.corotated) {
    rotation = polar_rotation(F);
    const Mat3 s = rotation.transpose() * F;
    eps = 0.5 * (s + s.transpose()) - Mat3::Identity();
  } else {
    rotation = Mat3::Identity();
    eps = 0.5 * (F + F.transpose()) - Mat3::Identity();
  }
}

}  // namespace

Mat3 polar_rotation(const Mat3& F) {
  // Newton's iteration needs F well inside the invertible matrices: det F against the cube of F's
  // RMS singular value (a scale det F itself cannot give: with det's own cube root the test passed any
  // det > 0, and a rank-deficient F whose round-off left det ~1e-30 > 0 iterated to NaN: a two-particle
  // piece's cross-covariance in the glTF animation). Singular, inverted or flat F go through the SVD.
  const double det = F.determinant();
  const double scale2 = F.squaredNorm() / 3.0;
  if (!(det > 1e-6 * scale2 * std::sqrt(scale2))) return rotation_by_svd(F);
  Mat3 r = F;
  for (int it = 0; it < 30; ++it) {
    const Mat3 inv_t = r.inverse().transpose();
    // Frobenius-norm scaling (Higham) speeds up the first iterations of a strongly stretched F.
    const double zeta = std::sqrt(std::sqrt(inv_t.squaredNorm() / r.squaredNorm()));
    const Mat3 next = 0.5 * (zeta * r + inv_t / zeta);
    const double change = (next - r).squaredNorm();
    r = next;
    if (change < 1e-20) {  // quadratic convergence: one more step reaches round-off
      r = 0.5 * (r + r.inverse().transpose());
      break;
    }
  }
  return r;
}

void compute_fem_force(const WorldState& w, const std::vector<Vec3>& y, std::vector<Vec3>& corner_force,
                       std::vector<Vec3>& force) {
  const auto& f = w.fem;
  const std::size_t nt = w.mesh.tets.size();
  corner_force.resize(4 * nt);
  parallel_for_each(nt, [&](std::size_t t) {
    Mat3 rot, eps;
    element_strain(w, y, t, rot, eps);
    const Mat3 sigma = f.lame_lambda[t] * eps.trace() * Mat3::Identity() + 2.0 * f.lame_mu[t] * eps;
    const Mat3 h = -f.volume[t] * (rot * sigma) * f.dm_inverse[t].transpose();
    corner_force[4 * t + 1] = h.col(0);
    corner_force[4 * t + 2] = h.col(1);
    corner_force[4 * t + 3] = h.col(2);
    corner_force[4 * t] = -(h.col(0) + h.col(1) + h.col(2));
  }, 1024);
  force.resize(y.size());
  parallel_for_each(y.size(), [&](std::size_t i) {
    Vec3 sum = Vec3::Zero();
    for (std::uint32_t k = f.vertex_offsets[i], end = f.vertex_offsets[i + 1]; k < end; ++k)
      sum += corner_force[f.vertex_corners[k]];
    force[i] = sum;
  }, 2048);
}

double fem_elastic_energy(const WorldState& w, const std::vector<Vec3>& y) {
  const auto& f = w.fem;
  return deterministic_sum(w.mesh.tets.size(), 0.0, [&](std::size_t t) {
    Mat3 rot, eps;
    element_strain(w, y, t, rot, eps);
    const double tr = eps.trace();
    return f.volume[t] * (f.lame_mu[t] * eps.squaredNorm() + 0.5 * f.lame_lambda[t] * tr * tr);
  });
}

SystemDecl fem_force_system(WorldState& w) {
  return {"fem_force", {Component::position}, {Component::internal_force}, [&w] {
            compute_fem_force(w, w.particles.position, w.fem.corner_force, w.state.internal_force);
          }};
}

}  // namespace perifx::systems
