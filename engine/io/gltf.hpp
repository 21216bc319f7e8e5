// Binary glTF 2.0 (.glb): the pieces of a run as rigid bodies for game engines and DCC tools. One
// writer.
#pragma once
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "perifx/math.hpp"
#include "perifx/mesh.hpp"

namespace perifx::io {

// Keyframes of one piece: translation and rotation (unit quaternion x, y, z, w) per time.
struct RigidPieceTrack {
  std::uint32_t id = 0;
  std::vector<Vec3> translation;
  std::vector<Eigen::Vector4d> rotation;
};

// `surface`: the final surface with its vertices at their reference positions (`vertices`), piece id
// (`fragment`) and crack flag per triangle. Each piece becomes a node `piece_<id>` (extras.piece = id)
// with a mesh of up to two primitives, outside faces (material `surface`) and crack faces (material
// `crack`, TEXCOORD_0 from `crack_uv`), each with its own vertices, POSITION, NORMAL (area-weighted,
// per primitive) and uint32 indices. With two or more `times`, one animation `perifx` moves every
// node by LINEAR translation and rotation keyframes (`tracks`, one per piece in increasing id order,
// each with one key per time). Y up, metres. GLB: 12-byte header, JSON chunk padded with spaces, BIN
// chunk padded with zeros. Written atomically; throws IoError naming the file on inconsistent input.
void write_glb(const std::filesystem::path& file, const SurfaceMesh& surface,
               const std::vector<std::array<std::array<double, 2>, 3>>& crack_uv, const std::vector<double>& times,
               const std::vector<RigidPieceTrack>& tracks, const std::string& generator);

}  // namespace perifx::io
