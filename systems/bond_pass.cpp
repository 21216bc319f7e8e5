// Bond pass: the fused form of four systems that each stream over every bond. For every alive bond
// k = i→j of particle i, in one visit and from the same positions and dilatations:
//   1. plasticity     (Eq 11–16, plasticity.cpp):  e^p_ij and the mirror copy e^p_ji, updated in place
//   2. elastic force  (Eq 2–4, 8, 10, 12, elastic_force.cpp): ½(A_ij + A_ji) n V_j with the new e^p
//                                                  (ω with the influence ramp; the yield and break
//                                                  tests below read the unramped δ, bond_rules.hpp)
//   3. fracture test  (Eq 18–19, fracture.cpp):   on the same e and new e^p, thresholds from the start
//                                                  of the step; a broken bond still pushed this step
//   4. damage         (Eq 19, damage.cpp):        φ_i and broken bonds after the breaks
// The per-bond rules are the inline functions of bond_rules.hpp that the separate systems call, in the
// same order, so the fused pass and the separate systems give the same bits (the separate systems
// are kept as the test oracle; a test checks it). Why fuse: the separate systems recompute |y_j − y_i| and Λ and stream the bond arrays
// four times; fused, the step does it twice (here and in dilatation).
// The far end's per-particle numbers are read from a packed copy (ParticleState::bond_end, one cache
// line per particle) that the pass refreshes first.
// Every write goes to particle i's own bond slots or to particle i: no atomics, independent of thread
// count (bond_rules.hpp explains why both ends of a bond reach the same plastic and break decisions).
// Reads:  position, dilatation, plastic_extension, bond_alive, fracture_threshold, bonds.break_scale.
// Writes: internal_force, plastic_extension, bond_alive, damage, bond_end (its packed far-end copy).
// Scheduled in every peridynamic step, elastic scenes included, where the separate systems
// (plasticity) → elastic_force → … → (fracture → damage) would run. It runs before kick_end,
// where elastic_force runs; fracture used to run after kick_end, but nothing in between moves the
// particles or reads the bonds, so the break decisions are the same.
#include "bond_gather.hpp"
#include "bond_rules.hpp"
#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {
namespace {

// Refreshes the packed far-end copy (ParticleState::bond_end) from this step's dilatation and
// break extensions: one short streaming pass, so the bond loop gathers one line per neighbour.
void pack_bond_ends(WorldState& w) {
  const auto& md = w.model;
  auto& s = w.state;
  const auto& volume = w.particles.volume;
  parallel_for_each(w.particles.count(), [&](std::size_t i) {
    const SideConstants c = side_constants(md, s, i);
    s.bond_end[i] = BondEnd{s.dilatation_coupling[i], md.b4[i],      volume[i],     c.horizon,
                            c.beta_theta,             c.yield_extension, c.plastic_cap, c.break_extension};
  }, 4096);
}

template <bool kAnisotropicWorld, bool kPlastic, bool kFracture, bool kScaled>
void bond_pass(WorldState& w, const std::vector<Vec3>& y_vec, std::vector<Vec3>& force) {
  pack_bond_ends(w);
  // Raw pointers, captured by value and copied into the task's locals (BondStreams in bond_rules.hpp
  // says why: the alive stores).
  const auto bs_p = bond_streams(w, y_vec);
  const BondEnd* const ends_p = w.state.bond_end.data();
  const std::uint32_t* const initial_count_p = w.bonds.initial_count.data();
  double* const damage_p = w.state.damage.data();
  std::uint32_t* const broken_p = w.state.broken_bonds.data();
  double* const force_p = force.data()->data();
  const auto& anisotropic_family = w.model.anisotropic_family;
  const InfluenceRamp ramp = influence_ramp(w);
  parallel_for_each(w.particles.count(), [=, &anisotropic_family](std::size_t i) {
    dispatch_row<kAnisotropicWorld>(anisotropic_family, i, [=](auto row_form) {
      constexpr bool kAnisotropic = decltype(row_form)::value, kSharedMetric = decltype(row_form)::shared_metric;
      const auto bs = bs_p;
      const BondEnd* const ends = ends_p;
      const auto o = bs.origin(i);
      const BondEnd end_i = ends[i];
      const SideConstants side_i = side_constants(end_i);
      const AnisotropyMetric& g_i = bs.template anisotropy<kAnisotropic>(i);
      double fx[kBondLanes] = {}, fy[kBondLanes] = {}, fz[kBondLanes] = {};
      std::uint64_t alive_lanes[kBondLanes] = {}, breaks_lanes[kBondLanes] = {};
      // The chunk's far ends in lane order (bond_gather.hpp): positions, and the BondEnd fields the
      // pass reads (the inelastic half only when plasticity or fracture is on).
      ChunkPositions cp;
      ChunkEnds ce;
      auto gather = [&](std::size_t k, int n) {
        gather_positions(bs.y, bs.reference, bs.neighbor + k, n, cp);
        gather_ends<kPlastic || kFracture>(ends, bs.neighbor + k, n, ce);
      };
      auto lane = [=, &g_i, &fx, &fy, &fz, &alive_lanes, &breaks_lanes, &cp, &ce](std::size_t k, int l,
                                                                                  std::uint64_t was_alive) {
        const double dyx = cp.yx[l] - o.yx, dyy = cp.yy[l] - o.yy, dyz = cp.yz[l] - o.yz;
        const double dxx = cp.xx[l] - o.xx, dxy = cp.xy[l] - o.xy, dxz = cp.xz[l] - o.xz;
        const double r = reference_length(dxx, dxy, dxz);
        BondGeometry g;
        // A collapsed bond (coincident particles) has no direction: no force, no flow, no break.
        const bool active = bond_geometry(dyx, dyy, dyz, dxx, dxy, dxz, r, g) & (was_alive != 0);
        const SideConstants side_j = side_constants<kPlastic || kFracture>(ce, l);
        const SideLengths weighted = side_lengths<kAnisotropic, kSharedMetric>(
            g_i, bs.template anisotropy<kAnisotropic && !kSharedMetric>(bs.neighbor[k]), r, dxx, dxy, dxz);
        double ep_ij = 0.0, ep_ji = 0.0;
        if constexpr (kPlastic) {  // plasticity.cpp. Stored as float; the force and the break test use the
          // rounded value, as the separate systems do when they read it back. Selected in float, then
          // widened once (a select between a float and a double kept GCC 12 from vectorizing the loop).
          const float old_ij = bs.plastic[k], old_ji = bs.plastic_mirror[k];
          const float new_ij = static_cast<float>(side_plastic_extension(g, r, weighted.ij, old_ij, side_i));
          const float new_ji = static_cast<float>(side_plastic_extension(g, r, weighted.ji, old_ji, side_j));
          const float kept_ij = active ? new_ij : old_ij, kept_ji = active ? new_ji : old_ji;
          bs.plastic[k] = kept_ij;
          bs.plastic_mirror[k] = kept_ji;
          ep_ij = kept_ij;
          ep_ji = kept_ji;
        }
        // elastic_force.cpp. Computed for every lane, then selected: a load inside the condition would
        // be a masked gather.
        const double density = paired_force_density<kAnisotropic, kPlastic>(
            g, force_weight<kAnisotropic>(ramped_horizon(side_i.horizon, r, ramp), weighted.inverse_ij),
            force_weight<kAnisotropic>(ramped_horizon(side_j.horizon, r, ramp), weighted.inverse_ji), ep_ij,
            ep_ji, end_i.coupling, end_i.b4, ce.coupling[l], ce.b4[l], ce.volume[l]);
        const double c = active ? density : 0.0;
        fx[l] += c * dyx;
        fy[l] += c * dyy;
        fz[l] += c * dyz;
        std::uint64_t breaks = 0;
        if constexpr (kFracture) {  // fracture.cpp
          const double scale = kScaled ? double(bs.break_scale[k]) : 1.0;
          breaks = static_cast<std::uint64_t>(active & (g.extension > 0.0) &
                                              (side_breaks<kAnisotropic>(g, r, weighted.inverse_ij, ep_ij, side_i, scale) |
                                               side_breaks<kAnisotropic>(g, r, weighted.inverse_ji, ep_ji, side_j, scale)));
        }
        breaks_lanes[l] = breaks;
        alive_lanes[l] += was_alive & ~breaks;  // damage.cpp (a collapsed bond stays alive)
      };
      std::uint8_t* const alive_flag = bs.alive;
      auto finish = [&breaks_lanes, alive_flag](std::size_t k, int n) {
        if constexpr (kFracture) {
          for (int l = 0; l < n; ++l)
            if (breaks_lanes[l]) alive_flag[k + static_cast<std::size_t>(l)] = 0;  // rare: a predictable branch
        }
      };
      for_each_gathered_bond_lane(bs.offsets[i], bs.offsets[i + 1], alive_flag, gather, lane, finish, DeadChunks::skip);
      const double v_i = end_i.volume;
      force_p[3 * i] = v_i * sum_lanes(fx);
      force_p[3 * i + 1] = v_i * sum_lanes(fy);
      force_p[3 * i + 2] = v_i * sum_lanes(fz);
      store_damage(damage_p[i], broken_p[i], initial_count_p[i], static_cast<std::uint32_t>(sum_lanes(alive_lanes)));
    });
  }, 256);
}

}  // namespace

void run_bond_pass(WorldState& w, const std::vector<Vec3>& y, std::vector<Vec3>& force) {
  dispatch_flags(
      [&](auto aniso, auto plastic, auto fracture, auto scaled) {
        bond_pass<decltype(aniso)::value, decltype(plastic)::value, decltype(fracture)::value, decltype(scaled)::value>(
            w, y, force);
      },
      w.any_anisotropic, w.any_plastic, w.any_fracture, !w.bonds.break_scale.empty());
}

SystemDecl bond_pass_system(WorldState& w) {
  return {"bond_pass",
          {Component::position, Component::dilatation, Component::plastic_extension, Component::bond_alive,
           Component::fracture_threshold},
          {Component::internal_force, Component::plastic_extension, Component::bond_alive, Component::damage,
           Component::bond_end},
          [&w] { run_bond_pass(w, w.particles.position, w.state.internal_force); }};
}

}  // namespace perifx::systems
