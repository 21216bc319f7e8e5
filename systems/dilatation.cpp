// Dilatation system: Eq 6 (θ_i) with Eq 5/17 weights and Eq 7 stretch.
//   θ_i = c_i Σ_k ω_ik s_ik (n_ik · ξ_ik) V_k = c_i Σ_k ω_ik e_ik Λ_ik V_k,
// c_i = 9/(4πδ⁴) (paper) or 3/m_i (discrete normalization, see model_constants.cpp).
// Also P_i = (a4_i − b4_i β_i) θ_i, the dilatational factor of Eq 4 + Eq 8 that the force needs
// from both ends of a bond, so the force pass gathers one number per neighbour instead of four.
// Reads:  position, bond_alive.   Writes: dilatation (θ and P).
#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {

void compute_dilatation(const WorldState& w, const std::vector<Vec3>& y, std::vector<double>& theta,
                        std::vector<double>& coupling) {
  const Bonds& b = w.bonds;
  const auto& x = w.particles.reference_position;
  const auto& volume = w.particles.volume;
  const auto& md = w.model;
  parallel_for_each(w.particles.count(), [&](std::size_t i) {
    const Vec3 yi = y[i], xi = x[i];
    double sum = 0.0;
    for (std::uint32_t k = b.offsets[i], end = b.offsets[i + 1]; k < end; ++k) {
      if (!b.alive[k]) continue;
      const std::uint32_t j = b.neighbor[k];
      const Vec3 dy = y[j] - yi;
      const double len = dy.norm();
      const double r = b.reference_length[k];
      // e·Λ = (|y_j−y_i| − |ξ|) · (y_j−y_i)·ξ / (|y_j−y_i| |ξ|); a collapsed bond has no direction.
      const double e_lambda = len > 0.0 ? (len - r) * dy.dot(x[j] - xi) / (len * r) : 0.0;
      sum += b.weight[k] * e_lambda * volume[j];
    }
    const double th = md.dilatation_scale[i] * sum;
    theta[i] = th;
    coupling[i] = (md.a4[i] - md.b4[i] * md.beta[i]) * th;
  });
}

SystemDecl dilatation_system(WorldState& w) {
  return {"dilatation",
          {Component::position, Component::bond_alive},
          {Component::dilatation},
          [&w] { compute_dilatation(w, w.particles.position, w.state.dilatation, w.state.dilatation_coupling); }};
}

}  // namespace perifx::systems
