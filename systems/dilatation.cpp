// Dilatation system: Eq 6 (θ_i) with Eq 5/17 weights and Eq 7 stretch.
//   θ_i = c_i Σ_k ω_ik s_ik (n_ik · ξ_ik) V_k = c_i Σ_k ω_ik e_ik Λ_ik V_k,
// c_i = 9/(4πδ⁴) (paper) or 3/m_i (discrete normalization, see model_constants.cpp).
// Also P_i = (a4_i − b4_i β_i) θ_i, the dilatational factor of Eq 4 + Eq 8 that the force needs
// from both ends of a bond, so the force pass gathers one number per neighbour instead of four.
// Reads:  position, bond_alive.   Writes: dilatation (θ and P).
#include "bond_rules.hpp"
#include "parallel.hpp"
#include "field_registry.hpp"
#include "systems.hpp"

namespace perifx::systems {

void compute_dilatation(const WorldState& w, const std::vector<Vec3>& y_vec, std::vector<double>& theta,
                        std::vector<double>& coupling) {
  const Bonds& b = w.bonds;
  const std::uint32_t* const offsets = b.offsets.data();
  const std::uint32_t* const neighbor = b.neighbor.data();
  const double* const reference_length = b.reference_length.data();
  const double* const weight = b.weight.data();
  const std::uint8_t* const alive = b.alive.data();
  const double* const y = y_vec.data()->data();  // 3 doubles per particle
  const double* const x = w.particles.reference_position.data()->data();
  const double* const volume = w.particles.volume.data();
  const auto& md = w.model;
  parallel_for_each(w.particles.count(), [&](std::size_t i) {
    const double yix = y[3 * i], yiy = y[3 * i + 1], yiz = y[3 * i + 2];
    const double xix = x[3 * i], xiy = x[3 * i + 1], xiz = x[3 * i + 2];
    double sum[kBondLanes] = {};
    // Lane-strided so that the bond loop runs as SIMD with a fixed summation order (bond_rules.hpp).
    auto lane = [=, &sum](std::size_t k, int l, std::uint64_t is_alive) {
      const std::size_t j = neighbor[k];
      const double r = reference_length[k];
      const double dyx = y[3 * j] - yix, dyy = y[3 * j + 1] - yiy, dyz = y[3 * j + 2] - yiz;
      const double dot = dyx * (x[3 * j] - xix) + dyy * (x[3 * j + 1] - xiy) + dyz * (x[3 * j + 2] - xiz);
      const double len = std::sqrt(dyx * dyx + dyy * dyy + dyz * dyz);
      // e·Λ = (|y_j−y_i| − |ξ|) · (y_j−y_i)·ξ / (|y_j−y_i| |ξ|); a collapsed bond has no direction.
      const double e_lambda = (len - r) * dot / (len * r);
      const double term = weight[k] * e_lambda * volume[j];
      sum[l] += (is_alive != 0) & (len > 0.0) ? term : 0.0;
    };
    for_each_bond_lane(offsets[i], offsets[i + 1], alive, lane, [](std::size_t, int) {});
    const double th = md.dilatation_scale[i] * sum_lanes(sum);
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


void register_dilatation_fields(FieldRegistry& r) {
  r.push_back(make_field("dilatation", FieldType::f64, 1, "1", "θ (Eq 6)",
                         [](WorldState& w, FieldView& v) { view_array(v, w.state.dilatation); }));
}

}  // namespace perifx::systems
