// The surface as a renderer wants it (PLY and VTP surface files): per-vertex normals that are smooth
// on the outside and across a crack face, but split along the rim where crack triangles meet outside
// triangles. A vertex used by both kinds is written twice (once per kind); each copy's normal is the
// area-weighted mean of its kind's triangle normals. Velocity, reference position and embedded-mesh
// index are copied to both (the index lets a reader weld the copies back: perifx check-surface).
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "components/math.hpp"
#include "perifx/mesh.hpp"

namespace perifx::io {

struct RenderSurface {
  std::vector<Vec3> position, normal, velocity, reference;  // per written vertex
  std::vector<std::uint32_t> source;                        // embedded-mesh vertex index
  std::vector<std::array<std::uint32_t, 3>> triangles;      // the input's triangles, in order
};

// Splits `surface` as above. Missing per-vertex arrays (a surface not from World::surface) give
// zero velocity, reference = position and source = the input vertex index.
RenderSurface render_surface(const SurfaceMesh& surface);

// Piece id (`fragment` of its triangles) per written vertex of `r` (made from `surface`).
std::vector<std::uint32_t> vertex_pieces(const RenderSurface& r, const SurfaceMesh& surface);

}  // namespace perifx::io
