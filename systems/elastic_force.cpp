// Elastic (and elastoplastic) force system: Eq 2–4, 8, 10, 12, paired as in systems/README.md §2.1:
//   f_i = V_i Σ_j ½ (A_ij + A_ji) n_ij V_j,
//   A_ij = ω_ij (Λ_ij P_i + b4_i (e_ij − e^p_ij)),   P_i = (a4_i − b4_i β_i) θ_i,
// which is A_dil + A_dev of Eq 4 and Eq 12 (Eq 8 when e^p = 0) with a4 = 4a, b4 = 4b, β = δ/4.
// e_ji = e_ij and Λ_ji = Λ_ij, so A_ji needs only P_j, b4_j, δ_j (ω_ji = δ̃_j/|G_j ξ|, recomputed
// like |ξ|: bond_rules.hpp) and, with plasticity, e^p_ji (Bonds::plastic_extension_mirror). Each particle gathers its
// own sum (no scatter, no atomics): the result is independent of thread count, and pair forces are
// equal and opposite to round-off. The per-bond rule is paired_force_density (bond_rules.hpp), shared
// with the fused bond pass and, through side_force_state, with the virial stress below.
// Reads:  position, dilatation, plastic_extension, bond_alive.   Writes: internal_force.
#include "bond_rules.hpp"
#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {
namespace {

// Visits every alive bond i→j of particle i with A_ij (side_force_state, the rule the force uses
// through paired_force_density), 1/|y_j − y_i| and y_j − y_i, for the virial stress.
template <bool kPlastic, class Sink>
inline void visit_bonds(const WorldState& w, const std::vector<Vec3>& y, const std::vector<double>& coupling,
                        std::size_t i, Sink&& sink) {
  const Bonds& b = w.bonds;
  const auto& x = w.particles.reference_position;
  const Vec3 yi = y[i], xi = x[i];
  const double p_i = coupling[i], b4_i = w.model.b4[i];
  for (std::uint32_t k = b.offsets[i], end = b.offsets[i + 1]; k < end; ++k) {
    if (!b.alive[k]) continue;
    const std::uint32_t j = b.neighbor[k];
    const Vec3 dy = y[j] - yi, dxi = x[j] - xi;
    BondGeometry g;
    if (!bond_geometry(dy, dxi, reference_length(dxi), g)) continue;
    const double ep = kPlastic ? double(b.plastic_extension[k]) : 0.0;
    const double a_ij = side_force_state<kPlastic>(g, bond_weight(w, i, dxi), ep, p_i, b4_i);
    sink(j, a_ij, g.inverse_length, dy);
  }
}

}  // namespace

void compute_internal_force(const WorldState& w, const std::vector<Vec3>& y_vec, const std::vector<double>& coupling,
                            std::vector<Vec3>& force) {
  // Lane-strided (bond_rules.hpp) with the same per-bond density and summation order as the fused
  // bond pass, so the two give the same bits.
  const auto bs = bond_streams(w, y_vec);
  const double* const volume = w.particles.volume.data();
  const double* const b4 = w.model.b4.data();
  const double* const p = coupling.data();
  const InfluenceRamp ramp = influence_ramp(w);
  double* const out = force.data()->data();
  dispatch_flags([&](auto aniso, auto plastic_on) {
    constexpr bool kAnisotropicWorld = decltype(aniso)::value, kPlastic = decltype(plastic_on)::value;
    parallel_for_each(w.particles.count(), [&](std::size_t i) {
      dispatch_row<kAnisotropicWorld>(w.model.anisotropic_family, i, [&](auto row_form) {  // as bond_pass.cpp
        constexpr bool kAnisotropic = decltype(row_form)::value, kSharedMetric = decltype(row_form)::shared_metric;
        const auto o = bs.origin(i);
        const double p_i = p[i], b4_i = b4[i], delta_i = bs.horizon[i];
        const AnisotropyMetric& g_i = bs.template anisotropy<kAnisotropic>(i);
        double fx[kBondLanes] = {}, fy[kBondLanes] = {}, fz[kBondLanes] = {};
        auto lane = [=, &fx, &fy, &fz, &g_i](std::size_t k, int l, std::uint64_t is_alive) {
          const std::size_t j = bs.neighbor[k];
          const double dyx = bs.y[3 * j] - o.yx, dyy = bs.y[3 * j + 1] - o.yy, dyz = bs.y[3 * j + 2] - o.yz;
          const double dxx = bs.x[3 * j] - o.xx, dxy = bs.x[3 * j + 1] - o.xy, dxz = bs.x[3 * j + 2] - o.xz;
          const double r = reference_length(dxx, dxy, dxz);
          BondGeometry g;
          const bool active = bond_geometry(dyx, dyy, dyz, dxx, dxy, dxz, r, g) & (is_alive != 0);
          const SideLengths weighted = side_lengths<kAnisotropic, kSharedMetric>(
              g_i, bs.template anisotropy<kAnisotropic && !kSharedMetric>(j), r, dxx, dxy, dxz);
          const double w_ij = force_weight<kAnisotropic>(ramped_horizon(delta_i, r, ramp), weighted.inverse_ij);
          const double w_ji = force_weight<kAnisotropic>(ramped_horizon(bs.horizon[j], r, ramp), weighted.inverse_ji);
          const double ep_ij = kPlastic ? double(bs.plastic[k]) : 0.0, ep_ji = kPlastic ? double(bs.plastic_mirror[k]) : 0.0;
          const double density = paired_force_density<kAnisotropic, kPlastic>(g, w_ij, w_ji, ep_ij, ep_ji, p_i, b4_i, p[j],
                                                                              b4[j], volume[j]);
          const double c = active ? density : 0.0;
          fx[l] += c * dyx;
          fy[l] += c * dyy;
          fz[l] += c * dyz;
        };
        for_each_bond_lane(bs.offsets[i], bs.offsets[i + 1], bs.alive, lane, [](std::size_t, int) {}, DeadChunks::skip);
        out[3 * i] = volume[i] * sum_lanes(fx);
        out[3 * i + 1] = volume[i] * sum_lanes(fy);
        out[3 * i + 2] = volume[i] * sum_lanes(fz);
      });
    }, 256);
  }, w.any_anisotropic, w.any_plastic);
}

