// Point caches (PC2): every vertex's position at every frame, for a mesh whose topology never
// changes; read by Blender's built-in Mesh Cache modifier (and 3ds Max, Houdini's File SOP via its
// point cache support). One writer.
#pragma once
#include <filesystem>
#include <vector>

namespace perifx::io {

// Layout (little endian): "POINTCACHE2\0", version i32 = 1, vertex count i32, start frame f32,
// sample rate f32 (frames between samples: 1), sample count i32, then per sample and vertex x y z as
// f32. `frames[k]` holds 3 floats per vertex (all the same size). Written atomically; throws IoError
// naming the file when the frames differ in size.
void write_pc2(const std::filesystem::path& file, const std::vector<std::vector<float>>& frames, float start_frame = 0.0f);

}  // namespace perifx::io
