// Seeded 3D value noise, the one noise of the runtime (noise loads in external_loads.cpp, strength
// noise in strength_field.cpp). A pseudo-random value in [−1, 1) sits at every integer lattice point
// (splitmix64 hash of the point and the seed: the same seed gives the same bits on any thread count
// and any platform with IEEE doubles); between points the eight corner values are blended with the
// quintic fade 6s⁵ − 15s⁴ + 10s³, so the field is C² smooth and its derivative vanishes at lattice
// points. The result stays in [−1, 1]: a convex combination of corner values.
#pragma once
#include <cmath>
#include <cstdint>

#include "perifx/math.hpp"

namespace perifx::systems {

inline std::uint64_t noise_hash(std::uint64_t z) {  // splitmix64 finalizer
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

inline double noise_lattice_value(std::int64_t x, std::int64_t y, std::int64_t z, std::uint64_t seed) {
  std::uint64_t h = noise_hash(seed);
  h = noise_hash(h ^ static_cast<std::uint64_t>(x));
  h = noise_hash(h ^ static_cast<std::uint64_t>(y));
  h = noise_hash(h ^ static_cast<std::uint64_t>(z));
  return static_cast<double>(h >> 11) * (2.0 / 9007199254740992.0) - 1.0;  // 53 bits → [−1, 1)
}

// Scalar value noise at q, given in lattice units (position / feature size).
inline double value_noise(const Vec3& q, std::uint64_t seed) {
  const auto fade = [](double s) { return s * s * s * (s * (6.0 * s - 15.0) + 10.0); };
  const double fx = std::floor(q.x()), fy = std::floor(q.y()), fz = std::floor(q.z());
  const auto ix = static_cast<std::int64_t>(fx), iy = static_cast<std::int64_t>(fy), iz = static_cast<std::int64_t>(fz);
  const double tx = fade(q.x() - fx), ty = fade(q.y() - fy), tz = fade(q.z() - fz);
  double v = 0.0;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    const double weight = (dx ? tx : 1.0 - tx) * (dy ? ty : 1.0 - ty) * (dz ? tz : 1.0 - tz);
    v += weight * noise_lattice_value(ix + dx, iy + dy, iz + dz, seed);
  }
  return v;
}

}  // namespace perifx::systems
