// Built-in structured meshers: a Freudenthal (Kuhn) grid for boxes, and for spheres and cylinders
// the grid cut at the surface (cut_and_warp), or carved and surface-snapped where the cut fails.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Geometry>  // cross(); components/math.hpp only brings in Eigen/Core

#include "geometry/geometry.hpp"
#include "geometry/mesh_checks.hpp"

namespace perifx::geometry {

namespace {

using Tet = std::array<std::uint32_t, 4>;

// Keeps the mesh addressable with 32-bit vertex indices and 32-bit face ids (tet * 4 + k), and
// refuses requests that would need tens of GB before trying to allocate them.
constexpr std::uint64_t kMaxTets = 1ull << 29;

std::size_t cells_along(double length, double cell, const char* what) {
  const double n = std::max(1.0, std::round(length / cell));
  if (!(n <= static_cast<double>(kMaxTets))) {
    throw GeometryError(std::string(what) + ": cell " + std::to_string(cell) + " is far too small for length " +
                        std::to_string(length));
  }
  return static_cast<std::size_t>(n);
}

void require_positive(double x, const char* what, const char* name) {
  if (!(std::isfinite(x) && x > 0.0)) {
    throw GeometryError(std::string(what) + ": " + name + " must be positive and finite, got " +
                        std::to_string(x));
  }
}

// A grid of n[0] x n[1] x n[2] cubes spanning `size`, centered at the origin, each cube split into the
// 6 Freudenthal tets: for every permutation (a, b, c) of the axes, the path corner -> +e_a -> +e_b
// -> +e_c. All six share the cube's main diagonal, and because every cube uses the same diagonal
// direction the split of each shared square face (along its (+,+) diagonal) agrees on both sides, so
// the mesh is conforming.
// mirror[a]: on axis a (when its cell count is even) the cubes of the lower half step the other way
// along that axis, so every cube's diagonal points away from the centre planes and the mesh is the
// mirror image of itself; the square faces on a centre plane are split alike from both sides (their
// diagonal depends only on the other two axes' halves), so it stays conforming.
TetMesh freudenthal_grid(const Vec3& size, const std::array<std::size_t, 3>& n, const char* what, const std::array<bool, 3>& mirror = {}) {
  // In double: each n may be up to 2^29, so the integer product could overflow.
  const double cells = static_cast<double>(n[0]) * static_cast<double>(n[1]) * static_cast<double>(n[2]);
  if (cells > static_cast<double>(kMaxTets / 6)) {
    throw GeometryError(std::string(what) + ": " + std::to_string(cells) +
                        " grid cells is too many (the cell size is too small for the body)");
  }
  const auto cubes = static_cast<std::size_t>(cells);
  const std::size_t sx = n[0] + 1, sy = n[1] + 1, sz = n[2] + 1;
  TetMesh mesh;
  mesh.vertices.resize(sx * sy * sz);
  // (i / n − 1/2) * size: the end planes land exactly on ±size/2 (i = 0 and i = n are exact), which the
  // cylinder relies on to recognize its caps.
  auto coord = [&](int axis, std::size_t i) {
    return (static_cast<double>(i) / static_cast<double>(n[static_cast<std::size_t>(axis)]) - 0.5) * size[axis];
  };
  for (std::size_t k = 0; k < sz; ++k) {
    for (std::size_t j = 0; j < sy; ++j) {
      for (std::size_t i = 0; i < sx; ++i) {
        mesh.vertices[i + sx * (j + sy * k)] = Vec3(coord(0, i), coord(1, j), coord(2, k));
      }
    }
  }

  // Vertex-index step for a unit move along each axis.
  const std::uint32_t step[3] = {1u, static_cast<std::uint32_t>(sx), static_cast<std::uint32_t>(sx * sy)};
  // The six axis permutations and their parity. det(e_a, e_b, e_c) = sign of the permutation, so the
  // odd ones get their last two vertices swapped to come out positively oriented.
  static constexpr int kPerm[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
  static constexpr bool kOdd[6] = {false, false, false, true, true, true};
  mesh.tets.reserve(6 * cubes);
  for (std::size_t k = 0; k < n[2]; ++k) {
    for (std::size_t j = 0; j < n[1]; ++j) {
      for (std::size_t i = 0; i < n[0]; ++i) {
        const std::size_t c[3] = {i, j, k};
        bool flip[3] = {false, false, false};
        int flips = 0;
        std::size_t corner[3] = {i, j, k};
        for (int a = 0; a < 3; ++a) {
          flip[a] = mirror[static_cast<std::size_t>(a)] && n[static_cast<std::size_t>(a)] % 2 == 0 && c[a] < n[static_cast<std::size_t>(a)] / 2;
          if (flip[a]) ++corner[a], ++flips;
        }
        const auto v0 = static_cast<std::uint32_t>(corner[0] + sx * (corner[1] + sy * corner[2]));
        // Unsigned wrap-around: adding 0 − step moves one vertex down along the axis.
        std::uint32_t d[3];
        for (int a = 0; a < 3; ++a) d[a] = flip[a] ? 0u - step[a] : step[a];
        for (int p = 0; p < 6; ++p) {
          const std::uint32_t v1 = v0 + d[kPerm[p][0]];
          const std::uint32_t v2 = v1 + d[kPerm[p][1]];
          const std::uint32_t v3 = v2 + d[kPerm[p][2]];
          // Each flipped axis reverses the orientation once more.
          mesh.tets.push_back(kOdd[p] != (flips % 2 == 1) ? Tet{v0, v1, v3, v2} : Tet{v0, v1, v2, v3});
        }
      }
    }
  }
  return mesh;
}

// A curved body for carve_and_snap: the inside test, which boundary faces belong to the curved
// surface (as opposed to exact flat grid planes such as a cylinder's caps), and the closest point
// on that surface (false where it is not unique).
struct CurvedShape {
  std::function<bool(const Vec3&)> inside;
  std::function<bool(const Vec3&, const Vec3&, const Vec3&)> curved_face;
  std::function<bool(const Vec3&, Vec3&)> project;
  // For cut_and_warp: a level function (< 0 inside, 0 on the surface, > 0 outside; the sign is what
  // counts) and where the segment from a point inside to a point outside meets the surface (exactly).
  std::function<double(const Vec3&)> level;
  std::function<Vec3(const Vec3&, const Vec3&)> crossing;
};

using Neighbors = std::vector<std::array<std::int32_t, 4>>;

// The three vertices of tet t other than local vertex k.
std::array<std::uint32_t, 3> face_vertices(const Tet& tet, int k) {
  std::array<std::uint32_t, 3> f{};
  std::size_t n = 0;
  for (int i = 0; i < 4; ++i) {
    if (i != k) f[n++] = tet[static_cast<std::size_t>(i)];
  }
  return f;
}

bool is_curved_face(const TetMesh& mesh, const Tet& tet, int k, const CurvedShape& shape) {
  const auto f = face_vertices(tet, k);
  return shape.curved_face(mesh.vertices[f[0]], mesh.vertices[f[1]], mesh.vertices[f[2]]);
}

// Keeps the largest face-connected group of tets: a tet hanging on by an edge or a vertex shares no
// face with the body, carries no load in the physics and would just be a loose fragment. Ties go to
// the group found first, which keeps the result deterministic.
void keep_largest_component(TetMesh& mesh) {
  const Neighbors neighbors = face_neighbors(mesh);
  const std::size_t nt = mesh.tets.size();
  std::vector<std::int32_t> component(nt, -1);
  std::vector<std::size_t> component_size;
  std::vector<std::uint32_t> stack;
  for (std::size_t seed = 0; seed < nt; ++seed) {
    if (component[seed] >= 0) continue;
    const auto id = static_cast<std::int32_t>(component_size.size());
    std::size_t count = 0;
    component[seed] = id;
    stack.assign(1, static_cast<std::uint32_t>(seed));
    while (!stack.empty()) {
      const std::uint32_t t = stack.back();
      stack.pop_back();
      ++count;
      for (std::int32_t nb : neighbors[t]) {
        if (nb >= 0 && component[static_cast<std::size_t>(nb)] < 0) {
          component[static_cast<std::size_t>(nb)] = id;
          stack.push_back(static_cast<std::uint32_t>(nb));
        }
      }
    }
    component_size.push_back(count);
  }
  if (component_size.size() <= 1) return;
  const auto best = static_cast<std::int32_t>(
      std::max_element(component_size.begin(), component_size.end()) - component_size.begin());
  std::size_t out = 0;
  for (std::size_t t = 0; t < nt; ++t) {
    if (component[t] == best) mesh.tets[out++] = mesh.tets[t];
  }
  mesh.tets.resize(out);
}

// Moves the vertices of curved boundary faces onto the true surface without inverting or flattening
// any tet: no tet may end below kMinVolumeRatio of its grid volume.
//
// Everything is decided from the original positions (Jacobi style), so the result does not depend
// on the order in which vertices are visited. All vertices first aim for the full step onto the
// surface, applied together (neighbors on one surface patch move coherently, so testing them one
// at a time would be needlessly pessimistic). Then, while some tet is below the ratio, the step of
// every moving vertex of every such tet is halved (and dropped once small). This terminates: an
// offending tet always has a moving vertex, steps only shrink, and with nothing moving every tet is
// at 100%.
void snap_to_surface(TetMesh& mesh, const CurvedShape& shape) {
  constexpr double kMinVolumeRatio = 0.2;
  const std::size_t nv = mesh.vertices.size();
  const std::size_t nt = mesh.tets.size();

  const Neighbors neighbors = face_neighbors(mesh);
  std::vector<char> on_surface(nv, 0);
  for (std::size_t t = 0; t < nt; ++t) {
    for (int k = 0; k < 4; ++k) {
      if (neighbors[t][static_cast<std::size_t>(k)] >= 0 || !is_curved_face(mesh, mesh.tets[t], k, shape)) continue;
      for (std::uint32_t v : face_vertices(mesh.tets[t], k)) on_surface[v] = 1;
    }
  }
  const std::vector<Vec3> original = mesh.vertices;
  std::vector<Vec3> delta(nv, Vec3::Zero());
  std::vector<double> step(nv, 0.0);
  for (std::size_t v = 0; v < nv; ++v) {
    Vec3 target;
    if (on_surface[v] && shape.project(original[v], target)) {
      delta[v] = target - original[v];
      step[v] = 1.0;
    }
  }
  std::vector<double> original_volume(nt);
  for (std::size_t t = 0; t < nt; ++t) original_volume[t] = tet_volume(mesh, t);

  std::vector<char> shrink(nv, 0);
  for (;;) {
    for (std::size_t v = 0; v < nv; ++v) mesh.vertices[v] = original[v] + step[v] * delta[v];
    std::fill(shrink.begin(), shrink.end(), 0);
    bool any = false;
    for (std::size_t t = 0; t < nt; ++t) {
      if (tet_volume(mesh, t) >= kMinVolumeRatio * original_volume[t]) continue;
      for (std::uint32_t v : mesh.tets[t]) {
        if (step[v] > 0.0) {
          shrink[v] = 1;
          any = true;
        }
      }
    }
    if (!any) break;
    for (std::size_t v = 0; v < nv; ++v) {
      if (shrink[v]) step[v] = step[v] > 0.2 ? 0.5 * step[v] : 0.0;
    }
  }
}

// Sphere/cylinder mesher: the grid tets whose barycenter is inside, cleaned up, then snapped.
//
// The carved staircase has convex "ridge" tets with two or more faces on the curved boundary. All
// four of their vertices are surface vertices, so projecting them onto a smooth surface flattens
// them, and the snap would have to hold back every vertex they touch, leaving a jagged surface.
// They are peeled off (all at once per pass, so the result is order-independent) until none are
// left; a pass exposes a few new ones, and on these convex shapes it settles in 2–3 passes. The
// volume they held is mostly recovered by the snap pushing the new surface outward.
TetMesh carve_and_snap(const TetMesh& grid, const CurvedShape& shape, const char* what) {
  TetMesh mesh;
  mesh.vertices = grid.vertices;
  mesh.tets.reserve(grid.tets.size());
  for (std::size_t t = 0; t < grid.tets.size(); ++t) {
    if (shape.inside(tet_barycenter(grid, t))) mesh.tets.push_back(grid.tets[t]);
  }

  constexpr int kMaxPeelPasses = 8;  // a safety bound; convex shapes need far fewer
  const std::size_t carved = mesh.tets.size();
  for (int pass = 0; pass < kMaxPeelPasses && !mesh.tets.empty(); ++pass) {
    const Neighbors neighbors = face_neighbors(mesh);
    std::vector<char> ridge(mesh.tets.size(), 0);
    std::size_t kept = 0;
    for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
      int curved_boundary_faces = 0;
      for (int k = 0; k < 4; ++k) {
        if (neighbors[t][static_cast<std::size_t>(k)] < 0 && is_curved_face(mesh, mesh.tets[t], k, shape)) {
          ++curved_boundary_faces;
        }
      }
      ridge[t] = curved_boundary_faces >= 2;
      kept += ridge[t] ? 0 : 1;
    }
    // The ridge fraction grows as the grid coarsens (~5% of the tets at 20 cells per diameter, ~11%
    // at 10). On a very coarse grid peeling would eat the body, so it stops before the total
    // removed would pass kMaxPeeled of the carved tets, keeping the staircase there instead.
    constexpr double kMaxPeeled = 0.15;
    if (kept == mesh.tets.size() ||
        static_cast<double>(carved - kept) > kMaxPeeled * static_cast<double>(carved)) {
      break;
    }
    std::size_t out = 0;
    for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
      if (!ridge[t]) mesh.tets[out++] = mesh.tets[t];
    }
    mesh.tets.resize(out);
  }
  if (mesh.tets.empty()) {
    throw GeometryError(std::string(what) + ": the cell size is too coarse to mesh the body");
  }

