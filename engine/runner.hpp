// Runs a world through a scene's duration and writes its frames: what `perifx run` does, available
// to hosts that want the same files without the CLI.
#pragma once
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "perifx/world.hpp"

namespace perifx {

struct RunProgress {
  std::uint64_t frame = 0, frames = 0;   // frames written so far (frame 0 = initial state) / total
  std::uint64_t step = 0, steps = 0;
  double wall_seconds = 0.0;
  double steps_per_second = 0.0;
  double eta_seconds = 0.0;
};

struct RunOptions {
  std::optional<std::filesystem::path> output_directory;  // overrides scene.output.directory
  std::optional<std::uint64_t> frames;                    // overrides duration: run this many frames
  std::function<void(const RunProgress&)> on_frame;       // called after every written frame
};

struct RunSummary {
  std::size_t particles = 0, bonds = 0, alive_bonds = 0;
  std::size_t fragments = 0;          // connected components of alive bonds at the end
  std::uint64_t steps = 0, frames = 0;
  double simulated_seconds = 0.0;
  double wall_seconds = 0.0;          // stepping only (setup and file output excluded)
  double output_seconds = 0.0;
  double bond_updates_per_second = 0.0;  // directed bonds × steps / stepping wall time
  int threads = 0;
  std::uint64_t contact_list_builds = 0;     // particle-contact pair list: full rebuilds (motion)
  std::uint64_t contact_list_additions = 0;  // and incremental additions of broken bonds' pairs
  std::filesystem::path output_directory;
};

// Writes frame files "<dir>/particles.NNNN.{vtu,ply}" and "<dir>/particles.pvd" (frame 0 is the
// initial state) and "<dir>/summary.json" at the end, all atomically. Throws io::IoError,
// std::invalid_argument for unknown output field names.
RunSummary run_world(World& world, const RunOptions& options);

}  // namespace perifx
