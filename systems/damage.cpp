// Damage system: Eq 19's damage φ_i = 1 − n_i/N_i (n_i alive bonds, N_i bonds at setup, i.e. after
// initial cracks removed theirs), plus two per-particle output measures:
//   broken_bonds_i   = N_i − n_i
//   plastic_strain_i = mean over alive bonds i→j of |e^p_ij|/|ξ_ij|   (0 with no alive bond)
// This is the only place damage is computed (World::fields() just exposes it). It runs after
// fracture, so the fracture test of the next step sees the damage of the start of that step.
// Reads:  bond_alive, plastic_extension.   Writes: damage (φ, broken_bonds, plastic_strain).
// Scheduled only when world.any_fracture or world.any_plastic; setup calls the kernel once.
#include <cmath>

#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {

void compute_damage(WorldState& w) {
  const Bonds& b = w.bonds;
  auto& s = w.state;
  parallel_for_each(w.particles.count(), [&](std::size_t i) {
    std::uint32_t alive = 0;
    double plastic = 0.0;
    for (std::uint32_t k = b.offsets[i], end = b.offsets[i + 1]; k < end; ++k) {
      if (!b.alive[k]) continue;
      ++alive;
      plastic += std::abs(b.plastic_extension[k]) / b.reference_length[k];
    }
    const std::uint32_t initial = b.initial_count[i];
    s.damage[i] = initial ? 1.0 - double(alive) / double(initial) : 0.0;
    s.broken_bonds[i] = initial - alive;
    s.plastic_strain[i] = alive ? plastic / double(alive) : 0.0;
  }, 1024);
}

SystemDecl damage_system(WorldState& w) {
  return {"damage",
          {Component::bond_alive, Component::plastic_extension},
          {Component::damage},
          [&w] { compute_damage(w); }};
}

}  // namespace perifx::systems
