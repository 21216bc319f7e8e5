// STL surface input, ASCII or binary (told apart by the binary size rule). Coincident corners are
// merged within 1e-6 of the bounding-box diagonal and triangles that collapse are dropped.
#pragma once
#include <filesystem>

#include "io/triangle_surface.hpp"

namespace perifx::io {

// Throws ReadError naming the file (and the line, in text files).
TriangleSurface read_stl(const std::filesystem::path& file);

}  // namespace perifx::io
