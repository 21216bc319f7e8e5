// Dilatation system: Eq 6 (θ_i) with Eq 5/17 weights and Eq 7 stretch.
//   θ_i = c_i Σ_k ω_ik s_ik (n_ik · ξ_ik) V_k = c_i Σ_k ω_ik e_ik Λ_ik V_k,
// c_i = 9/(4πδ⁴) (paper) or 3/m_i (discrete normalization, see model_constants.cpp), and
// ω_ik = δ̃_i/ℓ_ik with the `corrected` model's influence ramp (ramped_horizon, bond_rules.hpp).
// Also P_i = (a4_i − b4_i β_i) θ_i, the dilatational factor of Eq 4 + Eq 8 that the force needs
// from both ends of a bond, so the force pass gathers one number per neighbour instead of four.
// Reads:  position, bond_alive.   Writes: dilatation (θ and P).
#include "bond_gather.hpp"
#include "bond_rules.hpp"
#include "parallel.hpp"
#include "field_registry.hpp"
#include "systems.hpp"

namespace perifx::systems {

void compute_dilatation(const WorldState& w, const std::vector<Vec3>& y_vec, std::vector<double>& theta,
                        std::vector<double>& coupling) {
  const auto bs = bond_streams(w, y_vec);
  const auto& md = w.model;
  const InfluenceRamp ramp = influence_ramp(w);
  dispatch_flags([&](auto aniso) {
    constexpr bool kAnisotropicWorld = decltype(aniso)::value;
    parallel_for_each(w.particles.count(), [&](std::size_t i) {
      // Either form gives the same bits for an isotropic particle (ℓ = |ξ| exactly for M = I); the
      // isotropic one skips the weighted length.
      // Its ℓ is i's side only, so a shared-metric row is the general form (kReadsFarMetric false).
      dispatch_row<kAnisotropicWorld, false>(w.model.anisotropic_family, i, [&](auto row_form) {
        constexpr bool kAnisotropic = decltype(row_form)::value;
        const auto o = bs.origin(i);
        const AnisotropyMetric& g_i = bs.template anisotropy<kAnisotropic>(i);
        const double delta_i = md.horizon[i];
        double sum[kBondLanes] = {};
        ChunkPositions c;  // the chunk's far ends (bond_gather.hpp)
        auto gather = [&](std::size_t k, int n) { gather_positions(bs.y, bs.reference, bs.neighbor + k, n, c); };
        // Lane-strided so that the bond loop runs as SIMD with a fixed summation order (bond_rules.hpp).
        // ω e Λ = (δ̃_i/ℓ)(|y_j−y_i| − |ξ|)(y_j−y_i)·ξ/(|y_j−y_i| |ξ|): one division per bond. A
        // collapsed bond has no direction.
        auto lane = [=, &sum, &g_i, &c](std::size_t, int l, std::uint64_t is_alive) {
          const double dyx = c.yx[l] - o.yx, dyy = c.yy[l] - o.yy, dyz = c.yz[l] - o.yz;
          const double dxx = c.xx[l] - o.xx, dxy = c.xy[l] - o.xy, dxz = c.xz[l] - o.xz;
          const double r = reference_length(dxx, dxy, dxz);
          const double ell = weighted_length<kAnisotropic>(g_i, r, dxx, dxy, dxz);
          const double dot = dyx * dxx + dyy * dxy + dyz * dxz;
          const double len = std::sqrt(dyx * dyx + dyy * dyy + dyz * dyz);
          const double term = ramped_horizon(delta_i, r, ramp) * (len - r) * dot * c.v[l] / (len * r * ell);
          sum[l] += (is_alive != 0) & (len > 0.0) ? term : 0.0;
        };
        for_each_gathered_bond_lane(bs.offsets[i], bs.offsets[i + 1], bs.alive, gather, lane, [](std::size_t, int) {},
                                    DeadChunks::skip);
        const double th = md.dilatation_scale[i] * sum_lanes(sum);
        theta[i] = th;
        coupling[i] = dilatation_coupling(md, i, th);
      });
    });
  }, w.any_anisotropic);
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
