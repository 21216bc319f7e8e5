// Mesh measures and orderings: tet volume/barycenter, mean edge length λ, face adjacency, Morton
// order. These run once at setup on meshes of up to ~1e6 tets, so the adjacency-type queries avoid
// node-based containers: items are bucketed by their smallest vertex (a counting sort, O(n)) and
// only the short per-vertex buckets are sorted.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>  // cross(); components/math.hpp only brings in Eigen/Core

#include "geometry/geometry.hpp"
#include "systems/parallel.hpp"

namespace perifx::geometry {

namespace {

// Every tet must reference existing vertices; the bucketing below indexes arrays by vertex id, so a
// bad index would be memory corruption rather than a wrong answer.
void check_tet_indices(const TetMesh& mesh) {
  const std::size_t nv = mesh.vertices.size();
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    for (std::uint32_t v : mesh.tets[t]) {
      if (v >= nv) {
        throw GeometryError("tet " + std::to_string(t) + " references vertex " + std::to_string(v) +
                            " but the mesh has " + std::to_string(nv) + " vertices");
      }
    }
  }
}

// Prefix offsets of a counting sort: offsets[v]..offsets[v+1] is bucket v.
std::vector<std::size_t> bucket_offsets(const std::vector<std::size_t>& counts) {
  std::vector<std::size_t> offsets(counts.size() + 1, 0);
  for (std::size_t v = 0; v < counts.size(); ++v) offsets[v + 1] = offsets[v] + counts[v];
  return offsets;
}

// Spreads the low 21 bits of x so that bit i lands on bit 3i (the classic magic-mask sequence).
std::uint64_t spread_bits_3(std::uint64_t x) {
  x &= 0x1fffffULL;
  x = (x | x << 32) & 0x1f00000000ffffULL;
  x = (x | x << 16) & 0x1f0000ff0000ffULL;
  x = (x | x << 8) & 0x100f00f00f00f00fULL;
  x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
  x = (x | x << 2) & 0x1249249249249249ULL;
  return x;
}

}  // namespace

double tet_volume(const TetMesh& mesh, std::size_t tet) {
  const auto& t = mesh.tets[tet];
  const Vec3& p0 = mesh.vertices[t[0]];
  const Vec3 a = mesh.vertices[t[1]] - p0;
  const Vec3 b = mesh.vertices[t[2]] - p0;
  const Vec3 c = mesh.vertices[t[3]] - p0;
  return a.dot(b.cross(c)) / 6.0;
}

Vec3 tet_barycenter(const TetMesh& mesh, std::size_t tet) {
  const auto& t = mesh.tets[tet];
  return 0.25 * (mesh.vertices[t[0]] + mesh.vertices[t[1]] + mesh.vertices[t[2]] + mesh.vertices[t[3]]);
}

