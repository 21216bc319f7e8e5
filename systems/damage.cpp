// Damage system: Eq 19's damage φ_i = 1 − n_i/N_i (n_i alive bonds, N_i bonds at setup, i.e. after
// initial cracks removed theirs), and broken_bonds_i = N_i − n_i for output. (The plastic measure,
// mean |e^p|/|ξ|, is an output-only field computed when fields are requested: World::fields.)
// It runs after fracture in the tests' separate-systems oracle; the step's fused bond pass
// (bond_pass.cpp) counts the alive bonds while it decides the breaks instead.
// Reads:  bond_alive.   Writes: damage (φ, broken_bonds).
//
// Fracture-threshold system: the break extension B_i = (1 + α_i φ_i) s_c,i δ_i (Eq 19, systems/README.md §5;
// see side_exceeds in bond_rules.hpp), ∞ when unbreakable, from the damage just computed; the
// fracture test of the next step reads it, so that test sees the damage of the start of its step.
// Reads:  damage.   Writes: fracture_threshold (ParticleState::break_extension).
// The threshold system is scheduled only when world.any_fracture; setup calls its kernel once.
#include <cmath>

#include "bond_rules.hpp"
#include "parallel.hpp"
#include "field_registry.hpp"
#include "systems.hpp"

namespace perifx::systems {

void compute_damage(WorldState& w) {
  const Bonds& b = w.bonds;
  auto& s = w.state;
  parallel_for_each(w.particles.count(), [&](std::size_t i) {
    std::uint32_t alive = 0;
    for (std::uint32_t k = b.offsets[i], end = b.offsets[i + 1]; k < end; ++k) alive += b.alive[k];
    store_damage(s.damage[i], s.broken_bonds[i], b.initial_count[i], alive);
  }, 1024);
}

void compute_fracture_thresholds(WorldState& w) {
  const auto& md = w.model;
  auto& s = w.state;
  parallel_for_each(w.particles.count(), [&](std::size_t i) {
    s.break_extension[i] = break_extension(md.critical_stretch[i], md.damage_alpha[i], s.damage[i], md.horizon[i]);
  }, 4096);
}

SystemDecl damage_system(WorldState& w) {
  return {"damage",
          {Component::bond_alive},
          {Component::damage},
          [&w] { compute_damage(w); }};
}

SystemDecl fracture_threshold_system(WorldState& w) {
  return {"fracture_threshold", {Component::damage}, {Component::fracture_threshold},
          [&w] { compute_fracture_thresholds(w); }};
}


void register_damage_fields(FieldRegistry& r) {
  // damage and broken_bonds are kept current every step by this system (or the fused bond pass).
  r.push_back(make_field("damage", FieldType::f64, 1, "1", "φ = 1 − n/N (Eq 19)",
                         [](WorldState& w, FieldView& v) { view_array(v, w.state.damage); }));
  r.push_back(make_field("alive_bonds", FieldType::u32, 1, "1", "bonds still holding", [](WorldState& w, FieldView& v) {
    const Bonds& b = w.bonds;
    const std::size_t n = w.particles.count();
    w.derived.alive_bonds.resize(n);
    parallel_for_each(n, [&](std::size_t i) {
      std::uint32_t alive = 0;
      for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k) alive += b.alive[k];
      w.derived.alive_bonds[i] = alive;
    });
    view_array(v, w.derived.alive_bonds);
  }, true));
  r.push_back(make_field("broken_bonds", FieldType::u32, 1, "1", "N − n: bonds broken since setup",
                         [](WorldState& w, FieldView& v) { view_array(v, w.state.broken_bonds); }));
}

}  // namespace perifx::systems
