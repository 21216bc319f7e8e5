// Everything `perifx run` would refuse before the first step, without building the world's bonds:
// every body's mesh is read, placed and checked as setup does (placed_mesh), and the peak memory of
// the world is estimated from the particle count and the bonds a horizon sphere holds. `perifx check`
// runs it (then builds the world for the stable-step limit); `perifx run` runs it unless --force.
#pragma once
#include <cstddef>
#include <string>

#include "perifx/errors.hpp"
#include "perifx/scene.hpp"

namespace perifx::setup {

// Measured figures (World::memory on the shipped scenes, tests/engine/test_world.cpp): per directed
// bond 5 B (neighbour, alive flag), 8 B more when some material can yield (e^p and its mirror, float),
// 4 B more when a weak plane cuts bonds, 1 bit more in the contact list when particle contact is on
// (bytes_per_bond); about 440 B per particle; mesh and embedded mesh about 200 B per tet. Setup holds
// transient arrays on top (adjacency, Morton keys, the family lists), hence the peak factor.
inline constexpr double kBytesPerBondState = 5.0;
inline constexpr double kBytesPerBondPlastic = 8.0;
inline constexpr double kBytesPerBondScale = 4.0;
inline constexpr double kBytesPerBondContact = 0.125;
inline constexpr double kBytesPerParticle = 440.0;
inline constexpr double kBytesPerTet = 200.0;
inline constexpr double kPeakFactor = 1.25;

struct MemoryEstimate {
  std::size_t particles = 0;
  double bonds = 0.0;            // directed bonds, estimated
  double bytes = 0.0;            // estimated peak, with kPeakFactor
  double available = -1.0;       // MemAvailable from /proc/meminfo, bytes; < 0 when unknown
  bool meshed = false;           // false: refused from the primitives' cell counts, before meshing
};

// Not enough memory for a scene: what() is the one-line "<scene>: /bodies: ..." message.
class MemoryError : public Error {
 public:
  using Error::Error;
};

// Estimates the peak memory of `scene` (meshing every body; primitives whose cell count alone is
// beyond the available memory are refused before meshing). Throws SceneError for a bad mesh and,
// when `enforce`, MemoryError when the estimate exceeds the available memory.
MemoryEstimate preflight(const scene::Scene& scene, bool enforce);

std::string format_bytes(double bytes);  // "1.2 GiB"
// Bytes per directed bond the world will hold for this scene (see the figures above).
double bytes_per_bond(const scene::Scene& scene);

}  // namespace perifx::setup
