// The penalty contact law, written once for particle–particle contact (contact.cpp) and
// projectile–particle contact (projectiles.cpp): a linear spring on the overlap, a dashpot on the
// normal relative velocity (a fraction of critical damping of that spring on the pair's reduced
// mass), and Coulomb friction capped so that it cannot reverse the sliding within one step.
// (The kinematic colliders, colliders.cpp, resolve contact by projection instead: a different law.)
//
//   f_n = max(0, k g − c v_n),   c = 2ζ √(k m),   v_n = v · n
//   f_t = min(μ f_n, ¼ m |v_t| / dt)  along v_t = v − v_n n
// with g the overlap (m, > 0 in contact), n the unit contact normal, v the relative velocity (m/s),
// k the stiffness (N/m), m the reduced mass (kg), ζ the damping ratio, μ the friction coefficient.
// Sign convention: n and v are such that v_n < 0 while the two approach, so the dashpot adds to the
// push while closing and may cancel it while separating (never pulls: the max).
// The caller applies the result along its own n and v_t (see ContactForce), which keeps each call
// site's exact sequence of IEEE operations (the build uses -ffp-contract=off), so the shared law
// gives the same bits the separate copies gave.
// The stiffness is k = stiffness_factor·m/τ_k², τ_k = max(τ, dt) (contact_stiffness_per_mass below): τ
// the scene's contact time scale, set once at set-up (engine/setup/world_setup.cpp,
// allowed_time_step), so the contact does not stiffen or soften when only the step changes;
// the step takes over only where it is longer than τ, which keeps one spring's (ω dt)² ≤ 2·factor.
// Inline: it runs inside the contact loops.
#pragma once
#include <algorithm>
#include <cmath>

#include "components/math.hpp"

namespace perifx::systems {

struct ContactForce {
  double normal = 0.0;                // f_n ≥ 0, N: pushes the bodies apart along n
  Vec3 friction = Vec3::Zero();       // f_t v_t/|v_t|, N: along the sliding v_t (oppose it: subtract
                                      // from the force on the body whose velocity v is)
  bool sliding = false;               // friction is non-zero-length (μ > 0 and |v_t| > 0)
};

// k/m = 1/max(τ, dt)², 1/s²: the spring per kg of the lighter (or the particle's) mass, before the factor.
// τ = 0 (no time scale: a world built without one) gives the step's 1/dt².
inline double contact_stiffness_per_mass(double time_scale, double dt) {
  const double tau = std::max(time_scale, dt);
  return 1.0 / (tau * tau);
}

inline ContactForce contact_force(double overlap, const Vec3& normal, const Vec3& relative_velocity,
                                  double stiffness, double reduced_mass, double damping_ratio, double friction,
                                  double inv_dt) {
  ContactForce out;
  const double damp = 2.0 * damping_ratio * std::sqrt(stiffness * reduced_mass);
  const double vn = relative_velocity.dot(normal);
  out.normal = std::max(0.0, stiffness * overlap - damp * vn);
  if (friction > 0.0) {
    const Vec3 vt = relative_velocity - vn * normal;
    const double vt_len = vt.norm();
    if (vt_len > 0.0) {
      const double ft = std::min(friction * out.normal, 0.25 * reduced_mass * vt_len * inv_dt);
      out.friction = (ft / vt_len) * vt;
      out.sliding = true;
    }
  }
  return out;
}

}  // namespace perifx::systems