  keep_largest_component(mesh);
  detail::compact_vertices(mesh);  // drops unused vertices, keeps the grid order
  snap_to_surface(mesh, shape);
  return mesh;
}


// The grid as freudenthal_grid numbers it: vertex i + sx·(j + sy·k), n cells per axis.
struct GridLayout {
  std::array<std::size_t, 3> n{};
  std::array<bool, 3> mirror{};
};

// Sphere/cylinder mesher (preferred): the grid is cut at the surface, in the manner of isosurface
// stuffing (Labelle & Shewchuk 2007) on the Kuhn grid instead of their BCC lattice.
//   1. Each grid vertex is inside (level < 0) or outside. Where a grid edge crosses the surface, the
//      crossing is the exact point on the surface (CurvedShape::crossing).
//   2. Warp: a vertex with a crossing closer than kWarp of that edge's length is moved onto the
//      nearest such crossing and counts as on the surface. No crossing is then within kWarp of an
//      end, so no cut leaves a sliver: every piece keeps ≥ kWarp of each edge it cuts.
//   3. Each tet keeps the part of it inside: whole (no vertex outside), none (none inside), or cut
//      along its crossings into 1 tet (one vertex inside), a pyramid of 2 tets (two inside, one on
//      the surface) or a prism of 3 tets (two or three inside). A cut face shared by two tets is a
//      quadrilateral whose diagonal both must choose alike: it runs from the quad's least vertex in one
//      global order (grid vertices before crossings; a crossing ranked by its edge), which also makes
//      every prism splittable (Dompierre et al. 1999, least-vertex rule). With `mirror`, the order uses
//      each mirrored axis's distance from the centre plane, so the split is the mirror image too (in
//      one cell a vertex and its mirror image never meet, so the folded order is total there).
// Every boundary vertex is on the surface (a crossing or a warped vertex), where carve_and_snap
// holds back the vertices whose snap would flatten a tet and leaves pits (a 0.1 m ball at 12 cells
// across: 60 of 512 boundary vertices off the sphere, seen as missing grid cubes in a render).
// Returns false (the caller falls back to carve_and_snap) when the cut leaves a tet below
// kMinVolumeRatio of its grid tet or when the grid is too coarse to cut into one piece.
constexpr double kWarp = 0.4;

struct OrderKey {  // the global order of the least-vertex rule
  std::uint8_t crossing = 0;
  std::uint64_t a = 0, b = 0;
  bool operator<(const OrderKey& o) const {
    if (crossing != o.crossing) return crossing < o.crossing;
    if (a != o.a) return a < o.a;
    return b < o.b;
  }
};

bool cut_and_warp(const TetMesh& grid, const GridLayout& layout, const CurvedShape& shape, TetMesh& out) {
  constexpr double kMinVolumeRatio = 0.02;
  const std::size_t nv = grid.vertices.size(), nt = grid.tets.size();
  const std::size_t sx = layout.n[0] + 1, sy = layout.n[1] + 1;
  auto folded = [&](std::uint32_t v) -> std::uint64_t {
    std::size_t c[3] = {v % sx, (v / sx) % sy, v / (sx * sy)};
    for (int a = 0; a < 3; ++a)
      if (layout.mirror[static_cast<std::size_t>(a)] && layout.n[static_cast<std::size_t>(a)] % 2 == 0)
        c[a] = std::min(c[a], layout.n[static_cast<std::size_t>(a)] - c[a]);
    return c[0] + sx * (c[1] + sy * c[2]);
  };
  auto edge_key = [](std::uint32_t a, std::uint32_t b) {
    return a < b ? (std::uint64_t{a} << 32) | b : (std::uint64_t{b} << 32) | a;
  };
  static constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

  // 1–2. Signs, and the warp of vertices too near a crossing (decided from the grid positions).
  std::vector<int> sign(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    const double level = shape.level(grid.vertices[v]);
    sign[v] = level < 0.0 ? -1 : (level > 0.0 ? 1 : 0);
  }
  std::vector<double> warp_distance(nv, kInfinity);
  std::vector<Vec3> warp_to(nv);
  std::vector<char> tie(nv, 0);
  for (std::size_t t = 0; t < nt; ++t) {
    const Tet& tet = grid.tets[t];
    for (const auto& e : kEdges) {
      std::uint32_t a = tet[static_cast<std::size_t>(e[0])], b = tet[static_cast<std::size_t>(e[1])];
      if (sign[a] * sign[b] >= 0) continue;
      if (sign[a] > 0) std::swap(a, b);  // a inside
      const Vec3 c = shape.crossing(grid.vertices[a], grid.vertices[b]);
      const double length = (grid.vertices[b] - grid.vertices[a]).norm();
      for (const std::uint32_t v : {a, b}) {
        const double d = (c - grid.vertices[v]).norm();
        if (!(d < kWarp * length)) continue;
        if (d < warp_distance[v]) {
          // A different crossing as near as the nearest (to rounding) is a tie, which a choice by
          // grid order would break asymmetrically (a vertex on a mirror plane between mirrored
          // crossings): the vertex then goes to its nearest surface point instead.
          tie[v] = std::abs(d - warp_distance[v]) <= 1e-12 * length && (c - warp_to[v]).norm() > 1e-12 * length;
          warp_distance[v] = d, warp_to[v] = c;
        } else if (std::abs(d - warp_distance[v]) <= 1e-12 * length && (c - warp_to[v]).norm() > 1e-12 * length) {
          tie[v] = 1;
        }
      }
    }
  }
  std::vector<Vec3> position = grid.vertices;
  for (std::size_t v = 0; v < nv; ++v) {
    if (!(warp_distance[v] < kInfinity)) continue;
    Vec3 nearest;
    position[v] = tie[v] && shape.project(grid.vertices[v], nearest) ? nearest : warp_to[v];
    sign[v] = 0;
  }

  // The crossings left (edges between an inside and an outside vertex), numbered after the grid
  // vertices in edge-key order.
  std::vector<std::uint64_t> crossing_edges;
  for (std::size_t t = 0; t < nt; ++t) {
    const Tet& tet = grid.tets[t];
    for (const auto& e : kEdges) {
      const std::uint32_t a = tet[static_cast<std::size_t>(e[0])], b = tet[static_cast<std::size_t>(e[1])];
      if (sign[a] * sign[b] < 0) crossing_edges.push_back(edge_key(a, b));
    }
  }
  std::sort(crossing_edges.begin(), crossing_edges.end());
  crossing_edges.erase(std::unique(crossing_edges.begin(), crossing_edges.end()), crossing_edges.end());
  if (nv + crossing_edges.size() > std::numeric_limits<std::uint32_t>::max()) return false;
  std::vector<OrderKey> order(nv + crossing_edges.size());
  for (std::size_t v = 0; v < nv; ++v) order[v] = {0, folded(static_cast<std::uint32_t>(v)), 0};
  out.vertices = position;
  out.vertices.reserve(nv + crossing_edges.size());
  for (std::size_t k = 0; k < crossing_edges.size(); ++k) {
    auto a = static_cast<std::uint32_t>(crossing_edges[k] >> 32), b = static_cast<std::uint32_t>(crossing_edges[k]);
    if (sign[a] > 0) std::swap(a, b);
    out.vertices.push_back(shape.crossing(position[a], position[b]));
    const std::uint64_t fa = folded(a), fb = folded(b);
    order[nv + k] = {1, std::min(fa, fb), std::max(fa, fb)};
  }
  auto crossing_of = [&](std::uint32_t a, std::uint32_t b) {
    const auto it = std::lower_bound(crossing_edges.begin(), crossing_edges.end(), edge_key(a, b));
    return static_cast<std::uint32_t>(nv + static_cast<std::size_t>(it - crossing_edges.begin()));
  };
  auto less = [&](std::uint32_t u, std::uint32_t v) { return order[u] < order[v]; };

  // 3. The inside part of each tet.
  out.tets.clear();
  out.tets.reserve(nt);
  auto emit = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) {
    Tet t{a, b, c, d};
    const Vec3 &p0 = out.vertices[a], &p1 = out.vertices[b], &p2 = out.vertices[c], &p3 = out.vertices[d];
    if ((p1 - p0).cross(p2 - p0).dot(p3 - p0) < 0.0) std::swap(t[2], t[3]);
    out.tets.push_back(t);
  };
  // A pyramid with apex e over the quad (q0 q1 q2 q3, in cyclic order): split along the diagonal
  // from the quad's least vertex.
  auto pyramid = [&](std::uint32_t e, std::array<std::uint32_t, 4> q) {
    std::size_t m = 0;
    for (std::size_t k = 1; k < 4; ++k)
      if (less(q[k], q[m])) m = k;
    const std::uint32_t d0 = q[m], d1 = q[(m + 1) % 4], d2 = q[(m + 2) % 4], d3 = q[(m + 3) % 4];
    emit(e, d0, d1, d2), emit(e, d0, d2, d3);
  };
  // A prism: triangles (v0 v1 v2) and (v3 v4 v5), edges v0–v3, v1–v4, v2–v5; its three quads are split
  // by the least-vertex rule, which never makes the three diagonals cyclic.
  auto prism = [&](std::array<std::uint32_t, 6> v) {
    std::size_t m = 0;
    for (std::size_t k = 1; k < 6; ++k)
      if (less(v[k], v[m])) m = k;
    // Turn the prism so the least vertex is v0 (a rotation of the triangles, or their swap).
    static constexpr int kTurn[6][6] = {{0, 1, 2, 3, 4, 5}, {1, 2, 0, 4, 5, 3}, {2, 0, 1, 5, 3, 4},
                                        {3, 5, 4, 0, 2, 1}, {4, 3, 5, 1, 0, 2}, {5, 4, 3, 2, 1, 0}};
    std::array<std::uint32_t, 6> r{};
    for (int k = 0; k < 6; ++k) r[static_cast<std::size_t>(k)] = v[static_cast<std::size_t>(kTurn[m][k])];
    // The diagonals from v0 run to v4 and v5; the quad (v1 v2 v5 v4) takes its own least vertex.
    const std::uint32_t least15 = less(r[1], r[5]) ? r[1] : r[5], least24 = less(r[2], r[4]) ? r[2] : r[4];
    if (less(least15, least24)) emit(r[0], r[1], r[2], r[5]), emit(r[0], r[1], r[5], r[4]);
    else emit(r[0], r[1], r[2], r[4]), emit(r[0], r[4], r[2], r[5]);
    emit(r[0], r[4], r[5], r[3]);
  };
  for (std::size_t t = 0; t < nt; ++t) {
    const Tet& tet = grid.tets[t];
    std::array<std::uint32_t, 4> in{}, on{}, outside{};
    std::size_t n_in = 0, n_on = 0, n_out = 0;
    for (const std::uint32_t v : tet) {
      if (sign[v] < 0) in[n_in++] = v;
      else if (sign[v] == 0) on[n_on++] = v;
      else outside[n_out++] = v;
    }
    // None inside: nothing (a tet with every vertex on the surface is a sliver under the surface
    // patch its vertices span; its faces become boundary faces of its neighbours, all on the surface).
    if (n_in == 0) continue;
    if (n_out == 0) {
      emit(tet[0], tet[1], tet[2], tet[3]);
      continue;
    }
    if (n_in == 1) {
      // A tet: the inside vertex, the surface vertices and the crossings toward the outside ones.
      std::array<std::uint32_t, 4> v{in[0], 0, 0, 0};
      std::size_t k = 1;
      for (std::size_t j = 0; j < n_on; ++j) v[k++] = on[j];
      for (std::size_t j = 0; j < n_out; ++j) v[k++] = crossing_of(in[0], outside[j]);
      emit(v[0], v[1], v[2], v[3]);
    } else if (n_in == 2 && n_out == 1) {
      // A pyramid: apex the surface vertex, base on the face (in0 in1 out).
      pyramid(on[0], {in[0], in[1], crossing_of(in[1], outside[0]), crossing_of(in[0], outside[0])});
    } else if (n_in == 2) {
      // A prism: (in0, c(in0,o0), c(in0,o1)) over (in1, c(in1,o0), c(in1,o1)).
      prism({in[0], crossing_of(in[0], outside[0]), crossing_of(in[0], outside[1]), in[1],
             crossing_of(in[1], outside[0]), crossing_of(in[1], outside[1])});
    } else {
      // Three inside: the tet less its corner at the outside vertex, a prism.
      prism({in[0], in[1], in[2], crossing_of(in[0], outside[0]), crossing_of(in[1], outside[0]),
             crossing_of(in[2], outside[0])});
    }
  }
  if (out.tets.empty()) return false;
  const double grid_volume = tet_volume(grid, 0);
  for (std::size_t t = 0; t < out.tets.size(); ++t)
    if (!(tet_volume(out, t) >= kMinVolumeRatio * grid_volume)) return false;
  const std::size_t before = out.tets.size();
  keep_largest_component(out);
  if (out.tets.size() < before) return false;  // the cut split the body: too coarse a grid
  detail::compact_vertices(out);
  return true;
}

}  // namespace

