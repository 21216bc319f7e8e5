// Mesh and surface files as the model takes them: engine/io parses each format, this file applies
// the geometric checks (tet orientation, degenerate tets, one connected piece, at least one face)
// and turns io's ReadError into GeometryError, the error a scene's mesh problems are reported as.
#include <sstream>
#include <string>
#include <utility>

#include "geometry/mesh_checks.hpp"
#include "io/atomic.hpp"
#include "io/gmsh.hpp"
#include "io/obj.hpp"
#include "io/off.hpp"
#include "io/ply.hpp"
#include "io/stl.hpp"
#include "io/tetgen.hpp"

namespace perifx::geometry {

namespace fs = std::filesystem;

namespace {

// Runs an io reader; its message (file, line, problem) becomes a GeometryError unchanged.
template <class Read>
auto reading(Read&& read) {
  return io::rethrow_as<io::ReadError, GeometryError>(std::forward<Read>(read));
}

// Orients the tets of a file (flipping negative ones is lossless: writers differ in convention) and
// rejects degenerate ones, naming the file and line the tet came from.
TetMesh oriented(io::TetFile file) {
  TetMesh mesh;
  mesh.vertices = std::move(file.vertices);
  mesh.tets = std::move(file.tets);
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    double volume = 0.0, mean_edge = 0.0;
    if (!detail::orient_tet(mesh.vertices, mesh.tets[t], volume, mean_edge)) {
      std::ostringstream msg;
      msg << file.tet_source << ":" << file.tet_line[t] << ": " << file.tet_word << " " << file.tet_id[t]
          << " is degenerate (volume " << volume << ", mean edge " << mean_edge << ")";
      throw GeometryError(msg.str());
    }
  }
  return mesh;
}

SurfaceMesh surface(io::TriangleSurface s, const fs::path& file) {
  if (s.triangles.empty()) throw GeometryError(file.string() + ": no faces in the file");
  return SurfaceMesh{std::move(s.vertices), std::move(s.triangles)};
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c);
  return s;
}

}  // namespace

TetMesh read_tetgen(const fs::path& node_file) {
  io::TetFile file = reading([&] { return io::read_tetgen(node_file); });
  const std::string source = file.tet_source;
  TetMesh mesh = oriented(std::move(file));
  detail::require_one_piece(mesh, source);
  return mesh;
}

TetMesh read_gmsh(const fs::path& path) {
  io::TetFile file = reading([&] { return io::read_gmsh(path); });
  const std::string source = file.tet_source;
  TetMesh mesh = oriented(std::move(file));
  detail::compact_vertices(mesh);  // nodes no tet uses (surface-only nodes, geometry points)
  detail::require_one_piece(mesh, source);
  return mesh;
}

SurfaceMesh read_obj(const fs::path& file) { return surface(reading([&] { return io::read_obj(file); }), file); }
SurfaceMesh read_off(const fs::path& file) { return surface(reading([&] { return io::read_off(file); }), file); }
SurfaceMesh read_stl(const fs::path& file) { return surface(reading([&] { return io::read_stl(file); }), file); }
SurfaceMesh read_ply(const fs::path& file) {
  return surface(reading([&] { return io::read_ply(file).surface; }), file);
}

SurfaceMesh read_surface(const fs::path& file) {
  const std::string ext = lower(file.extension().string());
  if (ext == ".obj") return read_obj(file);
  if (ext == ".ply") return read_ply(file);
  if (ext == ".stl") return read_stl(file);
  if (ext == ".off") return read_off(file);
  throw GeometryError(file.string() + ": unknown surface format '" + ext + "' (expected .obj, .ply, .stl or .off)");
}

}  // namespace perifx::geometry
