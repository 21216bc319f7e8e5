// Wavefront OBJ surfaces: the embedded-mesh surface per frame (with its .mtl) and surface input.
#pragma once
#include <filesystem>
#include <array>
#include <string>
#include <vector>

#include "components/embedded_mesh.hpp"
#include "io/triangle_surface.hpp"

namespace perifx::io {

// Surface as Wavefront OBJ: `mtllib <mtl>`, vertices, then per piece (increasing id, from the
// triangles' `fragment`) `o piece_<id>` / `g piece_<id>` with its original-surface triangles under
// `usemtl surface` and its crack triangles under `usemtl crack` (1-based, outward counter-clockwise).
// Coordinates with 9 significant digits. No normals: vertices are shared (each piece is closed).
void write_obj_surface(const std::filesystem::path& target, const SurfaceMesh& surface,
                       const std::string& mtl_file = "surface.mtl");
// The surface of a point cache (animation.obj beside animation.pc2): vertices in the order given (the
// caller orders them by first use, so importers that renumber vertices by first use keep the order),
// `vt` coordinates for the crack faces (`uv`, 3 per triangle; outside faces have none), then per piece
// `o piece_<id>` / `g piece_<id>` with `usemtl surface` / `usemtl crack` faces, in triangle order
// (the caller sorts triangles by piece, outside before crack). `positions`: 3 floats per vertex.
void write_obj_cache(const std::filesystem::path& target, const SurfaceMesh& surface, const std::vector<float>& positions,
                     const std::vector<std::array<std::array<double, 2>, 3>>& uv,
                     const std::string& mtl_file = "surface.mtl");
// The two materials the OBJ files use (grey surface, orange crack).
void write_surface_mtl(const std::filesystem::path& target);

// v/f lines ("f 1/2/3", negative indices); vt/vn ignored. Faces after a g/o/usemtl line whose name
// contains "crack" are flagged as crack faces. Throws ReadError "file:line: message".
TriangleSurface read_obj(const std::filesystem::path& file);

}  // namespace perifx::io
