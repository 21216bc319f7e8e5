// External load system: the body force b of Eq 1 and the scene's loads (systems/README.md §8.1, §8.6).
//   gravity:         f_i = m_i g
//   body_force:      f_i += r̄ m_i a   or  r̄ V_i f                                  (acceleration / N/m³)
//   noise:           f_i += r̄ (m_i or V_i) A N((y_i − speed t d)/L)  (value noise, components in [−1, 1])
//   traction:        f_i += r̄ T Σ_faces a_f (n_f or d)                 (boundary faces of particle i)
//   blast:           f_i −= Σ_faces facing c  P (R/max(r, R))^k ḡ_f a_f n_f,  r = |c − (y_i + o_f)|
//   radial_impulse:  the same with P = 2I/τ (τ > 0), or an impulse I delivered in the step holding it
//   directional:     f_i += r̄ Σ_faces with n_f·u < 0  (c1 + c2|u|) a_f (−n_f·û) u,  u = U − v_i
// r̄ is the mean of the time window (and ḡ of window × pulse) over the time this step's force stands
// for in velocity Verlet, [t − dt/2, t + dt/2] with t = (step + 1) dt (at setup: [0, dt/2]), so a
// load's impulse is exact for any dt and its ramp is followed exactly (the mean of a linear ramp over
// a symmetric interval is its midpoint value).
// Reads: time, position (surface points, noise), velocity (wind); nothing without scene loads.
// Writes: external_force.
// Each load is one pass over its own particle list, in scene order, every particle written by one
// task: the sum has a fixed order for any thread count. No allocation: lists are set at setup
// (engine/setup/loads.cpp).
#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "parallel.hpp"
#include "systems.hpp"
#include "value_noise.hpp"

namespace perifx::systems {
namespace {

using Kind = scene::Load::Kind;

double window_value(const scene::TimeWindow& w, double t) {
  if (t < w.start || t >= w.end) return 0.0;
  if (w.ramp <= 0.0) return 1.0;
  return std::min(1.0, (t - w.start) / w.ramp);
}

// A load's strength over time: its window, times a triangular pulse 1 − s/τ on [arrival, arrival + τ)
// when `pulse` is set. Piecewise polynomial of degree ≤ 2 between its breakpoints.
struct Profile {
  const scene::TimeWindow* window;
  bool pulse = false;
  double arrival = 0.0, duration = 0.0;

  double value(double t) const {
    double v = window_value(*window, t);
    if (pulse) {
      const double s = t - arrival;
      v *= (s >= 0.0 && s < duration) ? 1.0 - s / duration : 0.0;
    }
    return v;
  }

