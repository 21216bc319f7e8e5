// Fracture system: Eq 18–19 as notes.md ("Fracture — one decision") reads them.
// For the directed bond i→j with extension e = |y_j − y_i| − |ξ| > 0 (compression never breaks):
//   measure_ij   = (e − e^p_ij)/|ξ| / ω_ij            (s^e/ω; = (e − e^p)/δ for ω = δ/|ξ|)
//   threshold_ij = (1 + α_i φ_i) s_c,i                 (material of i; s_c = ∞ never breaks)
// and the same for the mirror direction j→i with e^p_ji, ω_ji, φ_j and j's material. The physical
// bond breaks, for both particles at once, when either direction exceeds its threshold; it never
// heals. φ is the damage from the start of the step (the damage system runs after this one).
// The symmetric predicate is evaluated in i's loop for bond k and in j's loop for its mirror; it is
// computed from the pair (lower index, higher index) in the same operation order from both ends, so
// both loops get the same bits and each writes only its own alive[k]: no atomics, no dependence on
// thread count or visiting order.
// Reads:  position, plastic_extension, damage, bond_alive.   Writes: bond_alive.
// Runs at the end of the step (after kick_end), only when world.any_fracture.
#include <cmath>

#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {

bool bond_breaks(const WorldState& w, const std::vector<Vec3>& y, std::uint32_t owner, std::uint32_t k) {
  const Bonds& b = w.bonds;
  const auto& p = w.particles;
  const auto& materials = w.scene.materials;
  const std::uint32_t m = b.reverse[k];
  // Canonical orientation: (lo, hi) particles and (k_lo, k_hi) = bonds lo→hi and hi→lo.
  std::uint32_t i = owner;
  std::uint32_t j = b.neighbor[k];
  std::uint32_t k_lo = k, k_hi = m;
  if (j < i) std::swap(i, j), std::swap(k_lo, k_hi);
  const double len = (y[j] - y[i]).norm();
  const double r = b.reference_length[k_lo];
  const double e = len - r;
  if (!(e > 0.0)) return false;  // compression (or NaN-free rest) never breaks
  auto exceeds = [&](std::uint32_t bond, std::uint32_t particle) {
    const auto& mat = materials[p.material_id[particle]];
    const double s_c = mat.critical_stretch;
    if (!std::isfinite(s_c)) return false;
    const double plastic = w.any_plastic ? b.plastic_extension[bond] : 0.0;
    const double measure = (e - plastic) / r / b.weight[bond];
    const double threshold = (1.0 + mat.damage_alpha * w.state.damage[particle]) * s_c;
    return measure > threshold;
  };
  const bool lo_breaks = exceeds(k_lo, i);
  const bool hi_breaks = exceeds(k_hi, j);
  return lo_breaks || hi_breaks;
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
          {Component::position, Component::plastic_extension, Component::damage, Component::bond_alive},
          {Component::bond_alive},
          [&w] { update_fracture(w, w.particles.position); }};
}

}  // namespace perifx::systems
