// Tetrahedral meshes for bodies: a built-in structured mesher for primitives, TetGen file input,
// and the mesh measures the model needs (volumes, mean edge length λ, face adjacency, Morton order).
#pragma once
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "components/tet_mesh.hpp"

namespace perifx::geometry {

// A mesh that cannot be used; what() names the file and line when there is one.
class GeometryError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Structured meshers. Each fills a grid of cubes of side ~cell (adjusted so a whole number of cells
// spans the box) and splits every cube into 6 tets around its main diagonal (Freudenthal/Kuhn), which
// gives a conforming mesh of congruent tets. Meshes are centered at the origin.
TetMesh mesh_box(const Vec3& size, double cell);
// Sphere and cylinder: the cubes of a grid covering the shape, tets kept when their barycenter is
// inside, then boundary vertices moved onto the true surface where that keeps every tet valid.
TetMesh mesh_sphere(double radius, double cell);
TetMesh mesh_cylinder(double radius, double height, int axis, double cell);

// TetGen .node/.ele (1- or 0-based, optional attributes and markers). `node_file` names the .node
// file; the .ele beside it is read. Negatively oriented tets are flipped; degenerate ones are errors.
TetMesh read_tetgen(const std::filesystem::path& node_file);

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
