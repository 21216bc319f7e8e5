// Checks shared by the mesh file loaders (mesh_checks.hpp): tet orientation, vertex compaction and
// the one-piece check.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Geometry>  // cross()

#include "geometry/mesh_checks.hpp"
#include "systems/union_find.hpp"

namespace perifx::geometry::detail {

double signed_volume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return (b - a).dot((c - a).cross(d - a)) / 6.0;
}

bool orient_tet(const std::vector<Vec3>& vertices, std::array<std::uint32_t, 4>& tet, double& volume,
                double& mean_edge) {
  const Vec3& p0 = vertices[tet[0]];
  const Vec3& p1 = vertices[tet[1]];
  const Vec3& p2 = vertices[tet[2]];
  const Vec3& p3 = vertices[tet[3]];
  volume = signed_volume(p0, p1, p2, p3);
  mean_edge = ((p1 - p0).norm() + (p2 - p0).norm() + (p3 - p0).norm() + (p2 - p1).norm() + (p3 - p1).norm() +
               (p3 - p2).norm()) / 6.0;
  // Scale-free flatness test against the tet's own size, so a small but well-shaped tet is fine.
  if (!(std::abs(volume) > 1e-12 * mean_edge * mean_edge * mean_edge)) return false;
  if (volume < 0.0) std::swap(tet[2], tet[3]);  // other writers use the opposite convention
  return true;
}

void compact_vertices(TetMesh& mesh) {
  constexpr std::uint32_t kUnused = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> remap(mesh.vertices.size(), kUnused);
  for (const auto& tet : mesh.tets) {
    for (std::uint32_t v : tet) remap[v] = 0;
  }
  std::uint32_t next = 0;
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    if (remap[v] == kUnused) continue;
    remap[v] = next;
    mesh.vertices[next++] = mesh.vertices[v];
  }
  mesh.vertices.resize(next);
  for (auto& tet : mesh.tets) {
    for (auto& v : tet) v = remap[v];
  }
}

void require_one_piece(const TetMesh& mesh, const std::string& source) {
  const std::size_t nt = mesh.tets.size();
  if (nt == 0) return;
  try {
    (void)face_neighbors(mesh);  // rejects faces shared by 3+ tets, and bad vertex indices
  } catch (const GeometryError& e) {
    throw GeometryError(source + ": " + e.what());
  }
  // Pieces are groups of tets linked through shared vertices. A tet hanging on by an edge or a
  // vertex (voxel meshes have some) still belongs to the body: distance-based bonds reach across;
  // a piece that shares no vertex at all is a separate object.
  std::vector<std::uint32_t> parent;
  systems::UnionFind sets(parent, mesh.vertices.size());
  for (const auto& t : mesh.tets) {
    for (std::size_t i = 1; i < 4; ++i) sets.unite(t[0], t[i]);
  }
  std::vector<std::uint32_t> piece_of_root(mesh.vertices.size(), UINT32_MAX);
  std::vector<std::size_t> sizes;
  for (const auto& t : mesh.tets) {
    const std::uint32_t r = sets.find(t[0]);
    if (piece_of_root[r] == UINT32_MAX) {
      piece_of_root[r] = static_cast<std::uint32_t>(sizes.size());
      sizes.push_back(0);
    }
    ++sizes[piece_of_root[r]];
  }
  if (sizes.size() > 1) {
    std::string list;
    for (std::size_t k = 0; k < sizes.size() && k < 5; ++k) list += (k ? ", " : "") + std::to_string(sizes[k]);
    if (sizes.size() > 5) list += ", ...";
    throw GeometryError(source + ": mesh has " + std::to_string(sizes.size()) + " disconnected pieces (" + list +
                        " tets, sharing no vertex); split them into separate bodies");
  }
}

}  // namespace perifx::geometry::detail
