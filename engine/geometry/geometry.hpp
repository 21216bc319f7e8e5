// Tetrahedral meshes for bodies: a built-in structured mesher for primitives, TetGen and Gmsh file
// input, closed surfaces (OBJ/PLY/STL/OFF) filled with tets by the external `tetgen` program,
// and the mesh measures the model needs (volumes, mean edge length λ, face adjacency, Morton order).
// Files: structured.cpp (meshers), mesh_files.cpp (the file readers: engine/io parses, this applies
// the checks), mesh_checks.* (orientation, compaction, one piece), surface_mesh.cpp (closed-surface
// checks, the tetgen program call), measures.cpp.
#pragma once
#include <array>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "components/tet_mesh.hpp"
#include "perifx/errors.hpp"

namespace perifx::geometry {

// Structured meshers. Each fills a grid of cubes of side ~cell (adjusted so a whole number of cells
// spans the box) and splits every cube into 6 tets around its main diagonal (Freudenthal/Kuhn), which
// gives a conforming mesh of congruent tets. Meshes are centered at the origin.
// mirror[a]: mirror-symmetric about the centre plane normal to axis a (when its cell count is even):
// the cubes on the lower side are split around the mirror image of the upper side's diagonal.
TetMesh mesh_box(const Vec3& size, double cell, const std::array<bool, 3>& mirror = {});
// Sphere and cylinder: the grid covering the shape cut at the true surface (vertices within 0.4 of an
// edge from the surface moved onto it, the tets crossing it cut into 1–3 tets each), so every boundary
// vertex is on the surface and no tet is below ~9 % of a grid tet (worst mean ratio 0.31–0.55 at 3–40
// cells across). Where the cut fails (it would leave a tet below 2 %, or two pieces), the older
// carve-and-snap: tets with the barycenter inside, boundary vertices moved onto the surface where
// that keeps every tet valid (some held back, seen as pits).
TetMesh mesh_sphere(double radius, double cell, const std::array<bool, 3>& mirror = {});
TetMesh mesh_cylinder(double radius, double height, int axis, double cell, const std::array<bool, 3>& mirror = {});
// jitter.cpp: moves every vertex by a seeded random offset of up to `amplitude` × its shortest edge
// per axis (boundary vertices only within their flat face or along their straight edge; corners and
// curved boundaries fixed), keeping every tet above a quarter of its volume. Deterministic for a
// seed. Returns how many vertices moved. Removes the grid's preferred crack directions.
// mirror[a]: a vertex's random offset depends on its position with coordinate a taken absolute (not on
// its index) and is mirrored with it, so a mesh symmetric about the plane x_a = 0 stays symmetric
// (vertices on the plane stay on it).
std::size_t jitter_vertices(TetMesh& mesh, double amplitude, std::uint64_t seed, const std::array<bool, 3>& mirror = {});

// TetGen .node/.ele (1- or 0-based, optional attributes and markers). `node_file` names the .node
// file; the .ele beside it is read. Negatively oriented tets are flipped; degenerate ones are errors.
TetMesh read_tetgen(const std::filesystem::path& node_file);

// Gmsh .msh, ASCII format 2.2 or 4.1. Only tetrahedra are read (element type 4, and the corners of
// 10-node type 11); points, lines, triangles and other elements are ignored, as are nodes no tet uses.
// Node tags may be sparse. Tets are oriented and checked as read_tetgen does.
TetMesh read_gmsh(const std::filesystem::path& file);
// Every tet loader (read_tetgen, read_gmsh, mesh_surface) also rejects meshes whose tets form more
// than one piece (groups sharing no vertex): "mesh has K disconnected pieces; split them into
// separate bodies". Tets attached to the rest only by an edge or a vertex are accepted.

// A triangulated surface (polygons of the input are split into fans).
struct SurfaceMesh {
  std::vector<Vec3> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
};

// Surface readers. OBJ: v/f lines ("f 1/2/3", negative indices; vt/vn/groups ignored). PLY: ASCII or
// binary (little or big endian), "vertex" x/y/z and "face" index lists. STL: ASCII or binary;
// coincident vertices are merged within 1e-6 of the bounding-box diagonal and triangles that collapse
// are dropped. OFF (also COFF/NOFF). read_surface picks the reader by extension (.obj .ply .stl .off).
SurfaceMesh read_obj(const std::filesystem::path& file);
SurfaceMesh read_ply(const std::filesystem::path& file);
SurfaceMesh read_stl(const std::filesystem::path& file);
SurfaceMesh read_off(const std::filesystem::path& file);
SurfaceMesh read_surface(const std::filesystem::path& file);

// Checks that the surface bounds one solid and orients it outward, in place. Errors (prefixed with
// `source`): zero-area triangles, open surfaces (boundary edges), non-manifold edges (> 2 triangles),
// non-orientable surfaces, several disconnected pieces. Inconsistently oriented triangles are flipped
// to agree with their neighbors, then all of them if the enclosed volume comes out negative.
void check_closed_surface(SurfaceMesh& surface, const std::string& source);
// Signed volume enclosed by a closed surface (divergence theorem); > 0 when oriented outward.
double enclosed_volume(const SurfaceMesh& surface);

// How finely to fill a surface with tets: the first that is set wins. TetGen takes a volume bound,
// not a size; the bound is calibrated (≈ 4.6 h³/(6√2) for a mean edge h, volume/particles for a
// count) and then rescaled over up to two more runs toward the target. The surface's own triangles
// are kept, so a surface finer than the target gives a finer mesh.
struct SurfaceResolution {
  double edge_length = 0.0;   // target mean tet edge h
  long long particles = 0;    // target tet count
  int resolution = 20;        // else h = longest bounding-box extent / resolution
};
// Tetrahedralizes a closed surface by running the `tetgen` program (`tetgen -pq1.414a<bound>` on a
// .smesh in a private temp directory). Checks the surface first (check_closed_surface). Throws
// GeometryError when `tetgen` is not on PATH or fails (with the tail of its output).
TetMesh mesh_surface(SurfaceMesh surface, const SurfaceResolution& resolution, const std::string& source);
// read_surface + mesh_surface.
TetMesh load_surface(const std::filesystem::path& file, const SurfaceResolution& resolution);

double tet_volume(const TetMesh& mesh, std::size_t tet);            // > 0 for valid tets
Vec3 tet_barycenter(const TetMesh& mesh, std::size_t tet);
double mean_edge_length(const TetMesh& mesh);                        // λ, over unique edges

// For each tet, the tet across the face opposite local vertex k, or −1 on the boundary.
std::vector<std::array<std::int32_t, 4>> face_neighbors(const TetMesh& mesh);

// Order of points along a Z-order (Morton) curve in their bounding box: result[k] = index of the
// k-th point. Ties broken by index, so the order is deterministic.
std::vector<std::uint32_t> morton_order(const std::vector<Vec3>& points);
// Reorders tets: new tet k = old tet order[k]. Vertices are untouched.
void reorder_tets(TetMesh& mesh, const std::vector<std::uint32_t>& order);

}  // namespace perifx::geometry
