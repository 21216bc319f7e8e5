// PLY: binary particle frames and embedded-mesh surfaces (write), and one reader for ASCII and
// binary (little or big endian) files, used for input surfaces and for frames read back.
#pragma once
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "components/embedded_mesh.hpp"
#include "perifx/fields.hpp"
#include "components/math.hpp"
#include "io/triangle_surface.hpp"

namespace perifx::io {

// Particles as binary little-endian PLY points: x y z as float, then each field as properties
// (vectors become name_x name_y name_z). Houdini and Blender import these.
void write_ply_points(const std::filesystem::path& target, const std::vector<Vec3>& points,
                      const std::vector<FieldView>& fields);
// Surface as binary little-endian PLY (io/render_surface.hpp: vertices split along crack rims):
// vertex: float x y z, nx ny nz (normal), vx vy vz (velocity, m/s), rx ry rz (reference position),
// uint source (embedded-mesh vertex, to weld the split copies); face: list uchar int
// vertex_indices, uchar crack, uint fragment (stable piece id), uint tet (= particle).
void write_ply_surface(const std::filesystem::path& target, const SurfaceMesh& surface);

struct PlyContent {
  TriangleSurface surface;  // "vertex" x/y/z and the fanned "face" vertex_indices (crack flags too)
  // Every scalar property of the "vertex" element, by name, as doubles (one value per vertex).
  std::map<std::string, std::vector<double>> vertex_properties;
  // Every scalar property of the "face" element, by name, one value per triangle (a polygon's fan
  // repeats its value).
  std::map<std::string, std::vector<double>> face_properties;
};
// Reads a PLY file. Needs a "vertex" element with x, y, z; faces are optional (a particle frame has
// none). Throws ReadError naming the file (and the line, in ASCII files).
PlyContent read_ply(const std::filesystem::path& file);

}  // namespace perifx::io
