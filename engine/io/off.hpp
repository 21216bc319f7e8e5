// OFF surface input (also COFF/NOFF; 4-D and n-D variants are refused).
#pragma once
#include <filesystem>

#include "io/triangle_surface.hpp"

namespace perifx::io {

// Throws ReadError naming the file (and the line, in text files).
TriangleSurface read_off(const std::filesystem::path& file);

}  // namespace perifx::io
