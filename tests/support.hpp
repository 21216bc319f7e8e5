// Shared helpers for the test suite: scenes built in code, so physics tests do not depend on files.
#pragma once
#include <cmath>
#include <vector>

#include "perifx/world.hpp"
#include "systems/systems.hpp"
#include "components/world_state.hpp"

namespace perifx::test {

// A scene with one box body of the given size and cell, no gravity, no output.
inline scene::Scene box_scene(const Vec3& size, double cell, double kappa, double mu, double density = 1000.0) {
  scene::Scene s;
  s.name = "test";
  s.source = "<memory>";
  s.gravity = Vec3::Zero();
  s.threads = 2;
  s.time.dt = 1e-5;
  scene::Material m;
  m.name = "m";
  m.density = density;
  m.bulk_modulus = kappa;
  m.shear_modulus = mu;
  s.materials.push_back(m);
  scene::Body b;
  b.name = "box";
  b.material = 0;
  b.geometry.kind = scene::Geometry::Kind::box;
  b.geometry.size = size;
  b.geometry.edge_length = cell;
  s.bodies.push_back(b);
  return s;
}

// Dilatation and internal force for positions y of a world (outside the step graph).
struct Evaluation {
  std::vector<double> theta, coupling;
  std::vector<Vec3> force;
  std::vector<Mat3> stress;
};
inline Evaluation evaluate(const World& world, const std::vector<Vec3>& y, bool with_stress = false) {
  const WorldState& w = world.state();
  Evaluation e;
  e.theta.resize(y.size());
  e.coupling.resize(y.size());
  e.force.resize(y.size());
  systems::compute_dilatation(w, y, e.theta, e.coupling);
  systems::compute_internal_force(w, y, e.coupling, e.force);
  if (with_stress) systems::compute_virial_stress(w, y, e.coupling, e.stress);
  return e;
}

// Particles at least `depth` from every face of an axis-aligned box body of size `size` centered at 0.
inline std::vector<std::size_t> interior(const World& world, const Vec3& size, double depth) {
  std::vector<std::size_t> out;
  const auto x = world.reference_positions();
  for (std::size_t i = 0; i < x.size(); ++i)
    if (((0.5 * size - x[i].cwiseAbs()).array() >= depth).all()) out.push_back(i);
  return out;
}

}  // namespace perifx::test
