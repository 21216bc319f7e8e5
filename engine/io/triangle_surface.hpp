// The triangulated surface the surface-file readers return (OBJ, PLY, STL, OFF): what the mesh
// input (engine/geometry) and the run-directory reader (run_dir.hpp) both need.
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "components/math.hpp"

namespace perifx::io {

struct TriangleSurface {
  std::vector<Vec3> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;  // polygons are split into fans around corner 0
  // Per triangle, 1 on crack faces: OBJ faces under a group/object/material whose name contains
  // "crack", PLY faces with a non-zero crack (is_crack, crack_face) property. Empty when the file
  // marks none of its faces this way.
  std::vector<std::uint8_t> crack;
};

}  // namespace perifx::io
