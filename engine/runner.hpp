// Runs a world through a scene's duration and writes its frames: what `perifx run` does, available
// to hosts that want the same files without the CLI.
#pragma once
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "perifx/world.hpp"

namespace perifx {

struct RunProgress {
  std::uint64_t frame = 0, frames = 0;   // frames written so far (frame 0 = initial state) / total
  std::uint64_t step = 0, steps = 0;
  double wall_seconds = 0.0;
  double steps_per_second = 0.0;
  double eta_seconds = 0.0;
  double time = 0.0;                     // simulated seconds at this frame
  const World* world = nullptr;          // the world being run, for counters a host wants to show
};

// What run_world does when the output directory already holds a run's files (run_files).
enum class ExistingRun {
  refuse,     // throw io::IoError naming the folder and some of the files (CLI: exit 3)
  overwrite,  // remove that run's files first
  resume,     // continue after <dir>/checkpoint.bin; with no checkpoint, start over (as overwrite)
};

struct RunOptions {
  std::optional<std::filesystem::path> output_directory;  // overrides scene.output.directory
  std::optional<std::uint64_t> frames;                    // overrides duration: run this many frames
  std::function<void(const RunProgress&)> on_frame;       // called after every written frame
  ExistingRun existing = ExistingRun::refuse;
  // Polled after every frame; when it returns true the run writes a checkpoint and the summary and
  // returns with RunSummary::interrupted set (the CLI's SIGTERM/SIGINT handling).
  std::function<bool()> stop_requested;
  // Time every system of the step (World::set_profiling) and report it in RunSummary::system_times,
  // summary.json ("profile") and profile_table (`perifx run --profile`).
  bool profile = false;
};

struct RunSummary {
  std::size_t particles = 0, bonds = 0, alive_bonds = 0;
  std::size_t fragments = 0;          // connected components of alive bonds at the end
  std::optional<double> first_break_time;  // s: end of the step in which a bond first broke (World::first_break_time)
  std::uint64_t steps = 0, frames = 0;
  double simulated_seconds = 0.0;
  double wall_seconds = 0.0;          // stepping only (setup and file output excluded)
  double output_seconds = 0.0;
  double bond_updates_per_second = 0.0;  // directed bonds × steps / stepping wall time
  // This process's peak resident memory so far, bytes (getrusage; under mpirun, rank 0's): what a render
  // farm job must reserve, beside `perifx check`'s estimate.
  std::uint64_t peak_memory_bytes = 0;
  int threads = 0;
  int ranks = 1;                             // MPI ranks of a distributed run (1 in one process)
  std::uint64_t rebalances = 0;              // its re-splits as the work per rank drifted
  std::uint64_t contact_list_builds = 0;     // particle-contact pair list: full rebuilds (motion)
  std::uint64_t contact_list_additions = 0;  // and incremental additions of broken bonds' pairs
  std::uint64_t contact_list_partial_updates = 0;  // updates that searched only the moved particles
  std::uint64_t contact_list_searched = 0;         // particles searched by those updates
  // Distributed runs: every rank's share, ghosts and halo traffic (World::rank_stats; the contact_list_*
  // counts above are their sums).
  std::vector<RankStats> rank_stats;
  std::filesystem::path output_directory;
  std::uint64_t first_frame = 0;      // 0, or the checkpoint's frame a resumed run continued after
  std::uint64_t last_frame = 0;       // the last frame written
  bool interrupted = false;           // stopped by stop_requested before the last frame
  std::vector<SystemTime> system_times;  // RunOptions::profile: per system of the step, this session
  std::vector<SystemTime> setup_times;   // RunOptions::profile: the world's set-up phases (World::setup_times)
};

// The profile of a run as a text table: one row per system (wall seconds, ms per step, share of the
// stepping wall time), then stepping outside the graph's systems and file output. Systems the graph
// runs side by side overlap, so their shares can add up to more than 100 %.
std::string profile_table(const RunSummary& summary);

// The files of a run in `dir` (particles.*, surface.*, tets.*, *.pvd, projectiles.csv, summary.json,
// mesh.json, checkpoint.bin), sorted; empty when there are none or `dir` does not exist.
std::vector<std::filesystem::path> run_files(const std::filesystem::path& dir);

// Writes frame files "<dir>/particles.NNNN.{vtu,ply}" and "<dir>/particles.pvd" (frame 0 is the
// initial state), every scene.output.checkpoint_every frames and after the last one
// "<dir>/checkpoint.bin" (World::save_checkpoint), and "<dir>/summary.json" at the end, all
// atomically. Refuses a directory holding another run (see ExistingRun). Throws io::IoError,
// scene::SceneError (a checkpoint of another scene), std::invalid_argument for unknown output
// field names.
RunSummary run_world(World& world, const RunOptions& options);

}  // namespace perifx