  // Mean over [a, b]: split at the breakpoints, two-point Gauss on each piece (exact for the
  // quadratics the pieces are; it never evaluates at a breakpoint, where the value jumps).
  double mean(double a, double b) const {
    std::array<double, 7> pts{};
    int m = 0;
    pts[static_cast<std::size_t>(m++)] = a;
    const std::array<double, 5> cuts{window->start, window->start + window->ramp, window->end,
                                     pulse ? arrival : a, pulse ? arrival + duration : a};
    for (double c : cuts) {  // insertion keeps pts sorted (at most 5 cuts)
      if (!(c > a && c < b)) continue;
      std::size_t k = static_cast<std::size_t>(m++);
      for (; k > 1 && pts[k - 1] > c; --k) pts[k] = pts[k - 1];
      pts[k] = c;
    }
    pts[static_cast<std::size_t>(m++)] = b;
    const double g = 0.5 / std::sqrt(3.0);
    double sum = 0.0;
    for (int k = 0; k + 1 < m; ++k) {
      const double lo = pts[static_cast<std::size_t>(k)], hi = pts[static_cast<std::size_t>(k + 1)];
      const double w = hi - lo;
      if (!(w > 0.0)) continue;
      const double mid = 0.5 * (lo + hi);
      sum += 0.5 * w * (value(mid - g * w) + value(mid + g * w));
    }
    return sum / (b - a);
  }
};

// The noise load's field: three independent value-noise components (value_noise.hpp), each in [−1, 1].
Vec3 noise_field(const Vec3& q, std::uint64_t seed) {
  return Vec3(value_noise(q, seed * 3), value_noise(q, seed * 3 + 1), value_noise(q, seed * 3 + 2));
}

// The force of one load, added to out for its particles.
void apply_load(const WorldState& w, std::size_t l, double t, double a, double b, std::vector<Vec3>& out) {
  const scene::Load& load = w.loads.loads[l];
  const auto& list = w.loads.particles[l];
  const auto& offsets = w.loads.patch_offsets[l];
  const auto& chosen = w.loads.patches[l];
  const auto& p = w.particles;
  const auto& surf = w.surface;
  const Profile window{&load.window};
  const double r = window.mean(a, b);
  const std::size_t grain = 1024;
  switch (load.kind) {
    case Kind::body_force:
    case Kind::noise: {
      if (r == 0.0) return;
      const Vec3 drift = load.speed * t * load.direction;
      const double inv_l = 1.0 / load.feature_size;
      parallel_for_each(list.size(), [&](std::size_t k) {
        const auto i = list[k];
        const double scale = r * (load.per_volume ? p.volume[i] : p.mass[i]);
        if (load.kind == Kind::body_force) {
          out[i] += scale * load.vector;
        } else {
          out[i] += (scale * load.magnitude) * noise_field((p.position[i] - drift) * inv_l, load.seed);
        }
      }, grain);
      return;
    }
    case Kind::traction: {
      if (r == 0.0) return;
      const double stress = r * load.magnitude;
      parallel_for_each(list.size(), [&](std::size_t k) {
        Vec3 f = Vec3::Zero();
        for (std::uint32_t q = offsets[k]; q < offsets[k + 1]; ++q) {
          const auto patch = chosen[q];
          f += surf.area[patch] * (load.along_normal ? surf.normal[patch] : load.direction);
        }
        out[list[k]] += stress * f;
      }, grain);
      return;
    }
    case Kind::directional: {
      if (r == 0.0) return;
      parallel_for_each(list.size(), [&](std::size_t k) {
        const auto i = list[k];
        const Vec3 u = load.vector - p.velocity[i];
        const double speed = u.norm();
        if (!(speed > 0.0)) return;
        double exposed = 0.0;  // projected area facing the relative wind
        for (std::uint32_t q = offsets[k]; q < offsets[k + 1]; ++q) {
          const auto patch = chosen[q];
          const double facing = -surf.normal[patch].dot(u) / speed;
          if (facing > 0.0) exposed += surf.area[patch] * facing;
        }
        out[i] += (r * (load.drag + load.quadratic_drag * speed) * exposed) * u;
      }, grain);
      return;
    }
    case Kind::blast:
    case Kind::radial_impulse: {
      const bool delta = load.kind == Kind::radial_impulse && load.duration == 0.0;
      const double peak = load.kind == Kind::blast ? load.magnitude
                          : delta                  ? load.magnitude / (b - a)
                                                   : 2.0 * load.magnitude / load.duration;
      const bool instant = !std::isfinite(load.front_speed);
      // With an instantaneous front every face shares one strength (the common case).
      const auto strength = [&](double arrival) {
        if (delta) return (arrival >= a && arrival < b) ? window_value(load.window, arrival) : 0.0;
        const Profile pulse{&load.window, true, arrival, load.duration};
        return pulse.mean(a, b);
      };
      const double shared = instant ? strength(load.window.start) : 0.0;
      if (instant && shared == 0.0) return;
      parallel_for_each(list.size(), [&](std::size_t k) {
        const auto i = list[k];
        Vec3 f = Vec3::Zero();
        for (std::uint32_t q = offsets[k]; q < offsets[k + 1]; ++q) {
          const auto patch = chosen[q];
          const Vec3 to_center = load.center - (p.position[i] + surf.offset[patch]);
          if (!(surf.normal[patch].dot(to_center) > 0.0)) continue;  // faces away from the blast
          const double dist = to_center.norm();
          if (dist > load.cutoff) continue;
          const double g = instant ? shared : strength(load.window.start + dist / load.front_speed);
          if (g == 0.0) continue;
          const double decay = dist > load.radius ? std::pow(load.radius / dist, load.falloff) : 1.0;
          f -= (peak * g * decay * surf.area[patch]) * surf.normal[patch];
        }
        out[i] += f;
      }, grain);
      return;
    }
  }
}

}  // namespace

void compute_external_force(WorldState& w, double t, double a, double b) {
  const Vec3 g = w.settings.gravity;
  const auto& mass = w.particles.mass;
  auto& out = w.state.external_force;
  parallel_for_each(w.particles.count(), [&](std::size_t i) { out[i] = mass[i] * g; }, 4096);
  for (std::size_t l = 0; l < w.loads.loads.size(); ++l) apply_load(w, l, t, a, b, out);
}

SystemDecl external_load_system(WorldState& w) {
  // Gravity alone reads nothing that changes during a step, so the scheduler runs it alongside the
  // peridynamic chain; scene loads read the clock, the drifted positions and the half-step velocities.
  std::vector<Component> reads;
  if (!w.loads.loads.empty()) reads = {Component::time, Component::position, Component::velocity};
  return {"external_loads",
          std::move(reads),
          {Component::external_force},
          [&w] {
            // The force at the end of the step, t = (step + 1) dt, standing for [t − dt/2, t + dt/2];
            // the bounds come from the step index so consecutive steps tile time without gaps.
            const double dt = w.clock.dt;
            const auto step = static_cast<double>(w.clock.step);
            compute_external_force(w, (step + 1.0) * dt, (step + 0.5) * dt, (step + 1.5) * dt);
          }};
}

}  // namespace perifx::systems
