// Mesh vertices system (paper Eq 20–22): moves the embedded mesh's vertices with the particles,
// after mesh_split, so every vertex copy follows only its own tet group.
//   VertexMotion::paper (Eq 20–22 as written): v_v = Σ_t (m_t/4) v_t / Σ_t (m_t/4) over the tets t
//     that currently hold v, then x_v += dt·v_v (v_t: end-of-step particle velocities).
//     Exact for translation; for a rotation the explicit update leaves the circle (radius grows by
//     ~½(ω dt)² per step) and boundary vertices, whose tet star is lopsided, turn with the star's
//     centroid rather than with themselves. Measured in tests/systems/test_embedded_mesh.cpp.
//   VertexMotion::embedded (default): x_v = X_v + Σ_p w_vp (y_p − x_p), v_v = Σ_p w_vp v_p with the
//     affine-fit weights of systems/embedded_mesh.cpp. Same inputs (the group's particles, mass
//     weighted), but positions are a function of the particle positions, so there is no drift and
//     rigid (any affine) motion is reproduced to round-off.
// Parallel over vertices, each written by one task: deterministic.
// Reads:  position, velocity, mesh.   Writes: mesh (vertex positions and velocities).
#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {

void update_mesh_vertices(WorldState& w, double dt) {
  EmbeddedMesh& e = w.embedded;
  const auto& y = w.particles.position;
  const auto& x = w.particles.reference_position;
  const auto& vel = w.particles.velocity;
  if (e.motion == VertexMotion::embedded) {
    parallel_for_each(e.vertices.size(), [&](std::size_t v) {
      Vec3 u = Vec3::Zero(), vv = Vec3::Zero();
      for (std::uint32_t q = e.weight_rows[v][0]; q < e.weight_rows[v][1]; ++q) {
        const std::uint32_t p = e.weight_particle[q];
        u += e.weight_value[q] * (y[p] - x[p]);
        vv += e.weight_value[q] * vel[p];
      }
      e.vertices[v] = e.reference_vertices[v] + u;
      e.vertex_velocity[v] = vv;
    }, 1024);
    return;
  }
  const auto& mass = w.particles.mass;
  parallel_for_each(e.vertices.size(), [&](std::size_t v) {
    const std::uint32_t o = e.origin[v];
    Vec3 momentum = Vec3::Zero();
    double m = 0.0;
    for (std::uint32_t q = e.incidence_offsets[o]; q < e.incidence_offsets[o + 1]; ++q) {
      const std::uint32_t t = e.incidence[q] / 4, s = e.incidence[q] % 4;
      if (e.tets[t][s] != v) continue;
      momentum += 0.25 * mass[t] * vel[t];  // Eq 20: each tet contributes m_t/4
      m += 0.25 * mass[t];
    }
    if (m > 0.0) e.vertex_velocity[v] = momentum / m;  // Eq 21
    e.vertices[v] += dt * e.vertex_velocity[v];        // Eq 22
  }, 1024);
}

SystemDecl mesh_vertex_system(WorldState& w) {
  return {"mesh_vertices", {Component::position, Component::velocity, Component::mesh}, {Component::mesh},
          [&w] { update_mesh_vertices(w, w.clock.dt); }};
}

}  // namespace perifx::systems
