// Per-particle model constants (setup). Eq 6 (θ scale), Eq 10 (a, b) and Eq 9 (β = δ/4), or their
// discrete normalization (systems/README.md §2.4): with the particle's own family sums
//   m_i = Σ_j ω_ij |ξ_ij| V_j,   q_i = Σ_j ω_ij |ξ_ij|² V_j,
// θ_i = (3/m_i) Σ ω e Λ V gives θ = 3ε for a uniform stretch ε exactly, and
//   a = 3κ/(2 m_i),  β = q_i/(3 m_i)
// make the virial stress of a uniform dilatation exactly 3κε with no deviatoric part, and
//   b = μ / (2 M̄_i),  M̄_i = ⅓ (M_xy + M_yz + M_zx),  M_ab = Σ_j ω_ij ξ_a² ξ_b² / |ξ|² V_j
// makes the mean response to the three axis shears μγ. For an isotropic family M_ab = q/15, i.e.
// b = 15μ/(2q); lattice families (e.g. the structured mesher's six tet types) deviate from that by
// several percent per direction, which the fourth moments capture and q alone does not. In the continuum (ω = δ/r, full ball) m = 4πδ⁴/3 and q = πδ⁵, which gives
// back the paper's constants exactly.
//
// Physical fracture and yield parameters (systems/README.md §12), converted here for each particle's
// horizon δ (so one scene breaks and yields alike at any resolution):
//   G_c → s_c = √(G_c / (C K δ)),  K = 5μ + (81/80)(κ − 5μ/3)  (energy of the bonds crossing a unit
//         area when each is at the break extension s_c δ; C = kFractureEnergyFactor, measured; §12.1)
//   σ_y → A_c = √(2Ψ0) = σ_y / S_i,  S_i = ½ Σ_j |3 c_a² − 1|/2 |ξ| V_j (mean over axes a, c_a = ξ_a/|ξ|)
//         (flow stress of the per-bond return under sustained uniaxial plastic flow; §12.2); in the
//         continuum S = πδ⁴/(3√3) and, with the paper's b, Y = A_c/(b4 δ) = √3 σ_y/(10 μ).
//         `corrected` multiplies A_c by the surface fill to the power 0.3 (kSurfaceExponents.yield).
// Reads:  bonds (neighbor; |ξ| and ω recomputed, bond_rules.hpp), particles.volume, particles.material_id,
//         model.horizon, scene materials.
// Writes: model.dilatation_scale, model.a4, model.b4, model.beta, model.damping and the material's
//         inelastic constants per particle (yield_extension = √(2Ψ0)/(b4 δ), plastic_cap, critical_stretch,
//         damage_alpha).
// pack_reference_points (set-up, before the families): model.reference_point, a copy of
// particles.reference_position and volume packed per particle for the bond kernels' gathers.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <vector>

#include "bond_rules.hpp"
#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {

namespace {
// `corrected` (§2.4): a particle whose family is cut by a free surface has its dilatational constant
// a, its deviatoric constant b and its dilatation scale c multiplied by min(1, m_i/m_body)^p, one exponent
// each. Calibrated against the converged continuum reference (assets/report/accuracy.md, issue 12.2):
// b's exponent sets torsion, a's the lateral contraction at high ν, c's at low ν; bending needs all
// three. One exponent for all three cannot fit bending and contraction at once.
// Calibrated with the influence ramp (bond_rules.hpp, §2.6) on: the ramp changes which bonds a cut
// family loses, so the exponents of the sharp cut (0.8, 0.285, 0.35) no longer apply.
struct SurfaceExponents {
  double bulk = 0.7;        // on a
  double shear = 0.5;       // on b
  double dilatation = 0.55; // on c, the θ scale
  double yield = 0.3;       // on A_c (σ_y → A_c, below): the flow stress of a gripped bar in tension
};
constexpr SurfaceExponents kSurfaceExponents{};
}

