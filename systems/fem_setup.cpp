// FEM setup (components/fem.hpp): per-tet Dm⁻¹, volume and Lamé constants, and the vertex →
// incident-corner CSR used by the deterministic force gather. Particles are the mesh vertices.
// Reads: mesh, particles.reference_position, scene materials, per-tet material (from its vertices'
// material_id).   Writes: fem.
#include <Eigen/LU>
#include <stdexcept>
#include <string>

#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {

void setup_fem(WorldState& w) {
  auto& f = w.fem;
  const auto& tets = w.mesh.tets;
  const auto& x = w.particles.reference_position;
  const std::size_t nt = tets.size(), nv = x.size();
  f.corotated = w.settings.solver == scene::Solver::fem_corotated;
  f.dm_inverse.resize(nt);
  f.volume.resize(nt);
  f.lame_lambda.resize(nt);
  f.lame_mu.resize(nt);
  f.corner_force.assign(4 * nt, Vec3::Zero());
  for (std::size_t t = 0; t < nt; ++t) {
    const auto& v = tets[t];
    Mat3 dm;
    dm.col(0) = x[v[1]] - x[v[0]];
    dm.col(1) = x[v[2]] - x[v[0]];
    dm.col(2) = x[v[3]] - x[v[0]];
    const double det = dm.determinant();
    if (!(det > 0.0))
      throw std::invalid_argument("fem: tetrahedron " + std::to_string(t) + " is degenerate or inverted (6V = " +
                                  std::to_string(det) + ")");
    f.dm_inverse[t] = dm.inverse();
    f.volume[t] = det / 6.0;
    const auto& mat = w.settings.materials[w.particles.material_id[v[0]]];
    f.lame_mu[t] = mat.shear_modulus;
    f.lame_lambda[t] = mat.bulk_modulus - 2.0 * mat.shear_modulus / 3.0;
  }
  f.vertex_offsets.assign(nv + 1, 0);
  for (const auto& v : tets)
    for (auto i : v) ++f.vertex_offsets[i + 1];
  for (std::size_t i = 0; i < nv; ++i) f.vertex_offsets[i + 1] += f.vertex_offsets[i];
  f.vertex_corners.resize(4 * nt);
  std::vector<std::uint32_t> fill(f.vertex_offsets.begin(), f.vertex_offsets.end() - 1);
  for (std::size_t t = 0; t < nt; ++t)  // ascending t: each vertex's list comes out sorted by tet
    for (std::uint32_t c = 0; c < 4; ++c) f.vertex_corners[fill[tets[t][c]]++] = static_cast<std::uint32_t>(4 * t + c);
}

}  // namespace perifx::systems
