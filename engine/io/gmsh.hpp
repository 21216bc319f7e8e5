// Gmsh .msh tet mesh input, ASCII formats 2.2 and 4.1.
#pragma once
#include <filesystem>

#include "io/tet_file.hpp"

namespace perifx::io {

// Only tetrahedra are read (element type 4, and the corners of 10-node type 11); points, lines,
// triangles and other elements are ignored; every node is kept (sparse tags are renumbered in file
// order). Throws ReadError "file:line: message".
TetFile read_gmsh(const std::filesystem::path& file);

}  // namespace perifx::io
