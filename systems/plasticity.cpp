// Plasticity system: Eq 11–16 with the consistent return of notes.md ("Plasticity — one decision").
// Per directed alive bond k = i→j (e^p_ij is a state of particle i on that bond):
//   e      = |y_j − y_i| − |ξ|,   Λ = n_ij · ξ/|ξ|                              (Eq 7, as in dilatation)
//   A_dev  = ω_ij b4_i (e − β_i Λ θ_i − e^p_ij)  = 4 ω b (e^d − e^p)            (Eq 12, trial)
//   f      = A_dev²/2 − Ψ0                                                      (Eq 13)
//   f > 0: A_c = √(2Ψ0) sign(A_dev),  Δe^p = (A_dev − A_c)/(ω_ij b4_i)         (Eq 14–15, consistent)
//   e^p   ← (e^p + Δe^p)·min(1, γ/|e^p + Δe^p|),  γ = plastic_cap_ratio·|ξ|   (Eq 16)
// Ψ0 = ∞ (material of particle i) means purely elastic: the bond is skipped. Each bond is updated in
// place by its own particle's loop only, so the result does not depend on thread count.
// Reads:  position, dilatation, bond_alive.   Writes: plastic_extension.
// Scheduled after dilatation and before elastic_force, only when world.any_plastic.
#include <cmath>

#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {

void update_plastic_extension(WorldState& w, const std::vector<Vec3>& y, const std::vector<double>& theta) {
  Bonds& b = w.bonds;
  const auto& x = w.particles.reference_position;
  const auto& md = w.model;
  const auto& materials = w.scene.materials;
  const auto& material_id = w.particles.material_id;
  parallel_for_each(w.particles.count(), [&](std::size_t i) {
    const auto& mat = materials[material_id[i]];
    const double psi0 = mat.yield_energy;
    if (!std::isfinite(psi0)) return;  // purely elastic material
    const double a_c = std::sqrt(2.0 * psi0);
    const double cap_ratio = mat.plastic_cap_ratio;
    const Vec3 yi = y[i], xi = x[i];
    const double b4_i = md.b4[i], beta_theta = md.beta[i] * theta[i];
    for (std::uint32_t k = b.offsets[i], end = b.offsets[i + 1]; k < end; ++k) {
      if (!b.alive[k]) continue;
      const std::uint32_t j = b.neighbor[k];
      const Vec3 dy = y[j] - yi;
      const double len = dy.norm();
      if (!(len > 0.0)) continue;  // collapsed bond: no direction, no force, no plastic flow
      const double r = b.reference_length[k];
      const double e = len - r;
      const double lambda = dy.dot(x[j] - xi) / (len * r);
      const double stiffness = b.weight[k] * b4_i;  // ω_ij b4_i
      double ep = b.plastic_extension[k];
      const double a_dev = stiffness * (e - beta_theta * lambda - ep);
      if (0.5 * a_dev * a_dev <= psi0) continue;  // inside the yield surface: elastic
      ep += (a_dev - std::copysign(a_c, a_dev)) / stiffness;
      const double cap = cap_ratio * r;
      if (std::abs(ep) > cap) ep = std::copysign(cap, ep);
      b.plastic_extension[k] = ep;
    }
  }, 256);
}

SystemDecl plasticity_system(WorldState& w) {
  return {"plasticity",
          {Component::position, Component::dilatation, Component::bond_alive},
          {Component::plastic_extension},
          [&w] { update_plastic_extension(w, w.particles.position, w.state.dilatation); }};
}

}  // namespace perifx::systems
