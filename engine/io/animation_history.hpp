// animation.bin: a run's AnimationHistory (engine/animation.hpp), saved beside each checkpoint so a
// resumed run can still write its whole animation (pieces.csv, animation.obj/.pc2/.glb) at the end.
//
// Layout (little endian, this machine's doubles and floats): "PFXANIM1", then the settings
// (record_vertices u8, min_piece_tets u32), the frames (u64 count; per frame: frame u64, time f64,
// vertex_count u32, piece count u32 and per piece id u32, particles u32, mass, centre, rotation
// (row-major), translation, velocity, angular velocity as f64; u8 has-positions and 3·vertex_count
// f32), the piece origins (u64 count; id u32, birth frame u64, parent u32), the vertex parents and
// birth frames (u64 count; u32 each, u64 each), then "END!". Written atomically (io/atomic.hpp).
#pragma once
#include <filesystem>

#include "animation.hpp"

namespace perifx::io {

void write_animation_history(const std::filesystem::path& file, const AnimationHistory& history);

// Throws IoError naming the file when it is missing, truncated or not an animation history.
AnimationHistory read_animation_history(const std::filesystem::path& file);

}  // namespace perifx::io
