// Mirror-symmetric structured meshes (geometry.mirror; engine/geometry/structured.cpp, jitter.cpp):
// the mesh with its jitter is its own mirror image about the chosen centre plane, exactly in its
// topology and to round-off in its positions; it stays conforming and positively oriented.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "geometry/geometry.hpp"

using namespace perifx;
using namespace perifx::geometry;

namespace {

double volume(const TetMesh& m, const std::array<std::uint32_t, 4>& t) {
  return (m.vertices[t[1]] - m.vertices[t[0]]).dot((m.vertices[t[2]] - m.vertices[t[0]]).cross(m.vertices[t[3]] - m.vertices[t[0]])) / 6.0;
}

// For each vertex, the vertex at its mirror image about x_axis = 0 (within tol), or −1.
std::vector<long> mirror_map(const TetMesh& m, int axis, double tol) {
  std::vector<long> out(m.vertices.size(), -1);
  std::map<std::array<long long, 3>, std::uint32_t> cell;
  auto key = [&](const Vec3& p) {
    return std::array<long long, 3>{std::llround(p.x() / (10 * tol)), std::llround(p.y() / (10 * tol)), std::llround(p.z() / (10 * tol))};
  };
  for (std::uint32_t v = 0; v < m.vertices.size(); ++v) cell[key(m.vertices[v])] = v;
  for (std::uint32_t v = 0; v < m.vertices.size(); ++v) {
    Vec3 p = m.vertices[v];
    p[axis] = -p[axis];
    const auto it = cell.find(key(p));
    if (it != cell.end() && (m.vertices[it->second] - p).norm() < tol) out[v] = it->second;
  }
  return out;
}

// Tets (as vertex sets) whose mirror image is not a tet.
std::size_t unmirrored_tets(const TetMesh& m, const std::vector<long>& map) {
  std::set<std::array<std::uint32_t, 4>> tets;
  for (auto t : m.tets) {
    std::sort(t.begin(), t.end());
    tets.insert(t);
  }
  std::size_t bad = 0;
  for (const auto& t : m.tets) {
    std::array<std::uint32_t, 4> u{};
    bool ok = true;
    for (int c = 0; c < 4; ++c) {
      ok = ok && map[t[static_cast<std::size_t>(c)]] >= 0;
      u[static_cast<std::size_t>(c)] = ok ? static_cast<std::uint32_t>(map[t[static_cast<std::size_t>(c)]]) : 0u;
    }
    std::sort(u.begin(), u.end());
    bad += !ok || !tets.count(u);
  }
  return bad;
}

}  // namespace

TEST_CASE("mirror mesh: a mirrored, jittered box is its own mirror image, conforming and positive") {
  const Vec3 size(0.2, 0.1, 0.02);
  const double cell = 0.01;  // 20 × 10 × 2 cells
  const double tol = 1e-12;
  // The default grid is not symmetric about x = 0 (every cube split around the same diagonal).
  {
    const TetMesh plain = mesh_box(size, cell);
    CHECK(unmirrored_tets(plain, mirror_map(plain, 0, tol)) > 0);
  }
  TetMesh m = mesh_box(size, cell, {true, false, false});
  const TetMesh grid = m;
  CHECK(m.tets.size() == 6u * 20 * 10 * 2);
  CHECK(unmirrored_tets(m, mirror_map(m, 0, tol)) == 0);
  const std::size_t moved = jitter_vertices(m, 0.3, 5, {true, false, false});
  CHECK(moved > m.vertices.size() / 2);
  const auto map = mirror_map(m, 0, tol);
  CHECK(std::count(map.begin(), map.end(), -1L) == 0);
  CHECK(unmirrored_tets(m, map) == 0);
  // Vertices on the plane x = 0 stay on it; jittered positions differ from the grid's.
  std::size_t off_plane = 0;
  for (std::size_t v = 0; v < m.vertices.size(); ++v)
    if (grid.vertices[v].x() == 0.0) off_plane += m.vertices[v].x() != 0.0;
  CHECK(off_plane == 0);
  // Conforming (every interior face shared by exactly two tets) and positively oriented.
  const auto nb = face_neighbors(m);
  std::size_t boundary = 0;
  for (const auto& t : nb)
    for (auto u : t) boundary += u < 0;
  CHECK(boundary == 2u * 2 * (20 * 10 + 20 * 2 + 10 * 2));  // two triangles per boundary square
  double min_volume = 1e300;
  for (const auto& t : m.tets) min_volume = std::min(min_volume, volume(m, t));
  CHECK(min_volume > 0.25 * cell * cell * cell / 6.0 * 0.999);
  // Not mirrored about y: the jitter is not symmetric in y.
  CHECK(unmirrored_tets(m, mirror_map(m, 1, tol)) > 0);
}
