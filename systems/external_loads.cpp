// External load system: the body force b of Eq 1 (gravity), as a force m·g per particle.
// Reads: nothing that changes during a step (mass, scene gravity).   Writes: external_force.
// It has no dependency on the peridynamic chain, so the scheduler runs it alongside.
#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {

SystemDecl external_load_system(WorldState& w) {
  return {"external_loads", {}, {Component::external_force}, [&w] {
            const Vec3 g = w.settings.gravity;
            const auto& mass = w.particles.mass;
            auto& out = w.state.external_force;
            parallel_for_each(w.particles.count(), [&](std::size_t i) { out[i] = mass[i] * g; }, 4096);
          }};
}

}  // namespace perifx::systems
