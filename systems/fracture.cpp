// Fracture system: Eq 18–19 as systems/README.md §5 reads them.
// For the directed bond i→j in tension, e = |y_j − y_i| − |ξ| > 0 (compression never breaks):
//   side i exceeds:  (e − e^p_ij)/(|ξ| ω_ij) > (1 + α_i φ_i) s_c,i
// and the same for side j with e^p_ji, ω_ji and j's damage and material (side_breaks in
// bond_rules.hpp, which compares extensions against the particle's break extension (1 + αφ) s_c δ).
// The physical bond breaks, for both particles at once, when either side exceeds; it never heals.
// φ is the damage from the start of the step: break extensions are refreshed by
// fracture_threshold_system after the damage system has run.
// Each particle evaluates the predicate for its own slot k; it is an OR of two bit-symmetric side
// tests (bond_rules.hpp), so j's loop gets the same answer for the mirror slot, and each loop writes
// only its own alive[k]: no atomics, no dependence on thread count.
// Reads:  position, plastic_extension, fracture_threshold, bond_alive.   Writes: bond_alive.
// Not scheduled: bond_pass.cpp applies the same test in its fused pass, on the same positions and
// plastic extensions; this separate system (after kick_end) is the tests' oracle for it.
#include "bond_rules.hpp"
#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {
namespace {

template <bool kAnisotropic>
bool breaks(const WorldState& w, const std::vector<Vec3>& y, std::uint32_t i, std::uint32_t k) {
  const Bonds& b = w.bonds;
  const auto& x = w.particles.reference_position;
  const std::uint32_t j = b.neighbor[k];
  const Vec3 dxi = x[j] - x[i];
  const double r = reference_length(dxi);
  BondGeometry g;
  if (!bond_geometry(y[j] - y[i], dxi, r, g) || !(g.extension > 0.0)) return false;
  const auto& metric = w.model.anisotropy_metric;
  const SideLengths weighted =
      side_lengths<kAnisotropic>(particle_metric(metric, i), particle_metric(metric, j), r, dxi.x(), dxi.y(), dxi.z());
  const double ep_ij = w.any_plastic ? double(b.plastic_extension[k]) : 0.0;
  const double ep_ji = w.any_plastic ? double(b.plastic_extension_mirror[k]) : 0.0;
  const double scale = b.break_scale.empty() ? 1.0 : double(b.break_scale[k]);
  return side_breaks<kAnisotropic>(g, r, weighted.inverse_ij, ep_ij, side_constants(w.model, w.state, i), scale) ||
         side_breaks<kAnisotropic>(g, r, weighted.inverse_ji, ep_ji, side_constants(w.model, w.state, j), scale);
}

}  // namespace

bool bond_breaks(const WorldState& w, const std::vector<Vec3>& y, std::uint32_t owner, std::uint32_t k) {
  return dispatch_flags([&](auto aniso) { return breaks<decltype(aniso)::value>(w, y, owner, k); },
                        anisotropic_row(w, owner));  // the bond kernels' form for this row (dispatch_row)
}

void update_fracture(WorldState& w, const std::vector<Vec3>& y) {
  Bonds& b = w.bonds;
  parallel_for_each(w.particles.count(), [&](std::size_t i) {
    for (std::uint32_t k = b.offsets[i], end = b.offsets[i + 1]; k < end; ++k)
      if (b.alive[k] && bond_breaks(w, y, static_cast<std::uint32_t>(i), k)) b.alive[k] = 0;
  }, 256);
}

SystemDecl fracture_system(WorldState& w) {
  return {"fracture",
          {Component::position, Component::plastic_extension, Component::fracture_threshold, Component::bond_alive},
          {Component::bond_alive},
          [&w] { update_fracture(w, w.particles.position); }};
}

}  // namespace perifx::systems
