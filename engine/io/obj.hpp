// Wavefront OBJ surfaces: the embedded-mesh surface per frame (with its .mtl) and surface input.
#pragma once
#include <filesystem>
#include <string>

#include "components/embedded_mesh.hpp"
#include "io/triangle_surface.hpp"

namespace perifx::io {

// Surface as Wavefront OBJ: `mtllib <mtl>`, vertices, then `g surface`/`usemtl surface` with the
// original-surface triangles and `g crack`/`usemtl crack` with the crack triangles (1-based, outward
// counter-clockwise). Coordinates with 9 significant digits.
void write_obj_surface(const std::filesystem::path& target, const SurfaceMesh& surface,
                       const std::string& mtl_file = "surface.mtl");
// The two materials the OBJ files use (grey surface, orange crack).
void write_surface_mtl(const std::filesystem::path& target);

// v/f lines ("f 1/2/3", negative indices); vt/vn ignored. Faces after a g/o/usemtl line whose name
// contains "crack" are flagged as crack faces. Throws ReadError "file:line: message".
TriangleSurface read_obj(const std::filesystem::path& file);

}  // namespace perifx::io