double critical_stretch_from_energy(double fracture_energy, double kappa, double mu, double horizon) {
  if (!std::isfinite(fracture_energy)) return kInfinity;
  const double k = 5.0 * mu + (81.0 / 80.0) * (kappa - 5.0 * mu / 3.0);  // > 0 for any κ, μ > 0
  return std::sqrt(fracture_energy / (kFractureEnergyFactor * k * horizon));
}

double yield_extension_from_stress(double yield_stress, double mu) {
  if (!std::isfinite(yield_stress)) return kInfinity;
  return std::sqrt(3.0) * yield_stress / (10.0 * mu);
}

void mark_anisotropic_families(WorldState& w) {
  auto& family = w.model.anisotropic_family;
  family.clear();
  if (!w.any_anisotropic) return;
  const auto& p = w.particles;
  const auto& b = w.bonds;
  const std::size_t n = p.count();
  std::uint32_t bodies = 0;
  for (std::size_t i = 0; i < n; ++i) bodies = std::max(bodies, std::uint32_t{p.body_id[i]} + 1);
  std::vector<std::uint8_t> by_body(bodies, 0);
  // Decided on the metric GᵀG, which is what the kernels read: a G ≠ I that is a rotation
  // (any_anisotropic set) has GᵀG = I and gives every bond its isotropic length.
  const auto& metric = w.model.anisotropy_metric;
  for (std::size_t i = 0; i < n; ++i) {
    const AnisotropyMetric& m = metric[i];
    if (!(m.xx == 1.0 && m.yy == 1.0 && m.zz == 1.0 && m.xy == 0.0 && m.xz == 0.0 && m.yz == 0.0)) by_body[p.body_id[i]] = 1;
  }
  // Bodies are joined by bonds only where a scene glues them; a flag crosses every such bond, until
  // none joins two different flags (at most one round per body). Usually no bond joins two bodies
  // with different flags: one parallel pass finds that.
  std::atomic<bool> mixed{false};
  parallel_for_each(n, [&](std::size_t i) {
    for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k)
      if (by_body[p.body_id[i]] != by_body[p.body_id[b.neighbor[k]]]) mixed.store(true, std::memory_order_relaxed);
  }, 4096);
  for (bool changed = mixed.load(); changed;) {
    changed = false;
    for (std::size_t i = 0; i < n; ++i)
      for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k) {
        std::uint8_t& a = by_body[p.body_id[i]];
        std::uint8_t& c = by_body[p.body_id[b.neighbor[k]]];
        if (a != c) a = c = 1, changed = true;
      }
  }
  // An anisotropic row whose every neighbour (broken bonds included: the rows only lose bonds) has
  // the particle's metric bit for bit takes the shared-metric form. Compared as bytes, so that a
  // −0.0 against a 0.0 is a difference.
  family.resize(n);
  parallel_for_each(n, [&](std::size_t i) {
    RowForm form = by_body[p.body_id[i]] ? RowForm::shared_metric : RowForm::isotropic;
    for (std::uint32_t k = b.offsets[i]; form == RowForm::shared_metric && k < b.offsets[i + 1]; ++k)
      if (std::memcmp(&metric[i], &metric[b.neighbor[k]], sizeof(AnisotropyMetric)) != 0) form = RowForm::anisotropic;
    family[i] = static_cast<std::uint8_t>(form);
  }, 4096);
}

void pack_reference_points(WorldState& w) {
  const auto& p = w.particles;
  auto& packed = w.model.reference_point;
  packed.resize(p.count());
  parallel_for_each(p.count(), [&](std::size_t i) {
    const Vec3& x = p.reference_position[i];
    packed[i] = ReferencePoint{x.x(), x.y(), x.z(), p.volume[i]};
  }, 4096);
}

