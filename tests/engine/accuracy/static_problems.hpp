// Static linear reference problems for the accuracy study of issue 12 (assets/report/accuracy.md):
// a cantilever under gravity (tip deflection), a bar twisted by an end torque (twist rate) and a bar
// stretched by end loads (Poisson contraction), 1.0 × 0.1 × 0.1 m along x, centered at the origin.
//
//  * FEM: small-strain linear elasticity on the structured Freudenthal mesh (6 tets per cell) with
//    linear (4-node) or quadratic (10-node, straight-sided: mid-edge nodes at edge midpoints) tets,
//    4-point Gauss quadrature (exact for the quadratic stiffness), assembled and solved with Eigen's
//    sparse LDLᵀ. Nodes with x ≤ −0.45 are fixed (the clamp over the first 5 cm).
//  * PD: the linearization of the peridynamic force about the reference configuration, K v =
//    −(F(x + h v))/h (F(x) = 0), solved by conjugate gradients; particles with x ≤ −0.45 fixed.
// Both get the same body-force field b(x) (N/m³) and are measured by the same volume integrals.
#pragma once
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <vector>

#include "geometry/geometry.hpp"
#include "support.hpp"

namespace perifx::accuracy {

constexpr double kLength = 1.0, kDepth = 0.1, kClampX = -0.45;

enum class Problem { cantilever, torsion, stretch };

struct Material {
  double kappa = 33e6, mu = 20e6, density = 1000.0;
};

// Body force density (N/m³) of each problem at reference point x.
inline Vec3 body_force(Problem p, const Material& m, const Vec3& x) {
  switch (p) {
    case Problem::cantilever: return Vec3(0, -9.81 * m.density, 0);
    case Problem::torsion:  // a torque about x on the last 10 cm: b = c (0, −z, y)
      return x.x() >= 0.4 ? Vec3(Vec3(0, -x.z(), x.y()) * 1e7) : Vec3(Vec3::Zero());
    case Problem::stretch:  // a pull along +x on the last 10 cm
      return x.x() >= 0.4 ? Vec3(1e5, 0, 0) : Vec3(Vec3::Zero());
  }
  return Vec3::Zero();
}

// Measurements, as volume integrals over reference slabs (so FEM and PD are measured alike).
struct Measure {
  double tip = 0;        // cantilever: mean u_y over x ∈ [0.4, 0.5], m
  double twist_rate = 0; // torsion: (φ(slab [0.1, 0.2]) − φ(slab [−0.2, −0.1]))/0.3, rad/m
  double poisson = 0;    // stretch: −(ε_yy + ε_zz)/(2 ε_xx) from an affine fit over x ∈ [−0.2, 0.2]
};

// Accumulates volume-weighted samples (point, displacement, weight) into the measures.
struct Accumulator {
  double tip_u = 0, tip_v = 0;
  double phi_num[2] = {0, 0}, phi_den[2] = {0, 0};
  Eigen::Matrix<double, 4, 4> xx = Eigen::Matrix<double, 4, 4>::Zero();
  Eigen::Matrix<double, 4, 3> xu = Eigen::Matrix<double, 4, 3>::Zero();
  void add(const Vec3& x, const Vec3& u, double w) {
    if (x.x() >= 0.4) tip_u += w * u.y(), tip_v += w;
    for (int s = 0; s < 2; ++s) {
      const double lo = s == 0 ? -0.2 : 0.1;
      if (x.x() >= lo && x.x() <= lo + 0.1) {
        phi_num[s] += w * (x.y() * u.z() - x.z() * u.y());
        phi_den[s] += w * (x.y() * x.y() + x.z() * x.z());
      }
    }
    if (std::abs(x.x()) <= 0.2) {
      const Eigen::Vector4d p(x.x(), x.y(), x.z(), 1.0);
      xx += w * p * p.transpose();
      xu += w * p * u.transpose();
    }
  }
  Measure result() const {
    Measure m;
    m.tip = tip_v > 0 ? tip_u / tip_v : 0.0;
    if (phi_den[0] > 0 && phi_den[1] > 0) m.twist_rate = (phi_num[1] / phi_den[1] - phi_num[0] / phi_den[0]) / 0.3;
    const Eigen::Matrix<double, 4, 3> a = xx.ldlt().solve(xu);  // u ≈ aᵀ (x, 1): a(r, c) = ∂u_c/∂x_r
    if (a(0, 0) != 0.0) m.poisson = -(a(1, 1) + a(2, 2)) / (2.0 * a(0, 0));
    return m;
  }
};

// ------------------------------------------------------------------------------------------------
// FEM, linear or quadratic tets
// ------------------------------------------------------------------------------------------------
inline Measure solve_fem(Problem problem, const Material& mat, int cells_deep, bool quadratic) {
  const double h = kDepth / cells_deep;
  const TetMesh mesh = geometry::mesh_box(Vec3(kLength, kDepth, kDepth), h);
  std::vector<Vec3> nodes = mesh.vertices;
  std::vector<std::vector<std::uint32_t>> elems;
  constexpr int kEdges[6][2] = {{0, 1}, {1, 2}, {0, 2}, {0, 3}, {1, 3}, {2, 3}};
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> mid;
  for (const auto& t : mesh.tets) {
    std::vector<std::uint32_t> e(t.begin(), t.end());
    if (quadratic)
      for (const auto& ed : kEdges) {
        auto key = std::minmax(t[ed[0]], t[ed[1]]);
        auto it = mid.find({key.first, key.second});
        if (it == mid.end()) {
          it = mid.emplace(std::make_pair(key.first, key.second), static_cast<std::uint32_t>(nodes.size())).first;
          nodes.push_back(0.5 * (mesh.vertices[t[ed[0]]] + mesh.vertices[t[ed[1]]]));
        }
        e.push_back(it->second);
      }
    elems.push_back(e);
  }
  const std::size_t nn = nodes.size();
  std::vector<int> dof(3 * nn, -1);
  int ndof = 0;
  for (std::size_t v = 0; v < nn; ++v)
    if (nodes[v].x() > kClampX + 1e-9)
      for (int c = 0; c < 3; ++c) dof[3 * v + c] = ndof++;

  const double lam = mat.kappa - 2.0 * mat.mu / 3.0;
  Eigen::Matrix<double, 6, 6> D = Eigen::Matrix<double, 6, 6>::Zero();
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) D(a, b) = lam;
    D(a, a) += 2.0 * mat.mu;
    D(3 + a, 3 + a) = mat.mu;
  }
  const double qa = 0.5854101966249685, qb = 0.1381966011250105;
  std::vector<Eigen::Triplet<double>> trip;
  Eigen::VectorXd f = Eigen::VectorXd::Zero(ndof);
  struct Sample { Vec3 x; double w; std::vector<double> N; const std::vector<std::uint32_t>* e; };
  std::vector<Sample> samples;
  for (const auto& e : elems) {
    const int ne = static_cast<int>(e.size());
    const Vec3 &p0 = nodes[e[0]], &p1 = nodes[e[1]], &p2 = nodes[e[2]], &p3 = nodes[e[3]];
    Mat3 J;
    J.col(0) = p1 - p0, J.col(1) = p2 - p0, J.col(2) = p3 - p0;
    const double vol = J.determinant() / 6.0;
    const Mat3 Ji = J.inverse();  // rows: ∇L1, ∇L2, ∇L3
    Vec3 gL[4];
    gL[1] = Ji.row(0).transpose(), gL[2] = Ji.row(1).transpose(), gL[3] = Ji.row(2).transpose();
    gL[0] = -(gL[1] + gL[2] + gL[3]);
    Eigen::MatrixXd Ke = Eigen::MatrixXd::Zero(3 * ne, 3 * ne);
    Eigen::VectorXd fe = Eigen::VectorXd::Zero(3 * ne);
    for (int q = 0; q < 4; ++q) {
      double L[4] = {qb, qb, qb, qb};
      L[q] = qa;
      std::vector<double> N(ne);
      std::vector<Vec3> G(ne);
      for (int a = 0; a < 4; ++a) {
        N[a] = quadratic ? L[a] * (2 * L[a] - 1) : L[a];
        G[a] = quadratic ? Vec3((4 * L[a] - 1) * gL[a]) : gL[a];
      }
      if (quadratic)
        for (int k = 0; k < 6; ++k) {
          const int a = kEdges[k][0], b = kEdges[k][1];
          N[4 + k] = 4 * L[a] * L[b];
          G[4 + k] = 4 * (L[a] * gL[b] + L[b] * gL[a]);
        }
      Eigen::MatrixXd B = Eigen::MatrixXd::Zero(6, 3 * ne);
      Vec3 xq = Vec3::Zero();
      for (int a = 0; a < ne; ++a) {
        xq += N[a] * nodes[e[a]];
        const Vec3& g = G[a];
        B(0, 3 * a) = g.x(), B(1, 3 * a + 1) = g.y(), B(2, 3 * a + 2) = g.z();
        B(3, 3 * a) = g.y(), B(3, 3 * a + 1) = g.x();
        B(4, 3 * a + 1) = g.z(), B(4, 3 * a + 2) = g.y();
        B(5, 3 * a) = g.z(), B(5, 3 * a + 2) = g.x();
      }
      const double w = vol / 4.0;
      Ke += w * B.transpose() * D * B;
      const Vec3 b = body_force(problem, mat, xq);
      for (int a = 0; a < ne; ++a)
        for (int c = 0; c < 3; ++c) fe(3 * a + c) += w * N[a] * b(c);
      samples.push_back({xq, w, N, &e});
    }
    for (int r = 0; r < 3 * ne; ++r) {
      const int gr = dof[3 * e[r / 3] + r % 3];
      if (gr < 0) continue;
      f(gr) += fe(r);
      for (int c = 0; c < 3 * ne; ++c) {
        const int gc = dof[3 * e[c / 3] + c % 3];
        if (gc >= 0 && Ke(r, c) != 0.0) trip.emplace_back(gr, gc, Ke(r, c));
      }
    }
  }
  Eigen::SparseMatrix<double> K(ndof, ndof);
  K.setFromTriplets(trip.begin(), trip.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(K);
  const Eigen::VectorXd u = solver.solve(f);
  Accumulator acc;
  for (const auto& s : samples) {
    Vec3 us = Vec3::Zero();
    for (std::size_t a = 0; a < s.e->size(); ++a)
      for (int c = 0; c < 3; ++c) {
        const int g = dof[3 * (*s.e)[a] + c];
        if (g >= 0) us(c) += s.N[a] * u(g);
      }
    acc.add(s.x, us, s.w);
  }
  return acc.result();
}

