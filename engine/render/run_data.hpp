// Reading a perifx run directory back for rendering: particle frames (particles.NNNN.vtu, or .ply
// when there is no VTU), surface frames (surface.NNNN.ply / .obj, triangles with a per-face crack
// flag, from the embedded-mesh output), frame times (particles.pvd) and rigid projectiles
// (projectiles.csv). Only what the renderer needs is kept, as doubles.
#pragma once
#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "components/math.hpp"

namespace perifx::render {

class RunDataError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ParticleFrame {
  std::vector<Vec3> position;
  std::vector<double> volume;      // empty when the run did not write it
  std::vector<double> damage;      // empty when absent
  std::vector<std::uint32_t> material;  // material_id, else body_id; empty when neither was written
};

struct SurfaceFrame {
  std::vector<Vec3> vertex;
  std::vector<std::array<std::uint32_t, 3>> triangle;
  std::vector<std::uint8_t> crack;  // per triangle: 1 on crack faces (empty: no flags in the file)
  std::vector<double> damage;       // per vertex, when the file has it
};

struct ProjectileState {
  std::size_t id = 0;
  Vec3 center = Vec3::Zero();
  double radius = 0.0;  // 0 when projectiles.csv has no radius column
};

struct FrameFiles {
  std::uint64_t index = 0;
  std::filesystem::path particles;  // .vtu preferred, else .ply; empty when only surfaces exist
  std::filesystem::path surface;    // .ply preferred, else .obj; empty when none
  double time = 0.0;                // from particles.pvd, else index / 30
};

struct RunDirectory {
  std::filesystem::path path;
  std::vector<FrameFiles> frames;  // sorted by index
  // projectiles.csv grouped by time (in file order); frame k of the run matches group k.
  std::vector<std::pair<double, std::vector<ProjectileState>>> projectiles;
  double frame_rate = 30.0;  // from the frame times, when there are at least two
};

// Lists the frames of a run. Throws RunDataError when the directory has no frame files.
RunDirectory scan_run_directory(const std::filesystem::path& dir);

// Projectiles at a frame: the CSV group with the nearest time (empty when there are none).
std::vector<ProjectileState> projectiles_at(const RunDirectory& run, const FrameFiles& frame);

// Readers. Throw RunDataError naming the file and the problem.
ParticleFrame read_vtu_particles(const std::filesystem::path& file);
ParticleFrame read_ply_particles(const std::filesystem::path& file);
ParticleFrame read_particles(const std::filesystem::path& file);  // by extension
SurfaceFrame read_surface(const std::filesystem::path& file);     // .ply (binary or ascii) or .obj

}  // namespace perifx::render