TetMesh mesh_box(const Vec3& size, double cell, const std::array<bool, 3>& mirror) {
  require_positive(size.x(), "mesh_box", "size.x");
  require_positive(size.y(), "mesh_box", "size.y");
  require_positive(size.z(), "mesh_box", "size.z");
  require_positive(cell, "mesh_box", "cell");
  const std::array<std::size_t, 3> n = {cells_along(size.x(), cell, "mesh_box"),
                                        cells_along(size.y(), cell, "mesh_box"),
                                        cells_along(size.z(), cell, "mesh_box")};
  return freudenthal_grid(size, n, "mesh_box", mirror);
}

TetMesh mesh_sphere(double radius, double cell, const std::array<bool, 3>& mirror) {
  require_positive(radius, "mesh_sphere", "radius");
  require_positive(cell, "mesh_sphere", "cell");
  const double diameter = 2.0 * radius;
  const std::size_t n = cells_along(diameter, cell, "mesh_sphere");
  const TetMesh grid = freudenthal_grid(Vec3::Constant(diameter), {n, n, n}, "mesh_sphere", mirror);

  const double r2 = radius * radius;
  const double tiny = 1e-12 * radius;
  CurvedShape sphere;
  sphere.inside = [r2](const Vec3& b) { return b.squaredNorm() <= r2; };
  sphere.curved_face = [](const Vec3&, const Vec3&, const Vec3&) { return true; };
  sphere.project = [radius, tiny](const Vec3& p, Vec3& target) {
    const double d = p.norm();
    if (d <= tiny) return false;  // the center has no unique closest surface point
    target = (radius / d) * p;
    return true;
  };
  sphere.level = [r2](const Vec3& p) { return p.squaredNorm() - r2; };
  sphere.crossing = [radius](const Vec3& p, const Vec3& q) {
    // |p + s (q − p)| = R with |p| < R < |q|: the root in (0, 1) of a s² + 2 b s + c = 0.
    const Vec3 d = q - p;
    const double a = d.squaredNorm(), b = p.dot(d), c = p.squaredNorm() - radius * radius;
    const double s = (-b + std::sqrt(std::max(0.0, b * b - a * c))) / a;
    const Vec3 x = p + std::clamp(s, 0.0, 1.0) * d;
    return Vec3((radius / x.norm()) * x);  // on the sphere to rounding
  };
  TetMesh cut;
  if (cut_and_warp(grid, {{n, n, n}, mirror}, sphere, cut)) return cut;
  return carve_and_snap(grid, sphere, "mesh_sphere");
}

