// The continuum per-bond yield law in uniaxial tension (yield_law.hpp; systems/README.md §12.2).
// Axisymmetric about the load axis, so a direction is its cosine c to the axis and dΩ = 2π dc; the
// loading is monotone, in small strain increments, each with the lateral strain solved (secant) and
// then every direction's plastic part returned to the cap (the same return as plastic_return).
// Reads and writes no component: setup-time and reporting arithmetic only.
#include "yield_law.hpp"

#include "perifx/math.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

namespace perifx::systems {

double offset_yield_ratio(double kappa, double mu, double flow_stress, double offset_strain) {
  if (!(kappa > 0.0 && mu > 0.0 && flow_stress > 0.0 && offset_strain > 0.0) || !std::isfinite(flow_stress))
    return std::numeric_limits<double>::quiet_NaN();
  const double youngs = youngs_modulus(kappa, mu), eps_y = flow_stress / youngs;
  const double s_c = std::sqrt(3.0) * flow_stress / (10.0 * mu);
  constexpr int kDirections = 2000;  // midpoints in c ∈ [−1, 1]
  std::array<double, kDirections> c2{}, p{};
  for (int k = 0; k < kDirections; ++k) {
    const double c = -1.0 + (k + 0.5) * 2.0 / kDirections;
    c2[k] = c * c;
  }
  const double weight = 7.5 * mu * 2.0 / kDirections;  // (15μ/4π) · 2π · dc
  // σ_xx, σ_yy for axial strain exx and lateral eyy; with `plastic`, the return is also applied to p.
  auto stresses = [&](double exx, double eyy, bool plastic) {
    const double tr = exx + 2.0 * eyy, a = exx - tr / 3.0, b = eyy - tr / 3.0;
    double sxx = kappa * tr, syy = kappa * tr;
    for (int k = 0; k < kDirections; ++k) {
      const double trial = a * c2[k] + b * (1.0 - c2[k]) - p[k];
      const double s = std::clamp(trial, -s_c, s_c);
      if (plastic) p[k] += trial - s;
      sxx += weight * s * c2[k];
      syy += weight * s * 0.5 * (1.0 - c2[k]);
    }
    return std::pair{sxx, syy};
  };
  const int increments = 3000;
  const double strain_max = 4.0 * eps_y + 2.0 * offset_strain;  // the offset line meets the curve before this
  double eyy = 0.0, prev_gap = 0.0, prev_stress = 0.0, youngs_line = youngs;
  for (int n = 1; n <= increments; ++n) {
    const double exx = strain_max * n / increments;
    for (int it = 0; it < 20; ++it) {  // σ_yy is piecewise linear in eyy: the secant settles in a few steps
      const double h = 1e-6 * eps_y;
      const double f0 = stresses(exx, eyy, false).second, f1 = stresses(exx, eyy + h, false).second;
      if (std::abs(f0) < 1e-12 * flow_stress || f1 == f0) break;
      eyy -= f0 * h / (f1 - f0);
    }
    const double sxx = stresses(exx, eyy, true).first;
    // The elastic line is the curve's own first (elastic) increment: the quadrature's modulus differs
    // from the exact E by ~1e-6, which would swamp a tiny offset.
    if (n == 1) youngs_line = sxx / exx;
    const double gap = sxx - youngs_line * (exx - offset_strain);  // curve minus the offset elastic line
    if (gap <= 0.0) {
      const double f = prev_gap / (prev_gap - gap);
      return (prev_stress + f * (sxx - prev_stress)) / flow_stress;
    }
    prev_gap = gap, prev_stress = sxx;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

double flow_stress_for_offset_yield(double kappa, double mu, double offset_yield, double offset_strain) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (!(kappa > 0.0 && mu > 0.0 && offset_yield > 0.0 && offset_strain > 0.0) || !std::isfinite(offset_yield)) return kNaN;
  // g(σ) = σ · ratio(σ) − Y, the offset stress of flow stress σ minus the target; increasing in σ.
  auto g = [&](double flow) { return flow * offset_yield_ratio(kappa, mu, flow, offset_strain) - offset_yield; };
  double lo = offset_yield, hi = offset_yield / (0.3 * std::sqrt(3.0)) * 1.01;  // g(lo) ≤ 0 ≤ g(hi)
  double g_lo = g(lo), g_hi = g(hi);
  if (!(g_lo <= 0.0 && g_hi >= 0.0)) return kNaN;
  if (g_lo == 0.0) return lo;
  int side = 0;  // which end stayed last time (Illinois: halve its value so the bracket closes from both sides)
  for (int it = 0; it < 100; ++it) {
    const double mid = (lo * g_hi - hi * g_lo) / (g_hi - g_lo), g_mid = g(mid);
    if (!std::isfinite(g_mid)) return kNaN;
    if (g_mid == 0.0 || hi - lo <= 1e-10 * mid) return mid;
    if (g_mid < 0.0) {
      lo = mid, g_lo = g_mid;
      if (side == -1) g_hi *= 0.5;
      side = -1;
    } else {
      hi = mid, g_hi = g_mid;
      if (side == 1) g_lo *= 0.5;
      side = 1;
    }
    if (std::abs(g_mid) <= 1e-10 * offset_yield) return mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace perifx::systems
