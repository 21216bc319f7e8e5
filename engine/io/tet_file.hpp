// The tet mesh the tet-file readers return (TetGen, Gmsh), as the file has it: tets are neither
// oriented nor checked here (engine/geometry does that), so each keeps where it came from for the
// messages of those checks.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "components/math.hpp"

namespace perifx::io {

struct TetFile {
  std::vector<Vec3> vertices;
  std::vector<std::array<std::uint32_t, 4>> tets;  // corners only (quadratic tets' mid-edge nodes dropped)
  std::vector<std::size_t> tet_line;               // line of each tet in `tet_source`
  std::vector<long long> tet_id;                   // the tet's number in the file
  std::string tet_word = "tet";                    // what the format calls a tet ("tet", "tetrahedron")
  std::string tet_source;                          // the file the tets were read from
};

}  // namespace perifx::io
