// Boundary condition system (systems/README.md §8.2, "What the paper leaves out": anchors, prescribed velocity or
// displacement on a region, with time ramps; needed by Fig. 3, 9, 12, 14, 17).
// Runs between kick_begin and drift and sets the velocity the drift will use:
//   anchor:        v = 0 (the particle holds its place)
//   velocity:      v = r(t)·(v0 + ω × (y − c(t))),  c(t) = c + v0·τ(t), τ = ∫ r dt  (a rigid motion)
//   displacement:  v = (x + u(t+dt) − y)/dt with u = r·(d + (R(r·angle) − I)(x − c)), exact target
// r(t) ramps 0→1 over `ramp` seconds after `start`; outside [start, end) the condition is released
// and the particles move freely with the velocity they have. Conditions apply in scene order, so the
// last one wins where regions overlap (per axis). A condition limited to some world axes (`axes`)
// writes only those velocity components and sets only their kPrescribed{X,Y,Z} bits; integration
// goes on kicking the others. Every particle is written by one task: deterministic.
// Reads: time, position, velocity.   Writes: velocity, flags.
#include <Eigen/Geometry>
#include <algorithm>

#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {
namespace {

bool active(const scene::TimeWindow& win, double t) { return t >= win.start && t < win.end; }

double strength(const scene::TimeWindow& win, double t) {
  if (win.ramp <= 0.0) return 1.0;
  return std::clamp((t - win.start) / win.ramp, 0.0, 1.0);
}

// The kPrescribed bits of the condition's axes.
std::uint8_t axis_bits(const scene::BoundaryCondition& bc) {
  return static_cast<std::uint8_t>((bc.axes[0] ? kPrescribedX : 0) | (bc.axes[1] ? kPrescribedY : 0) |
                                   (bc.axes[2] ? kPrescribedZ : 0));
}

// Writes the prescribed components of v into the particle's velocity and marks them.
inline void prescribe(Particles& p, std::uint32_t i, const Vec3& v, std::uint8_t bits) {
  if (bits == kPrescribed) {
    p.velocity[i] = v;
  } else {
    for (int a = 0; a < 3; ++a)
      if (bits & (kPrescribedX << a)) p.velocity[i][a] = v[a];
  }
  p.flags[i] |= bits;
}

// ∫_start^t strength(s) ds
double integrated_strength(const scene::TimeWindow& win, double t) {
  const double s = std::max(0.0, t - win.start);
  if (win.ramp <= 0.0) return s;
  if (s <= win.ramp) return 0.5 * s * s / win.ramp;
  return 0.5 * win.ramp + (s - win.ramp);
}

}  // namespace

SystemDecl boundary_condition_system(WorldState& w) {
  return {"boundary_conditions",
          {Component::time, Component::position},
          {Component::velocity, Component::flags},
          [&w] {
            auto& p = w.particles;
            const auto& set = w.boundary;
            const double dt = w.clock.dt;
            const double t_mid = w.clock.time + 0.5 * dt, t_end = w.clock.time + dt;
            parallel_for_each(set.constrained.size(), [&](std::size_t k) {
              p.flags[set.constrained[k]] &= static_cast<std::uint8_t>(~kPrescribed);
            }, 4096);
            for (std::size_t c = 0; c < set.conditions.size(); ++c) {
              const auto& bc = set.conditions[c];
              if (!active(bc.window, t_mid)) continue;
              const auto& list = set.particles[c];
              const std::uint8_t bits = axis_bits(bc);
              using Kind = scene::BoundaryCondition::Kind;
              if (bc.kind == Kind::anchor) {
                parallel_for_each(list.size(), [&](std::size_t k) {
                  prescribe(p, list[k], Vec3::Zero(), bits);
                }, 4096);
              } else if (bc.kind == Kind::velocity) {
                const double r = strength(bc.window, t_mid);
                const Vec3 center = bc.center + bc.velocity * integrated_strength(bc.window, w.clock.time);
                parallel_for_each(list.size(), [&](std::size_t k) {
                  const auto i = list[k];
                  prescribe(p, i, r * (bc.velocity + bc.angular_velocity.cross(p.position[i] - center)), bits);
                }, 4096);
              } else {
                const double r = strength(bc.window, t_end);
                const Mat3 rot_minus_i =
                    Eigen::AngleAxisd(r * bc.rotation_angle, bc.rotation_axis).toRotationMatrix() - Mat3::Identity();
                parallel_for_each(list.size(), [&](std::size_t k) {
                  const auto i = list[k];
                  const Vec3& x = p.reference_position[i];
                  const Vec3 target = x + r * bc.displacement + rot_minus_i * (x - bc.center);
                  prescribe(p, i, (target - p.position[i]) / dt, bits);
                }, 4096);
              }
            }
          }};
}

}  // namespace perifx::systems
