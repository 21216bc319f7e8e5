// Crack face smoothing (beyond the paper, which names zig-zag crack surfaces as its limitation;
// systems/README.md §6.6). Output only, not a step system: called when the mesh is read
// (World::surface, World::tet_mesh), before the vertex motion, so the vertices' current positions
// follow the smoothed reference positions.
//
// Crack faces are tet faces, so a crack through a structured mesh is a stair-step. This moves the
// reference positions X_v of the vertices on the crack surface (the separated face pairs) towards a
// smooth surface, with `iterations` × 2 Laplacian steps (λ = 0.5) over the crack surface's own edges. Plain
// Laplacian, not Taubin: the crack surface is bounded by its rim on the outer surface and its front,
// so shrinking within its plane is harmless, and Taubin's inflating step undid most of the flattening
// of a stair-step (tests/systems/test_crack_smoothing.cpp: area ratio 1.78 → 1.57 with 3 Taubin
// iterations, → 1.08 with 6 Laplacian steps, i.e. 3 iterations now).
//   - it works on original vertices: every copy of an original vertex (its `origin`) gets the same
//     X, so the two sides of a crack keep coinciding in the reference configuration (they can never
//     cross) and the intact tets around it stay conforming; topology is untouched, so every piece
//     that was closed stays closed;
//   - vertices on the crack's rim (edges of one crack face: crack front, where the crack meets the
//     outer surface) and on branch lines (edges of three or more) move only along those lines, with
//     their rim neighbours; where rim lines meet the vertex stays;
//   - vertices on the original outer surface move only within their flat face (or along their
//     straight edge), as in the jitter of the structured mesher (engine/geometry/jitter.cpp);
//   - each step is backed off per vertex (halved, at last zeroed) until every tet around the moved
//     vertices keeps at least kMinVolumeFraction of its original volume (so stays positively oriented)
//     and every moved vertex stays within kReach δ of the particle of each tet it belongs to (Laplacian
//     smoothing shrinks a crack network; without this a lone debris tet's vertex was drawn from 0.54 δ
//     to 1.07 δ of its particle in the full glass walls).
// It starts every time from the original vertices (WorldState::mesh), so the result depends only on
// the current crack set, not on when the frames were written; serial, in vertex order: deterministic
// and the same for any thread count. It allocates its work arrays per call (once per output frame),
// never inside a step.
// Reads: mesh (original vertices and tets), embedded (pair states, origin, incidence, neighbors),
// particles.reference_position, model.horizon.
// Writes: embedded.reference_vertices.
#include <algorithm>
#include <cmath>

#include "systems.hpp"

namespace perifx::systems {
namespace {

// Laplacian step: a vertex moves this fraction of the way to its neighbours' mean.
constexpr double kLambda = 0.5;
// Every tet around a moved vertex keeps at least this fraction of its original volume.
constexpr double kMinVolumeFraction = 0.2;
// No vertex ends farther than this fraction of δ from the particle of a tet it belongs to (or than it
// was, if the mesher put it farther). A lone debris tet is drawn rigidly from its one particle, and
// check-surface calls a vertex farther than δ from every particle of its piece a spike; the 0.1 δ
// margin is for the stretch of a fitted piece.
constexpr double kReach = 0.9;
constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

double tet_volume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return (b - a).dot((c - a).cross(d - a)) / 6.0;
}

}  // namespace

