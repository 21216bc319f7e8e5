// A perifx run directory read back: the one reader `perifx render` and `perifx compare` share.
// Particle frames (particles.NNNN.vtu, or .ply when there is no VTU), frame times (particles.pvd),
// surface frames (surface.NNNN.ply / .obj: triangles with a per-face crack flag), rigid projectiles
// (projectiles.csv) and mesh.json (what the particles are, written by the runner, read by compare).
// Only what the tools need is kept, as doubles.
#pragma once
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "components/math.hpp"

namespace perifx::io {

// A run directory or one of its files cannot be read; what() names the file and the problem.
class RunDirError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ParticleFrame {
  std::vector<Vec3> position;
  std::vector<double> volume;           // empty when the run did not write it
  std::vector<double> damage;           // empty when absent
  std::vector<std::uint32_t> material;  // material_id, else body_id; empty when neither was written
  std::vector<std::uint32_t> fragment;  // fragment_id (piece id); empty when absent
};

struct SurfaceFrame {
  std::vector<Vec3> vertex;
  std::vector<std::array<std::uint32_t, 3>> triangle;
  std::vector<std::uint8_t> crack;  // per triangle: 1 on crack faces (empty: no flags in the file)
  std::vector<double> damage;       // per vertex, when the file has it
  // Surface PLY files of perifx runs (io/ply.hpp) also carry, each empty when absent:
  std::vector<Vec3> reference;              // per vertex: reference position (rx ry rz)
  std::vector<std::uint32_t> source;        // per vertex: embedded-mesh vertex (welds rim copies)
  std::vector<std::uint32_t> fragment;      // per triangle: piece id
  std::vector<std::uint32_t> tet;           // per triangle: its tet (= particle)
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
  double time = 0.0;                // from particles.pvd, else mesh.json's frame rate and step, else index / 30
};

struct RunDirectory {
  std::filesystem::path path;
  std::vector<FrameFiles> frames;  // sorted by index
  // projectiles.csv grouped by time (in file order); frame k of the run matches group k.
  std::vector<std::pair<double, std::vector<ProjectileState>>> projectiles;
  double frame_rate = 30.0;  // from the frame times, when there are at least two
};

// Lists the frames of a run. Throws RunDirError when the directory has no frame files.
RunDirectory scan_run_directory(const std::filesystem::path& dir);

// Projectiles at a frame: the CSV group with the nearest time (empty when there are none).
std::vector<ProjectileState> projectiles_at(const RunDirectory& run, const FrameFiles& frame);

// The particle series as particles.pvd lists it, in its order: time and file (joined to `dir`).
// Throws RunDirError "<dir>: not a run directory (no particles.pvd)" or "<pvd>: no frames".
struct TimedFile {
  double time = 0.0;
  std::filesystem::path file;
};
std::vector<TimedFile> particle_series(const std::filesystem::path& dir);

// Frame readers. Throw RunDirError naming the file and the problem.
ParticleFrame read_particle_frame(const std::filesystem::path& file);  // .vtu or .ply, by extension
SurfaceFrame read_surface_frame(const std::filesystem::path& file);    // .ply (binary or ASCII) or .obj

// mesh.json: the solver, what the particles are (tet barycenters for peridynamics, mesh vertices
// for FEM), counts, a hash of the tet connectivity and, for FEM runs, the tets themselves
// (vertex = particle index), so `perifx compare` can map one kind of run onto the other.
struct RunMesh {
  bool present = false;  // read_run_mesh: false when the run has no mesh.json
  std::string solver = "unknown";
  bool vertices_are_particles = false;
  std::size_t particles = 0, vertices = 0, tet_count = 0;
  std::string hash;
  std::vector<std::array<std::uint32_t, 4>> tets;  // written and read only when vertices_are_particles
  double horizon = 0.0;  // largest horizon δ of the bodies, m; written when the run writes surfaces (else 0)
  // The output frame rate (1/s) and time step (s): frame k is at step round(k / (frame_rate · dt)), so a
  // run without particles.pvd (ply-only output) still has its frame times. 0 in older runs.
  double frame_rate = 0.0, dt = 0.0;
};
// FNV-1a 64 of the vertex count, tet count and connectivity, as 16 hex digits.
std::string tet_hash(const std::vector<std::array<std::uint32_t, 4>>& tets, std::size_t vertices);
// The step at which frame k is written: the step nearest to k/frame_rate (the runner writes frames
// there; a reader without particles.pvd times frame k as frame_step(k, …) · dt).
inline std::uint64_t frame_step(std::uint64_t k, double frame_rate, double dt) {
  return static_cast<std::uint64_t>(std::llround(double(k) * (1.0 / frame_rate) / dt));
}
// Writes <dir>/mesh.json atomically (the tets only when vertices_are_particles).
void write_run_mesh(const std::filesystem::path& dir, const RunMesh& mesh);
// Throws RunDirError naming the file when mesh.json exists but is malformed.
RunMesh read_run_mesh(const std::filesystem::path& dir);

}  // namespace perifx::io
