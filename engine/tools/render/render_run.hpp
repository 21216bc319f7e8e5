// `perifx render`: turns a run directory into PNG frames (POV-Ray or the built-in rasterizer) and
// optionally an MP4 (ffmpeg).
#pragma once
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "tools/render/render.hpp"
#include "io/run_dir.hpp"

namespace perifx::render {

// The run directory is read through engine/io (the reader `perifx compare` uses too).
using io::FrameFiles;
using io::ParticleFrame;
using io::ProjectileState;
using io::RunDirectory;
using io::RunDirError;
using io::SurfaceFrame;

enum class Backend { automatic, povray, builtin };
// automatic: damage when a particle of the last rendered frame is damaged, else material.
enum class ColorBy { automatic, damage, material, none };
// What a frame is drawn from. automatic: the surface (embedded tet mesh) when the run wrote one, except
// that an explicit --color-by damage falls back to the particles when the surface has no damage.
enum class Draw { automatic, particles, surface };

// A cut-away plane: what lies where normal·x > offset is left out (normal of unit length).
struct CutPlane {
  Vec3 normal = Vec3::UnitZ();
  double offset = 0.0;
};

struct RenderProgress {
  std::size_t frame = 0, frames = 0;  // frames done, of frames
  std::uint64_t index = 0;            // run frame number just written
  double wall_seconds = 0.0, eta_seconds = 0.0;
};

struct RenderOptions {
  std::filesystem::path run_directory;
  std::optional<std::filesystem::path> output_directory;  // default run_directory/render
  int width = 1280, height = 720;
  ColorBy color_by = ColorBy::automatic;
  std::optional<std::uint64_t> first_frame, last_frame;   // inclusive run frame numbers
  bool mp4 = false;
  Backend backend = Backend::automatic;
  Draw draw = Draw::automatic;
  int threads = 0;                                         // 0: all cores (TBB default, POV-Ray default)
  Vec3 view = Vec3(0.75, 0.55, 1.3);                       // direction from the subject to the camera
  std::optional<std::uint64_t> fit_first, fit_last;        // frames the camera is framed on (default: the rendered ones)
  double zoom = 1.0;                                       // > 1 moves the camera closer to the framed subject
  std::optional<CutPlane> cut;                             // hide one side of a plane (a cut-away view)
  std::optional<std::filesystem::path> scene_file;        // optional: projectile radii, ground plane
  std::optional<double> projectile_radius;                // overrides a missing radius column
  double particle_scale = 0.62;                            // sphere radius = scale * volume^(1/3)
  std::function<void(const RenderProgress&)> on_frame;
  std::function<void(const std::string&)> on_note;       // one-line notes (backend choice, fallbacks)
};

struct RenderSummary {
  std::size_t frames = 0;
  Backend backend = Backend::builtin;
  std::filesystem::path output_directory;
  std::optional<std::filesystem::path> movie;
};

// Throws io::RunDirError (bad run directory or frame files), io::IoError (cannot write),
// std::runtime_error (a backend program failed; the message carries the end of its log).
RenderSummary render_run(const RenderOptions& options);

// The absolute path of an executable found on PATH, or empty.
std::filesystem::path find_program(const std::string& name);

// Builds the backend-neutral scene of one frame (exposed for the tests).
struct FrameStyle {
  ColorBy color_by = ColorBy::material;
  double particle_scale = 0.62;
  double fallback_radius = 0.01;    // particle radius when the frame has no volume field
  double projectile_radius = 0.1;   // when projectiles.csv has no radius column
  // Particles and projectiles whose center, and triangles whose centroid, lie beyond it are left out.
  std::optional<CutPlane> cut;
};
RenderScene frame_scene(const ParticleFrame* particles, const SurfaceFrame* surface,
                        const std::vector<ProjectileState>& projectiles, const FrameStyle& style);

}  // namespace perifx::render