std::size_t smooth_crack_faces(WorldState& w, int iterations) {
  EmbeddedMesh& e = w.embedded;
  const std::vector<Vec3>& X0 = w.mesh.vertices;
  const auto& tets0 = w.mesh.tets;
  const std::size_t nv0 = X0.size();
  if (e.tets.empty() || nv0 == 0 || e.origin.size() != e.reference_vertices.size()) return 0;
  // Crack triangles over original vertex ids.
  std::vector<std::array<std::uint32_t, 3>> tris;
  for (std::size_t p = 0; p < e.pair_state.size(); ++p) {
    if (e.pair_state[p] != FaceState::separated) continue;
    const std::uint32_t t = e.pair_tets[p][0];
    const int k = e.pair_local[p][0];
    tris.push_back({tets0[t][static_cast<std::size_t>(kFace[k][0])], tets0[t][static_cast<std::size_t>(kFace[k][1])],
                    tets0[t][static_cast<std::size_t>(kFace[k][2])]});
  }
  std::vector<std::int32_t> local(nv0, -1);
  std::vector<std::uint32_t> verts;
  if (iterations > 0) {
    for (const auto& t : tris)
      for (auto v : t) local[v] = 0;
    for (std::uint32_t v = 0; v < nv0; ++v)
      if (local[v] == 0) local[v] = static_cast<std::int32_t>(verts.size()), verts.push_back(v);
  }
  const std::size_t n = verts.size();
  std::vector<Vec3> P(n);
  for (std::size_t i = 0; i < n; ++i) P[i] = X0[verts[i]];
  std::size_t moved = 0;
  if (n > 0) {
    // Crack edges (local ids) with their use counts.
    std::vector<std::array<std::uint32_t, 2>> edges;
    edges.reserve(tris.size() * 3);
    for (const auto& t : tris)
      for (int c = 0; c < 3; ++c) {
        const auto a = static_cast<std::uint32_t>(local[t[static_cast<std::size_t>(c)]]);
        const auto b = static_cast<std::uint32_t>(local[t[static_cast<std::size_t>((c + 1) % 3)]]);
        edges.push_back({std::min(a, b), std::max(a, b)});
      }
    std::sort(edges.begin(), edges.end());
    // Unique edges with a feature flag (used once or more than twice).
    std::vector<std::array<std::uint32_t, 2>> uniq;
    std::vector<std::uint8_t> feature;
    for (std::size_t i = 0; i < edges.size();) {
      std::size_t j = i;
      while (j < edges.size() && edges[j] == edges[i]) ++j;
      uniq.push_back(edges[i]);
      feature.push_back(j - i != 2);
      i = j;
    }
    std::vector<std::uint32_t> feature_degree(n, 0);
    for (std::size_t q = 0; q < uniq.size(); ++q)
      if (feature[q]) ++feature_degree[uniq[q][0]], ++feature_degree[uniq[q][1]];
    // Neighbour lists (CSR): feature vertices see only their feature edges.
    std::vector<std::uint32_t> offsets(n + 1, 0), nb;
    auto keep = [&](std::size_t q, std::uint32_t v) { return feature_degree[v] == 0 || feature[q]; };
    for (std::size_t q = 0; q < uniq.size(); ++q)
      for (int s = 0; s < 2; ++s)
        if (keep(q, uniq[q][static_cast<std::size_t>(s)])) ++offsets[uniq[q][static_cast<std::size_t>(s)] + 1];
    for (std::size_t i = 0; i < n; ++i) offsets[i + 1] += offsets[i];
    nb.resize(offsets[n]);
    {
      std::vector<std::uint32_t> fill(offsets.begin(), offsets.end() - 1);
      for (std::size_t q = 0; q < uniq.size(); ++q)
        for (int s = 0; s < 2; ++s) {
          const std::uint32_t v = uniq[q][static_cast<std::size_t>(s)];
          if (keep(q, v)) nb[fill[v]++] = uniq[q][static_cast<std::size_t>(1 - s)];
        }
    }
    // Mobility: outer-surface normals around each vertex; rim junctions stay.
    std::vector<Mat3> mobility(n, Mat3::Identity());
    std::vector<std::uint32_t> check_tets;  // tets around crack vertices (original tet ids)
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint32_t v = verts[i];
      Vec3 normals[3];
      int count = 0;
      for (std::uint32_t q = e.incidence_offsets[v]; q < e.incidence_offsets[v + 1]; ++q) {
        const std::uint32_t t = e.incidence[q] / 4, slot = e.incidence[q] % 4;
        check_tets.push_back(t);
        for (int k = 0; k < 4; ++k) {
          if (k == static_cast<int>(slot) || e.neighbors[t][static_cast<std::size_t>(k)] >= 0) continue;
          const Vec3 &a = X0[tets0[t][static_cast<std::size_t>(kFace[k][0])]], &b = X0[tets0[t][static_cast<std::size_t>(kFace[k][1])]],
                     &c = X0[tets0[t][static_cast<std::size_t>(kFace[k][2])]];
          const Vec3 m = (b - a).cross(c - a).normalized();
          bool known = false;
          for (int j = 0; j < count; ++j) known = known || std::abs(normals[j].dot(m)) > 1.0 - 1e-9;
          if (!known && count < 3) normals[count++] = m;
        }
      }
      if (feature_degree[i] > 2 || count >= 3) {
        mobility[i].setZero();
      } else if (count == 1) {
        mobility[i] = Mat3::Identity() - normals[0] * normals[0].transpose();
      } else if (count == 2) {
        const Vec3 d = normals[0].cross(normals[1]);
        mobility[i] = d.squaredNorm() > 0.25 ? Mat3(d.normalized() * d.normalized().transpose()) : Mat3(Mat3::Zero());
      }
    }
    std::sort(check_tets.begin(), check_tets.end());
    check_tets.erase(std::unique(check_tets.begin(), check_tets.end()), check_tets.end());
    std::vector<double> volume0(check_tets.size());
    for (std::size_t j = 0; j < check_tets.size(); ++j) {
      const auto& t = tets0[check_tets[j]];
      volume0[j] = tet_volume(X0[t[0]], X0[t[1]], X0[t[2]], X0[t[3]]);
    }
    auto pos = [&](const std::vector<Vec3>& Q, std::uint32_t v) -> const Vec3& {
      return local[v] >= 0 ? Q[static_cast<std::size_t>(local[v])] : X0[v];
    };
    std::vector<Vec3> D(n), Q(n);
    std::vector<double> step(n);
    std::vector<std::uint8_t> fail(n);
    for (int it = 0; it < 2 * iterations; ++it) {
      const double f = kLambda;
      for (std::size_t i = 0; i < n; ++i) {
        const std::uint32_t b = offsets[i], end = offsets[i + 1];
        Vec3 mean = Vec3::Zero();
        for (std::uint32_t q = b; q < end; ++q) mean += P[nb[q]];
        D[i] = end > b ? Vec3(f * (mobility[i] * (mean / static_cast<double>(end - b) - P[i]))) : Vec3(Vec3::Zero());
        step[i] = 1.0;
      }
      for (int round = 0;; ++round) {
        for (std::size_t i = 0; i < n; ++i) Q[i] = P[i] + step[i] * D[i];
        std::fill(fail.begin(), fail.end(), 0);
        bool bad = false;
        for (std::size_t j = 0; j < check_tets.size(); ++j) {
          const auto& t = tets0[check_tets[j]];
          // Reach: within the larger of kReach δ and the vertex's original distance.
          const Vec3& xp = w.particles.reference_position[check_tets[j]];
          const double reach = kReach * w.model.horizon[check_tets[j]];
          for (auto v : t) {
            if (local[v] < 0 || step[static_cast<std::size_t>(local[v])] == 0.0) continue;
            const double d = (Q[static_cast<std::size_t>(local[v])] - xp).squaredNorm();
            if (d > reach * reach && d > (X0[v] - xp).squaredNorm()) fail[static_cast<std::size_t>(local[v])] = 1, bad = true;
          }
          if (tet_volume(pos(Q, t[0]), pos(Q, t[1]), pos(Q, t[2]), pos(Q, t[3])) >= kMinVolumeFraction * volume0[j]) continue;
          for (auto v : t)
            if (local[v] >= 0 && step[static_cast<std::size_t>(local[v])] > 0.0) fail[static_cast<std::size_t>(local[v])] = 1, bad = true;
        }
        if (!bad) break;
        for (std::size_t i = 0; i < n; ++i)
          if (fail[i]) step[i] = round < 5 ? 0.5 * step[i] : 0.0;
      }
      P.swap(Q);
    }
    for (std::size_t i = 0; i < n; ++i) moved += P[i] != X0[verts[i]];
  }
  for (std::size_t v = 0; v < e.reference_vertices.size(); ++v) {
    const std::uint32_t o = e.origin[v];
    e.reference_vertices[v] = local[o] >= 0 && n > 0 ? P[static_cast<std::size_t>(local[o])] : X0[o];
  }
  return moved;
}

}  // namespace perifx::systems
