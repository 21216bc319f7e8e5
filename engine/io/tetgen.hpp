// TetGen files: .node/.ele tet meshes (read) and the .smesh surface handed to the tetgen program
// (write; geometry/surface_mesh.cpp runs the program).
#pragma once
#include <array>
#include <cstdint>
#include <filesystem>
#include <vector>

#include "components/math.hpp"
#include "io/tet_file.hpp"

namespace perifx::io {

// TetGen .node/.ele (1- or 0-based, optional attributes and markers). `node_file` names the .node
// file; the .ele beside it is read ("mesh.1.node" -> "mesh.1.ele"). Throws ReadError naming the file
// and line.
TetFile read_tetgen(const std::filesystem::path& node_file);

// A closed triangle surface as a TetGen .smesh (1-based, no holes, no regions), 17 digits.
void write_tetgen_smesh(const std::filesystem::path& target, const std::vector<Vec3>& vertices,
                        const std::vector<std::array<std::uint32_t, 3>>& triangles);

}  // namespace perifx::io