void compute_virial_stress(const WorldState& w, const std::vector<Vec3>& y, const std::vector<double>& coupling,
                           std::vector<Mat3>& stress) {
  const auto& volume = w.particles.volume;
  const auto& x = w.particles.reference_position;
  stress.resize(w.particles.count());
  dispatch_flags([&](auto plastic) {
    parallel_for_each(w.particles.count(), [&](std::size_t i) {
      Mat3 s_i = Mat3::Zero();
      visit_bonds<decltype(plastic)::value>(
          w, y, coupling, i, [&](std::uint32_t j, double a_ij, double inv_len, const Vec3& dy) {
            s_i += (0.5 * a_ij * inv_len * volume[j]) * dy * (x[j] - x[i]).transpose();
          });
      stress[i] = s_i;
    }, 256);
  }, w.any_plastic);
}

SystemDecl elastic_force_system(WorldState& w) {
  return {"elastic_force",
          {Component::position, Component::dilatation, Component::plastic_extension, Component::bond_alive},
          {Component::internal_force},
          [&w] { compute_internal_force(w, w.particles.position, w.state.dilatation_coupling, w.state.internal_force); }};
}

// Elastic energy of the current state (systems/README.md): Σ_i V_i [k_i θ_i² + b_i Σ_j ω_ij (e_ij − e^p_ij)² V_j],
// k_i = (a_i − b_i β_i)/c_i, whose negative gradient is the paired force above (to first order in Λ).
// Used by World::diagnostics and the energy-conservation tests. FEM mode: the FEM energy.
double elastic_energy(const WorldState& w) {
  if (w.settings.solver != scene::Solver::peridynamics) return fem_elastic_energy(w, w.particles.position);
  const auto& b = w.bonds;
  const auto& p = w.particles;
  const auto& md = w.model;
  return deterministic_sum(p.count(), 0.0, [&](std::size_t i) {
    if (md.dilatation_scale[i] == 0.0) return 0.0;
    const double bb = 0.25 * md.b4[i], k = bulk_energy_coefficient(md, i);
    double bond_sum = 0.0;
    for (std::uint32_t q = b.offsets[i]; q < b.offsets[i + 1]; ++q) {
      if (!b.alive[q]) continue;
      const std::uint32_t j = b.neighbor[q];
      const Vec3 xi = p.reference_position[j] - p.reference_position[i];
      const double ep = w.any_plastic ? double(b.plastic_extension[q]) : 0.0;
      const double e = (p.position[j] - p.position[i]).norm() - reference_length(xi) - ep;
      bond_sum += bond_weight(w, i, xi) * e * e * p.volume[j];
    }
    const double th = w.state.dilatation[i];
    return p.volume[i] * (k * th * th + bb * bond_sum);
  });
}

}  // namespace perifx::systems
