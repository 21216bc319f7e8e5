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

}  // namespace perifx::systems
