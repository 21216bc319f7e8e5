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
  const auto bs = bond_streams(w.bonds, y_vec, w.particles.reference_position);
  const double* const volume = w.particles.volume.data();
  const auto& md = w.model;
  parallel_for_each(w.particles.count(), [&](std::size_t i) {
    const auto o = bs.origin(i);
    double sum[kBondLanes] = {};
    // Lane-strided so that the bond loop runs as SIMD with a fixed summation order (bond_rules.hpp).
    auto lane = [=, &sum](std::size_t k, int l, std::uint64_t is_alive) {
      const std::size_t j = bs.neighbor[k];
      const double r = bs.reference_length[k];
      const double dyx = bs.y[3 * j] - o.yx, dyy = bs.y[3 * j + 1] - o.yy, dyz = bs.y[3 * j + 2] - o.yz;
      const double dot =
          dyx * (bs.x[3 * j] - o.xx) + dyy * (bs.x[3 * j + 1] - o.xy) + dyz * (bs.x[3 * j + 2] - o.xz);
      const double len = std::sqrt(dyx * dyx + dyy * dyy + dyz * dyz);
      // e·Λ = (|y_j−y_i| − |ξ|) · (y_j−y_i)·ξ / (|y_j−y_i| |ξ|); a collapsed bond has no direction.
      const double e_lambda = (len - r) * dot / (len * r);
      const double term = bs.weight[k] * e_lambda * volume[j];
      sum[l] += (is_alive != 0) & (len > 0.0) ? term : 0.0;
    };
    for_each_bond_lane(bs.offsets[i], bs.offsets[i + 1], bs.alive, lane, [](std::size_t, int) {});
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