// ------------------------------------------------------------------------------------------------
// PD, linearized about the reference, conjugate gradients
// ------------------------------------------------------------------------------------------------
struct PdResult {
  Measure measure;
  int iterations = 0;
  double residual = 0;
  std::size_t particles = 0;
};

// jitter: the structured mesh's vertex offset (the default of breakable bodies is 0.3), 0 = regular.
inline scene::Scene pd_scene(const Material& mat, int cells_deep, scene::Normalization norm, double horizon_factor,
                             double jitter = 0.0) {
  auto sc = test::box_scene(Vec3(kLength, kDepth, kDepth), kDepth / cells_deep, mat.kappa, mat.mu, mat.density);
  sc.normalization = norm;
  sc.bodies[0].horizon_factor = horizon_factor;
  sc.bodies[0].geometry.jitter = jitter;
  return sc;
}

inline PdResult solve_pd(Problem problem, const Material& mat, int cells_deep, scene::Normalization norm,
                         double horizon_factor = 1.45, double tolerance = 1e-8, int max_iterations = 200000,
                         double jitter = 0.0) {
  World world(pd_scene(mat, cells_deep, norm, horizon_factor, jitter));
  const WorldState& w = world.state();
  const auto xs = world.reference_positions();
  const std::vector<Vec3> x(xs.begin(), xs.end());
  const std::size_t n = x.size();
  std::vector<std::uint8_t> free(n);
  Eigen::VectorXd f = Eigen::VectorXd::Zero(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    free[i] = x[i].x() > kClampX;
    if (free[i]) f.segment<3>(3 * i) = w.particles.volume[i] * body_force(problem, mat, x[i]);
  }
  std::vector<Vec3> y(n);
  std::vector<double> theta(n), coupling(n);
  std::vector<Vec3> force(n);
  const double lambda = kDepth / cells_deep;
  auto apply = [&](const Eigen::VectorXd& v, Eigen::VectorXd& out) {
    const double vmax = v.cwiseAbs().maxCoeff();
    out.setZero(3 * n);
    if (vmax == 0.0) return;
    const double step = 1e-7 * lambda / vmax;
    for (std::size_t i = 0; i < n; ++i) y[i] = x[i] + step * Vec3(v.segment<3>(3 * i));
    systems::compute_dilatation(w, y, theta, coupling);
    systems::compute_internal_force(w, y, coupling, force);
    for (std::size_t i = 0; i < n; ++i)
      if (free[i]) out.segment<3>(3 * i) = -force[i] / step;
  };
  // Coarse (Ritz) start: the best combination of a few smooth fields of the problem's kind (beam
  // bending, twist with warping, stretch with contraction, as powers of the distance s from the
  // clamp), so CG only has to resolve the local corrections, not the slow global mode.
  // The fields return Vec3, never an Eigen expression: an expression of a temporary Vec3 would
  // outlive it (it failed the torsion solve now and then, with a zero twist).
  std::vector<Eigen::VectorXd> basis;
  auto field = [&](auto&& fn) {
    Eigen::VectorXd v = Eigen::VectorXd::Zero(3 * n);
    for (std::size_t i = 0; i < n; ++i)
      if (free[i]) v.segment<3>(3 * i) = fn(x[i], x[i].x() - kClampX);
    basis.push_back(v);
  };
  for (int k = 1; k <= 5; ++k) {
    if (problem == Problem::cantilever) {
      field([&](const Vec3& p, double s) -> Vec3 { return Vec3(-p.y() * k * std::pow(s, k - 1), std::pow(s, k), 0); });
      field([&](const Vec3& p, double s) -> Vec3 { return Vec3(0, std::pow(s, k) * (p.z() * p.z() - p.y() * p.y()), p.y() * p.z() * std::pow(s, k)); });
      field([&](const Vec3& p, double s) -> Vec3 { return Vec3(std::pow(s, k) * p.y(), 0, 0); });
    } else if (problem == Problem::torsion) {
      field([&](const Vec3& p, double s) -> Vec3 { return Vec3(0, -p.z(), p.y()) * std::pow(s, k); });
      field([&](const Vec3& p, double s) -> Vec3 { return Vec3(p.y() * p.z() * k * std::pow(s, k - 1), 0, 0); });
    }  // stretch: CG from zero converges quickly (an axial problem)
  }
  Eigen::VectorXd u = Eigen::VectorXd::Zero(3 * n), Ap(3 * n);
  if (!basis.empty()) {
    const std::size_t m = basis.size();
    std::vector<Eigen::VectorXd> kb(m);
    for (std::size_t a = 0; a < m; ++a) apply(basis[a], kb[a]);
    Eigen::MatrixXd small(m, m);
    Eigen::VectorXd rhs(m);
    for (std::size_t a = 0; a < m; ++a) {
      rhs(a) = basis[a].dot(f);
      for (std::size_t b = 0; b < m; ++b) small(a, b) = 0.5 * (basis[a].dot(kb[b]) + basis[b].dot(kb[a]));
    }
    const Eigen::VectorXd c = small.completeOrthogonalDecomposition().solve(rhs);
    for (std::size_t a = 0; a < m; ++a) u += c(a) * basis[a];
  }
  Eigen::VectorXd r(3 * n);
  apply(u, Ap);
  r = f - Ap;
  Eigen::VectorXd p = r;
  double rr = r.squaredNorm();
  const double stop = tolerance * tolerance * f.squaredNorm();
  auto measure_now = [&] {
    Accumulator acc;
    for (std::size_t i = 0; i < n; ++i) acc.add(x[i], Vec3(u.segment<3>(3 * i)), w.particles.volume[i]);
    const Measure m = acc.result();
    return problem == Problem::cantilever ? m.tip : problem == Problem::torsion ? m.twist_rate : m.poisson;
  };
  double last = measure_now();
  int steady = 0;
  int it = 0;
  for (; it < max_iterations && rr > stop; ++it) {
    apply(p, Ap);
    const double alpha = rr / p.dot(Ap);
    u += alpha * p;
    r -= alpha * Ap;
    if (it % 200 == 199) {  // recompute the residual: the finite-difference operator drifts
      Eigen::VectorXd Au(3 * n);
      apply(u, Au);
      r = f - Au;
    }
    const double rr_new = r.squaredNorm();
    p = r + (rr_new / rr) * p;
    rr = rr_new;
    if (it % 100 == 99) {  // the measured value has settled to 1e-5 over 3 checks in a row: done
      const double now = measure_now();
      steady = std::abs(now - last) <= 1e-5 * std::abs(now) ? steady + 1 : 0;
      last = now;
      if (steady >= 3) break;
    }
  }
  Accumulator acc;
  for (std::size_t i = 0; i < n; ++i) acc.add(x[i], Vec3(u.segment<3>(3 * i)), w.particles.volume[i]);
  return {acc.result(), it, std::sqrt(rr / f.squaredNorm()), n};
}

}  // namespace perifx::accuracy
