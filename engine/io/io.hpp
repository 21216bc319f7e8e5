// File output. Every file is written to "<name>.tmp-<pid>" in the same directory, flushed, then
// renamed over the target, so readers never see a half-written file, even after a crash or kill.
#pragma once
#include <filesystem>
#include <functional>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "components/embedded_mesh.hpp"
#include "perifx/fields.hpp"
#include "components/math.hpp"
#include "perifx/errors.hpp"

namespace perifx::io {

// Writes through `fill` into a temporary file, then renames it to `target`. Throws IoError naming
// the path and the OS error on failure (and removes the temporary).
void write_atomic(const std::filesystem::path& target, const std::function<void(std::ostream&)>& fill);

// Particles as a VTK XML UnstructuredGrid (one vertex cell per point), binary appended raw data,
// little endian, readable by ParaView. Fields must have location particle and count == points.size().
void write_vtu_points(const std::filesystem::path& target, const std::vector<Vec3>& points,
                      const std::vector<FieldView>& fields);

// Particles as binary little-endian PLY points: x y z as float, then each field as properties
// (vectors become name_x name_y name_z). Houdini and Blender import these.
void write_ply_points(const std::filesystem::path& target, const std::vector<Vec3>& points,
                      const std::vector<FieldView>& fields);

// ---- Embedded tet mesh output (surface.cpp) ----
// Surface as Wavefront OBJ: `mtllib <mtl>`, vertices, then `g surface`/`usemtl surface` with the
// original-surface triangles and `g crack`/`usemtl crack` with the crack triangles (1-based, outward
// counter-clockwise). Coordinates with 9 significant digits.
void write_obj_surface(const std::filesystem::path& target, const SurfaceMesh& surface,
                       const std::string& mtl_file = "surface.mtl");
// The two materials the OBJ files use (grey surface, orange crack).
void write_surface_mtl(const std::filesystem::path& target);
// Surface as binary little-endian PLY: vertex x y z float; face: list uchar int vertex_indices,
// uchar crack, uint fragment.
void write_ply_surface(const std::filesystem::path& target, const SurfaceMesh& surface);
// Surface as VTK XML PolyData (.vtp) with cell data crack (UInt8) and fragment (UInt32): what the
// surface.pvd series lists (ParaView's .pvd reader takes VTK XML files only).
void write_vtp_surface(const std::filesystem::path& target, const SurfaceMesh& surface);
// Tet mesh as VTK XML UnstructuredGrid (VTK_TETRA cells) with per-cell damage (Float64) and
// fragment (UInt32); both arrays have one value per tet.
void write_vtu_tets(const std::filesystem::path& target, const std::vector<Vec3>& vertices,
                    const std::vector<std::array<std::uint32_t, 4>>& tets, const std::vector<double>& damage,
                    const std::vector<std::uint32_t>& fragment);

// A ParaView .pvd collection, rewritten atomically each time a frame is added.
class PvdSeries {
 public:
  explicit PvdSeries(std::filesystem::path target);
  void add(double time, const std::filesystem::path& file);  // file: relative to the .pvd's folder
 private:
  std::filesystem::path target_;
  std::vector<std::pair<double, std::string>> entries_;
};

}  // namespace perifx::io