TetMesh mesh_cylinder(double radius, double height, int axis, double cell, const std::array<bool, 3>& mirror) {
  require_positive(radius, "mesh_cylinder", "radius");
  require_positive(height, "mesh_cylinder", "height");
  require_positive(cell, "mesh_cylinder", "cell");
  if (axis < 0 || axis > 2) {
    throw GeometryError("mesh_cylinder: axis must be 0, 1 or 2, got " + std::to_string(axis));
  }
  const double diameter = 2.0 * radius;
  Vec3 size = Vec3::Constant(diameter);
  size[axis] = height;
  std::array<std::size_t, 3> n{};
  for (int a = 0; a < 3; ++a) {
    n[static_cast<std::size_t>(a)] = cells_along(size[a], cell, "mesh_cylinder");
  }
  const TetMesh grid = freudenthal_grid(size, n, "mesh_cylinder", mirror);

  auto radial = [axis](const Vec3& p) {
    Vec3 r = p;
    r[axis] = 0.0;
    return r;
  };
  // The grid spans the height exactly, so only the radial test carves and the caps are the grid's
  // end planes, already exact. A boundary face lying in a cap plane must not pull its vertices
  // radially; every other boundary face is on the side. A rim vertex (on both) moves radially
  // within its cap. The end-plane coordinates are computed exactly as freudenthal_grid computes them.
  const double cap_lo = -0.5 * height, cap_hi = 0.5 * height;
  const double r2 = radius * radius;
  const double tiny = 1e-12 * radius;
  CurvedShape cylinder;
  cylinder.inside = [=](const Vec3& b) { return radial(b).squaredNorm() <= r2; };
  cylinder.curved_face = [=](const Vec3& p0, const Vec3& p1, const Vec3& p2) {
    const double w = p0[axis];
    const bool cap = w == p1[axis] && w == p2[axis] && (w == cap_lo || w == cap_hi);
    return !cap;
  };
  cylinder.project = [=](const Vec3& p, Vec3& target) {
    const Vec3 r = radial(p);
    const double d = r.norm();
    if (d <= tiny) return false;  // on the axis: no unique closest side point
    target = p + (radius / d - 1.0) * r;
    return true;
  };
  cylinder.level = [=](const Vec3& p) { return radial(p).squaredNorm() - r2; };
  cylinder.crossing = [=](const Vec3& p, const Vec3& q) {
    // The same quadratic in the plane across the axis; the axial coordinate follows the segment.
    const Vec3 d = q - p, pr = radial(p), dr = radial(d);
    const double a = dr.squaredNorm(), b = pr.dot(dr), c = pr.squaredNorm() - r2;
    const double s = (-b + std::sqrt(std::max(0.0, b * b - a * c))) / a;
    Vec3 x = p + std::clamp(s, 0.0, 1.0) * d;
    const double w = x[axis];
    x = radial(x);
    x *= radius / x.norm();
    x[axis] = w;
    return x;
  };
  TetMesh cut;
  if (cut_and_warp(grid, {n, mirror}, cylinder, cut)) return cut;
  return carve_and_snap(grid, cylinder, "mesh_cylinder");
}

}  // namespace perifx::geometry
