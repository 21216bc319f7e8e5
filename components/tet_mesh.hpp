// A tetrahedral mesh as plain arrays. Tets are positively oriented:
// (v1−v0)·((v2−v0)×(v3−v0)) > 0.
#pragma once
#include <array>
#include <vector>

#include "components/math.hpp"

namespace perifx {

struct TetMesh {
  std::vector<Vec3> vertices;                         // m
  std::vector<std::array<std::uint32_t, 4>> tets;     // vertex indices
};

}  // namespace perifx
