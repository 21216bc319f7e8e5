// perifx public API: triangle surfaces, as perifx extracts them from its (cracking) tet mesh and as
// the surface-file readers return them.
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "perifx/math.hpp"

namespace perifx {

// Boundary triangles of a mesh. From World::surface(): the split embedded mesh's outside and crack
// faces, with per-triangle crack flag, piece id (`fragment`, the particles' stable fragment_id) and
// tet, and per vertex its velocity, reference position and embedded-mesh vertex index. A vertex is
// shared by every triangle that uses it (each piece's surface is closed). From the surface readers:
// vertices and triangles only (the other arrays empty).
struct SurfaceMesh {
  std::vector<Vec3> vertices;                          // only the referenced ones, in vertex order
  std::vector<std::array<std::uint32_t, 3>> triangles; // outward (counter-clockwise seen from outside)
  std::vector<std::uint8_t> crack;                     // 1: the face was interior in the original mesh
  std::vector<std::uint32_t> fragment;                 // fragment id of the triangle's tet's particle
  std::vector<std::uint32_t> tet;                      // the tet the triangle bounds
  std::vector<Vec3> velocity;                          // per vertex, m/s
  std::vector<Vec3> reference;                         // per vertex: reference position X_v, m
  std::vector<std::uint32_t> source;                   // per vertex: index in the embedded mesh
};

}  // namespace perifx