void compute_model_constants(WorldState& w) {
  const std::size_t n = w.particles.count();
  auto& md = w.model;
  md.dilatation_scale.resize(n);
  md.a4.resize(n);
  md.b4.resize(n);
  md.beta.resize(n);
  md.damping.resize(n);
  md.yield_extension.resize(n);
  md.plastic_cap.resize(n);
  md.critical_stretch.resize(n);
  md.damage_alpha.resize(n);
  const bool discrete = w.settings.normalization != scene::Normalization::paper;
  // `corrected`: the discrete constants a, b, c scaled by powers of min(1, m_i / m_body), m_body the
  // weighted volume of a full interior family of the particle's body (below), §2.4.
  const bool corrected = w.settings.normalization == scene::Normalization::corrected;
  // The discrete normalization's family sums, in one pass over every family (read again below by
  // the fill reference and the constants): with wv = ω |ξ| V_j per bond, m = Σ wv, q = Σ wv |ξ| and the
  // shear moment Σ wv (ξx²ξy² + ξy²ξz² + ξz²ξx²)/(3|ξ|³) (systems/README.md §2.1). Shape: n each.
  std::vector<double> family_m, family_q, family_shear;
  if (discrete) {
    family_m.assign(n, 0.0);
    family_q.assign(n, 0.0);
    family_shear.assign(n, 0.0);
    parallel_for_each(n, [&](std::size_t i) {
      double m = 0.0, q = 0.0, shear_moment = 0.0;
      const Vec3& xi = w.particles.reference_position[i];
      for (std::uint32_t k = w.bonds.offsets[i]; k < w.bonds.offsets[i + 1]; ++k) {
        const std::uint32_t j = w.bonds.neighbor[k];
        const Vec3 bond = w.particles.reference_position[j] - xi;
        const double r = reference_length(bond);
        const double wv = bond_weight(w, i, bond) * r * w.particles.volume[j];
        m += wv;
        q += wv * r;
        const Vec3 s2 = bond.cwiseAbs2();
        shear_moment += wv * (s2.x() * s2.y() + s2.y() * s2.z() + s2.z() * s2.x()) / (3.0 * r * r * r);
      }
      family_m[i] = m;
      family_q[i] = q;
      family_shear[i] = shear_moment;
    });
  }
  std::vector<double> body_m;
  if (corrected) {
    // The reference is the largest *family-averaged* m of the body, not the largest m: on a jittered
    // or unstructured mesh the interior's m_i scatter by a few percent (random tet volumes and
    // distances, 1.4 % s.d. at jitter 0.3), so the largest single m sits several s.d. above a typical
    // complete family and every interior particle read as partly cut (fill ≈ 0.96, which took 3 % off
    // the interior's bulk and shear stiffness). The average over a family scatters about ten times
    // less; on a regular lattice, where complete families have equal m, it is that same m.
    std::vector<double> m_smooth(n, 0.0);
    parallel_for_each(n, [&](std::size_t i) {
      double sum = 0.0, weight = 0.0;
      for (std::uint32_t k = w.bonds.offsets[i]; k < w.bonds.offsets[i + 1]; ++k) {
        const std::uint32_t j = w.bonds.neighbor[k];
        const Vec3 xi = w.particles.reference_position[j] - w.particles.reference_position[i];
        const double wv = bond_weight(w, i, xi) * w.particles.volume[j];
        sum += wv * family_m[j];
        weight += wv;
      }
      m_smooth[i] = weight > 0.0 ? sum / weight : family_m[i];
    });
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t b = w.particles.body_id[i];
      if (body_m.size() <= b) body_m.resize(b + 1, 0.0);
      body_m[b] = std::max(body_m[b], m_smooth[i]);
    }
  }
  parallel_for_each(n, [&](std::size_t i) {
    const auto& mat = w.settings.materials[w.particles.material_id[i]];
    const double delta = md.horizon[i];
    const double kappa = mat.bulk_modulus, mu = mat.shear_modulus;
    double scale, a, b, beta, fill = 1.0;
    if (discrete) {
      const double m = family_m[i], q = family_q[i], shear_moment = family_shear[i];
      if (m > 0.0 && shear_moment > 0.0) {
        scale = 3.0 / m;
        a = 1.5 * kappa / m;
        beta = q / (3.0 * m);
        b = mu / (2.0 * shear_moment);
        if (corrected) {
          fill = std::min(1.0, m / body_m[w.particles.body_id[i]]);  // 1 inside, ≈ ½ on a face
          a *= std::pow(fill, kSurfaceExponents.bulk);
          b *= std::pow(fill, kSurfaceExponents.shear);
          scale *= std::pow(fill, kSurfaceExponents.dilatation);
        }
      } else {  // an isolated particle carries no elastic force
        scale = a = b = beta = 0.0;
      }
    } else {
      const double d4 = delta * delta * delta * delta;
      scale = 9.0 / (4.0 * kPi * d4);
      a = 9.0 * kappa / (8.0 * kPi * d4);
      b = 15.0 * mu / (2.0 * kPi * d4 * delta);
      beta = delta / 4.0;
    }
    md.dilatation_scale[i] = scale;
    md.a4[i] = 4.0 * a;
    md.b4[i] = 4.0 * b;
    md.beta[i] = beta;
    md.damping[i] = mat.damping;
    // Ψ0 = ∞ or b4 = 0 (an isolated particle) give ∞: never yields.
    if (mat.yield_stress > 0.0) {
      // A_c = σ_y / S_i with S_i = ½ Σ_j |3 (ξ_a/|ξ|)² − 1|/2 |ξ| V_j averaged over the axes a: the
      // family's own flow-stress sum (§12.2), which is πδ⁴/(3√3) in the continuum (Y = √3σ_y/(10μ)).
      // A bond's share is weighted by its partial volume δ̃/δ (the influence ramp, §2.6): a yielded
      // bond carries ±A_c, and the ramp scales how much of its neighbour's volume counts.
      double flow_sum = 0.0;
      const InfluenceRamp ramp = influence_ramp(w);
      const Vec3& xi = w.particles.reference_position[i];
      for (std::uint32_t k = w.bonds.offsets[i]; k < w.bonds.offsets[i + 1]; ++k) {
        const std::uint32_t j = w.bonds.neighbor[k];
        const double r = reference_length(w.particles.reference_position[j] - xi);
        const Vec3 c2 = (w.particles.reference_position[j] - xi).cwiseAbs2() / (r * r);
        flow_sum += (std::abs(3.0 * c2.x() - 1.0) + std::abs(3.0 * c2.y() - 1.0) + std::abs(3.0 * c2.z() - 1.0)) *
                    r * w.particles.volume[j] * (ramped_horizon(delta, r, ramp) / delta);
      }
      flow_sum /= 12.0;  // ½ · ½ · (mean of three axes)
      // `corrected`: a cut family's S_i counts only the bonds it keeps, so σ_y/S_i alone made the
      // surface layer flow above σ_y (a bar hardened 6–10 % by 10 ε_y, more the coarser it was);
      // fill^p, p calibrated on that bar (§12.2), makes the flow stress the same at every resolution.
      const double a_c = mat.yield_stress / flow_sum * std::pow(fill, kSurfaceExponents.yield);
      md.yield_extension[i] =
          b > 0.0 && flow_sum > 0.0 && std::isfinite(mat.yield_stress) ? a_c / (4.0 * b * delta) : kInfinity;
    } else {
      const double yield_ext = std::sqrt(2.0 * mat.yield_energy) / (4.0 * b * delta);
      md.yield_extension[i] = std::isnan(yield_ext) ? kInfinity : yield_ext;
    }
    md.plastic_cap[i] = mat.plastic_cap_ratio;
    md.critical_stretch[i] = mat.fracture_energy > 0.0
                                 ? critical_stretch_from_energy(mat.fracture_energy, kappa, mu, delta)
                                 : mat.critical_stretch;
    md.damage_alpha[i] = mat.damage_alpha;
  });
}

}  // namespace perifx::systems
