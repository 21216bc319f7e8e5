// Bond pass: the fused form of four systems that each stream over every bond. For every alive bond
// k = i→j of particle i, in one visit and from the same positions and dilatations:
//   1. plasticity     (Eq 11–16, plasticity.cpp):  e^p_ij and the mirror copy e^p_ji, updated in place
//   2. elastic force  (Eq 2–4, 8, 10, 12, elastic_force.cpp): ½(A_ij + A_ji) n V_j with the new e^p
//   3. fracture test  (Eq 18–19, fracture.cpp):   on the same e and new e^p, thresholds from the start
//                                                  of the step; a broken bond still pushed this step
//   4. damage         (Eq 19, damage.cpp):        φ_i and broken bonds after the breaks
// The per-bond rules are the inline functions of bond_rules.hpp that the separate systems call, in the
// same order, so scenes with `model.fuse_bond_systems` true and false give the same bits (a test
// checks it). Why fuse: the separate systems recompute |y_j − y_i| and Λ and stream the bond arrays
// four times; fused, the step does it twice (here and in dilatation).
// Every write goes to particle i's own bond slots or to particle i: no atomics, independent of thread
// count (bond_rules.hpp explains why both ends of a bond reach the same plastic and break decisions).
// Reads:  position, dilatation, plastic_extension, bond_alive, fracture_threshold.
// Writes: internal_force, plastic_extension, bond_alive, damage.
// Scheduled instead of plasticity → elastic_force → … → fracture → damage when the scene has
// plasticity or fracture and model.fuse_bond_systems is true (the default). It runs before kick_end,
// where elastic_force runs; fracture used to run after kick_end, but nothing in between moves the
// particles or reads the bonds, so the break decisions are the same.
#include "bond_rules.hpp"
#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {
namespace {

template <bool kAnisotropic, bool kPlastic, bool kFracture>
void bond_pass(WorldState& w, const std::vector<Vec3>& y, std::vector<Vec3>& force) {
  Bonds& b = w.bonds;
  const auto& x = w.particles.reference_position;
  const auto& volume = w.particles.volume;
  const auto& md = w.model;
  auto& s = w.state;
  const auto& coupling = s.dilatation_coupling;
  parallel_for_each(w.particles.count(), [&](std::size_t i) {
    const Vec3 yi = y[i], xi = x[i];
    const double p_i = coupling[i], b4_i = md.b4[i];
    const SideConstants side_i = side_constants(md, s, i);
    Vec3 f = Vec3::Zero();
    std::uint32_t alive = 0;
    for (std::uint32_t k = b.offsets[i], end = b.offsets[i + 1]; k < end; ++k) {
      if (!b.alive[k]) continue;
      const std::uint32_t j = b.neighbor[k];
      const double r = b.reference_length[k];
      const Vec3 dy = y[j] - yi;
      BondGeometry g;
      if (!bond_geometry(dy, x[j] - xi, r, g)) {  // collapsed: no force, no flow, no break
        ++alive;
        continue;
      }
      const double w_ij = b.weight[k];
      const double w_ji = kAnisotropic ? b.weight[b.reverse[k]] : w_ij;
      const SideConstants side_j = side_constants(md, s, j);
      double ep_ij = 0.0, ep_ji = 0.0;
      if constexpr (kPlastic) {  // plasticity.cpp
        ep_ij = side_plastic_extension<kAnisotropic>(g, r, w_ij, b.plastic_extension[k], side_i);
        ep_ji = side_plastic_extension<kAnisotropic>(g, r, w_ji, b.plastic_extension_mirror[k], side_j);
        b.plastic_extension[k] = ep_ij;
        b.plastic_extension_mirror[k] = ep_ji;
      }
      // elastic_force.cpp
      const double e_ij = kPlastic ? g.extension - ep_ij : g.extension;
      const double e_ji = kPlastic ? g.extension - ep_ji : g.extension;
      const double a_ij = w_ij * (g.cosine * p_i + b4_i * e_ij);
      const double a_ji = w_ji * (g.cosine * coupling[j] + md.b4[j] * e_ji);
      f += (0.5 * (a_ij + a_ji) * g.inverse_length * volume[j]) * dy;
      if constexpr (kFracture) {  // fracture.cpp
        if (g.extension > 0.0 && (side_breaks<kAnisotropic>(g, r, w_ij, ep_ij, side_i) ||
                                  side_breaks<kAnisotropic>(g, r, w_ji, ep_ji, side_j))) {
          b.alive[k] = 0;
          continue;
        }
      }
      ++alive;  // damage.cpp
    }
    force[i] = volume[i] * f;
    store_damage(s, i, b.initial_count[i], alive);
  }, 256);
}

}  // namespace

void run_bond_pass(WorldState& w, const std::vector<Vec3>& y, std::vector<Vec3>& force) {
  const bool aniso = w.any_anisotropic, plastic = w.any_plastic, fracture = w.any_fracture;
  if (aniso) {
    if (plastic) fracture ? bond_pass<true, true, true>(w, y, force) : bond_pass<true, true, false>(w, y, force);
    else fracture ? bond_pass<true, false, true>(w, y, force) : bond_pass<true, false, false>(w, y, force);
  } else {
    if (plastic) fracture ? bond_pass<false, true, true>(w, y, force) : bond_pass<false, true, false>(w, y, force);
    else fracture ? bond_pass<false, false, true>(w, y, force) : bond_pass<false, false, false>(w, y, force);
  }
}

SystemDecl bond_pass_system(WorldState& w) {
  return {"bond_pass",
          {Component::position, Component::dilatation, Component::plastic_extension, Component::bond_alive,
           Component::fracture_threshold},
          {Component::internal_force, Component::plastic_extension, Component::bond_alive, Component::damage},
          [&w] { run_bond_pass(w, w.particles.position, w.state.internal_force); }};
}

}  // namespace perifx::systems