double mean_edge_length(const TetMesh& mesh) {
  if (mesh.tets.empty()) return 0.0;
  check_tet_indices(mesh);
  static constexpr int kEdge[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

  // Bucket each edge's larger endpoint under its smaller endpoint; duplicates (an edge is shared by
  // several tets) then sit in the same short bucket and a local sort+unique removes them.
  const std::size_t nv = mesh.vertices.size();
  std::vector<std::size_t> counts(nv, 0);
  for (const auto& t : mesh.tets) {
    for (const auto& e : kEdge) ++counts[std::min(t[e[0]], t[e[1]])];
  }
  const std::vector<std::size_t> offsets = bucket_offsets(counts);
  std::vector<std::uint32_t> other(offsets.back());
  std::vector<std::size_t> fill(offsets.begin(), offsets.end() - 1);
  for (const auto& t : mesh.tets) {
    for (const auto& e : kEdge) {
      const std::uint32_t a = t[e[0]], b = t[e[1]];
      other[fill[std::min(a, b)]++] = std::max(a, b);
    }
  }

  double sum = 0.0;
  std::size_t unique_edges = 0;
  for (std::size_t v = 0; v < nv; ++v) {
    auto first = other.begin() + static_cast<std::ptrdiff_t>(offsets[v]);
    auto last = other.begin() + static_cast<std::ptrdiff_t>(offsets[v + 1]);
    std::sort(first, last);
    last = std::unique(first, last);
    for (auto it = first; it != last; ++it) {
      // A repeated vertex inside a tet makes a zero-length "edge" v–v; it is not an edge.
      if (*it == v) continue;
      sum += (mesh.vertices[*it] - mesh.vertices[v]).norm();
      ++unique_edges;
    }
  }
  return unique_edges == 0 ? 0.0 : sum / static_cast<double>(unique_edges);
}

std::vector<std::array<std::int32_t, 4>> face_neighbors(const TetMesh& mesh) {
  const std::size_t nt = mesh.tets.size();
  // Faces are identified by tet * 4 + k in 32 bits.
  if (nt > static_cast<std::size_t>(UINT32_MAX / 4)) {
    throw GeometryError("mesh has too many tets for 32-bit face ids: " + std::to_string(nt));
  }
  check_tet_indices(mesh);
  std::vector<std::array<std::int32_t, 4>> result(nt, {-1, -1, -1, -1});
  if (nt == 0) return result;

  // Face k of a tet is the sorted triple of its vertices other than local vertex k. The face is
  // bucketed by its smallest vertex a, and within the bucket identified by the 64-bit key (b, c).
  struct FaceEntry {
    std::uint64_t key;  // (b << 32) | c
    std::uint32_t id;   // tet * 4 + k; the sort tiebreak, so the outcome does not depend on the sort
  };
  auto sorted_face = [](const std::array<std::uint32_t, 4>& t, int k) {
    std::array<std::uint32_t, 3> f{};
    int n = 0;
    for (int i = 0; i < 4; ++i) {
      if (i != k) f[static_cast<std::size_t>(n++)] = t[static_cast<std::size_t>(i)];
    }
    if (f[0] > f[1]) std::swap(f[0], f[1]);
    if (f[1] > f[2]) std::swap(f[1], f[2]);
    if (f[0] > f[1]) std::swap(f[0], f[1]);
    return f;
  };

  const std::size_t nv = mesh.vertices.size();
  std::vector<std::size_t> counts(nv, 0);
  for (const auto& t : mesh.tets) {
    for (int k = 0; k < 4; ++k) ++counts[sorted_face(t, k)[0]];
  }
  const std::vector<std::size_t> offsets = bucket_offsets(counts);
  std::vector<FaceEntry> faces(offsets.back());
  std::vector<std::size_t> fill(offsets.begin(), offsets.end() - 1);
  for (std::size_t ti = 0; ti < nt; ++ti) {
    for (int k = 0; k < 4; ++k) {
      const auto f = sorted_face(mesh.tets[ti], k);
      faces[fill[f[0]]++] = {(static_cast<std::uint64_t>(f[1]) << 32) | f[2],
                             static_cast<std::uint32_t>(ti * 4 + static_cast<std::size_t>(k))};
    }
  }

  // The buckets are independent (each face id is in one bucket, so each result slot is written once):
  // sorted and matched in parallel. A face shared by three or more tets marks its bucket; the first
  // marked bucket is reported afterwards, so the message does not depend on the thread count.
  std::vector<std::uint8_t> non_manifold(nv, 0);
  auto match_bucket = [&](std::size_t v, bool report) {
    auto first = faces.begin() + static_cast<std::ptrdiff_t>(offsets[v]);
    auto last = faces.begin() + static_cast<std::ptrdiff_t>(offsets[v + 1]);
    if (!report)
      std::sort(first, last, [](const FaceEntry& x, const FaceEntry& y) {
        return x.key != y.key ? x.key < y.key : x.id < y.id;
      });
    for (auto run = first; run != last;) {
      auto end = run + 1;
      while (end != last && end->key == run->key) ++end;
      const auto multiplicity = end - run;
      if (multiplicity == 2 && !report) {
        const std::uint32_t a = run[0].id, b = run[1].id;
        result[a / 4][a % 4] = static_cast<std::int32_t>(b / 4);
        result[b / 4][b % 4] = static_cast<std::int32_t>(a / 4);
      } else if (multiplicity > 2) {
        // Three or more tets on one triangle: no consistent "other side" exists, and the physics
        // would double-count the contact across it.
        if (!report) {
          non_manifold[v] = 1;
        } else {
          throw GeometryError("non-manifold mesh: face (" + std::to_string(v) + ", " +
                              std::to_string(run->key >> 32) + ", " +
                              std::to_string(run->key & 0xffffffffULL) + ") is shared by " +
                              std::to_string(multiplicity) + " tets (first: tet " +
                              std::to_string(run[0].id / 4) + ")");
        }
      }
      run = end;
    }
  };
  parallel_for_each(nv, [&](std::size_t v) { match_bucket(v, false); }, 1024);
  for (std::size_t v = 0; v < nv; ++v)
    if (non_manifold[v]) match_bucket(v, true);
  return result;
}

std::vector<std::uint32_t> morton_order(const std::vector<Vec3>& points) {
  const std::size_t n = points.size();
  if (n > static_cast<std::size_t>(UINT32_MAX)) {
    throw GeometryError("too many points for a 32-bit Morton order: " + std::to_string(n));
  }
  std::vector<std::uint32_t> order(n);
  if (n == 0) return order;

  Vec3 lo = points[0], hi = points[0];
  for (std::size_t i = 0; i < n; ++i) {
    if (!points[i].allFinite()) {
      throw GeometryError("morton_order: point " + std::to_string(i) + " has a non-finite coordinate");
    }
    lo = lo.cwiseMin(points[i]);
    hi = hi.cwiseMax(points[i]);
  }
  // One scale for all three axes (the largest extent): the curve's cells stay cubes, so locality is
  // isotropic even for flat or slender bodies.
  const double extent = (hi - lo).maxCoeff();
  constexpr double kMaxQ = static_cast<double>((1u << 21) - 1u);
  const double scale = extent > 0.0 ? kMaxQ / extent : 0.0;
  auto quantize = [&](double x, double x0) {
    const double q = std::floor((x - x0) * scale);
    return static_cast<std::uint64_t>(std::clamp(q, 0.0, kMaxQ));
  };

  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3& p = points[i];
    const std::uint64_t code = spread_bits_3(quantize(p.x(), lo.x())) |
                               (spread_bits_3(quantize(p.y(), lo.y())) << 1) |
                               (spread_bits_3(quantize(p.z(), lo.z())) << 2);
    keyed[i] = {code, static_cast<std::uint32_t>(i)};
  }
  // (code, index) pairs are all distinct, so a plain sort is already deterministic.
  std::sort(keyed.begin(), keyed.end());
  for (std::size_t k = 0; k < n; ++k) order[k] = keyed[k].second;
  return order;
}

void reorder_tets(TetMesh& mesh, const std::vector<std::uint32_t>& order) {
  const std::size_t nt = mesh.tets.size();
  if (order.size() != nt) {
    throw GeometryError("reorder_tets: order has " + std::to_string(order.size()) +
                        " entries but the mesh has " + std::to_string(nt) + " tets");
  }
  std::vector<char> seen(nt, 0);
  for (std::uint32_t o : order) {
    if (o >= nt || seen[o]) {
      throw GeometryError("reorder_tets: order is not a permutation (entry " + std::to_string(o) + ")");
    }
    seen[o] = 1;
  }
  std::vector<std::array<std::uint32_t, 4>> reordered(nt);
  for (std::size_t k = 0; k < nt; ++k) reordered[k] = mesh.tets[order[k]];
  mesh.tets = std::move(reordered);
}

}  // namespace perifx::geometry
