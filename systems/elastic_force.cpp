// Elastic (and elastoplastic) force system: Eq 2–4, 8, 10, 12, paired as in notes.md:
//   f_i = V_i Σ_j ½ (A_ij + A_ji) n_ij V_j,
//   A_ij = ω_ij (Λ_ij P_i + b4_i (e_ij − e^p_ij)),   P_i = (a4_i − b4_i β_i) θ_i,
// which is A_dil + A_dev of Eq 4 and Eq 12 (Eq 8 when e^p = 0) with a4 = 4a, b4 = 4b, β = δ/4.
// e_ji = e_ij and Λ_ji = Λ_ij, so A_ji needs only P_j, b4_j and, with anisotropy or plasticity,
// the mirror bond's ω_ji and e^p_ji. Each particle gathers its own sum (no scatter, no atomics):
// the result is independent of thread count, and pair forces are equal and opposite to round-off.
// Reads:  position, dilatation, plastic_extension, bond_alive.   Writes: internal_force.
#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {
namespace {

template <bool kAnisotropic, bool kPlastic>
void force_kernel(const WorldState& w, const std::vector<Vec3>& y, const std::vector<double>& coupling,
                  std::vector<Vec3>& force) {
  const Bonds& b = w.bonds;
  const auto& x = w.particles.reference_position;
  const auto& volume = w.particles.volume;
  const auto& b4 = w.model.b4;
  parallel_for_each(w.particles.count(), [&](std::size_t i) {
    const Vec3 yi = y[i], xi = x[i];
    const double p_i = coupling[i], b4_i = b4[i];
    Vec3 f = Vec3::Zero();
    for (std::uint32_t k = b.offsets[i], end = b.offsets[i + 1]; k < end; ++k) {
      if (!b.alive[k]) continue;
      const std::uint32_t j = b.neighbor[k];
      const Vec3 dy = y[j] - yi;
      const double len = dy.norm();
      if (!(len > 0.0)) continue;  // coincident particles: no direction, no force
      const double inv_len = 1.0 / len;
      const double r = b.reference_length[k];
      const double e = len - r;
      const double lambda = dy.dot(x[j] - xi) * inv_len / r;
      const double w_ij = b.weight[k];
      double e_ij = e, e_ji = e;
      double w_ji = w_ij;
      if constexpr (kAnisotropic || kPlastic) {
        const std::uint32_t m = b.reverse[k];
        if constexpr (kAnisotropic) w_ji = b.weight[m];
        if constexpr (kPlastic) {
          e_ij -= b.plastic_extension[k];
          e_ji -= b.plastic_extension[m];
        }
      }
      const double a_ij = w_ij * (lambda * p_i + b4_i * e_ij);
      const double a_ji = w_ji * (lambda * coupling[j] + b4[j] * e_ji);
      f += (0.5 * (a_ij + a_ji) * volume[j] * inv_len) * dy;
    }
    force[i] = volume[i] * f;
  }, 256);
}

}  // namespace

void compute_internal_force(const WorldState& w, const std::vector<Vec3>& y, const std::vector<double>& coupling,
                            std::vector<Vec3>& force) {
  if (w.any_anisotropic) {
    if (w.any_plastic) force_kernel<true, true>(w, y, coupling, force);
    else force_kernel<true, false>(w, y, coupling, force);
  } else {
    if (w.any_plastic) force_kernel<false, true>(w, y, coupling, force);
    else force_kernel<false, false>(w, y, coupling, force);
  }
}

SystemDecl elastic_force_system(WorldState& w) {
  return {"elastic_force",
          {Component::position, Component::dilatation, Component::plastic_extension, Component::bond_alive},
          {Component::internal_force},
          [&w] { compute_internal_force(w, w.particles.position, w.state.dilatation_coupling, w.state.internal_force); }};
}

}  // namespace perifx::systems
