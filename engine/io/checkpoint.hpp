// Checkpoints: the complete state of a world in one binary file, so a run can continue after a kill
// with frames byte-identical to an uninterrupted run (perifx run --resume, World::save_checkpoint).
//
// Layout (little endian, this machine's doubles): "PERIFXCK", format version u32, a JSON header
// (u64 length + text: scene hash and text, dt, solver, particle and bond counts, step, and the
// caller's note), then every array of for_each_array (components/world_state.hpp) as name, element
// size, count and bytes, then the scalars the arrays do not hold (clock, contact pair-list
// bookkeeping, embedded-mesh counters), then "END!". One writer and one reader, both here; the file
// is written atomically (io/atomic.hpp).
#pragma once
#include <cstdint>
#include <filesystem>
#include <string>

#include "components/world_state.hpp"

namespace perifx::io {

struct CheckpointHeader {
  std::string scene_hash;   // FNV-1a 64 of the scene's JSON text, 16 hex digits
  std::string scene_text;   // the scene's JSON text (to say what changed)
  std::string solver;
  double dt = 0.0;
  double contact_time_scale = 0.0;  // s, as resolved at set-up (settings.contact.time_scale)
  std::uint64_t step = 0, particles = 0, bonds = 0;
  std::string note;         // the caller's (the runner keeps its frame bookkeeping here)
};

std::string scene_hash(const std::string& text);

// Writes `state` with `header` (its step, counts, dt and contact time scale are taken from the state)
// atomically.
void write_checkpoint(const std::filesystem::path& file, const WorldState& state, CheckpointHeader header);

// Reads only the header. Throws IoError naming the file when it is missing or not a checkpoint.
CheckpointHeader read_checkpoint_header(const std::filesystem::path& file);

// Why a checkpoint cannot continue a world built from `scene_text` with `dt`, `contact_time_scale` and
// `solver`: empty when it can, else one line naming what differs (the top-level scene keys, dt, the
// contact time scale, solver, counts). The step and the time scale are compared apart from the text
// because the command line can override them.
std::string checkpoint_mismatch(const CheckpointHeader& header, const std::string& scene_text, double dt,
                                double contact_time_scale, const std::string& solver, std::uint64_t particles,
                                std::uint64_t bonds);

// Fills `state` (built from the same scene) from the checkpoint. Thread-dependent scratch
// (contact.pairs.bonded_stamp, one row per worker slot) keeps the world's own, so a run can resume
// on another thread count. Throws IoError when the file is truncated or its arrays do not fit.
CheckpointHeader read_checkpoint(const std::filesystem::path& file, WorldState& state);

}  // namespace perifx::io
