// Embedded mesh setup (paper §5.2) and the vertex embedding weights shared by setup and mesh_split.
// Reads:  WorldState::mesh (original tets and vertices), its face adjacency, bonds (neighbor lists),
//         particles (reference positions, masses), bodies (λ).
// Writes: WorldState::embedded (all of it).
//
// Face pairs: every original face-adjacent tet pair (t < u) gets the index of the bond t→u, found by
// binary search in t's sorted neighbour list, so a broken bond maps to its shared face in O(1). A
// pair without a bond (an initial crack removed it, or the horizon is shorter than the barycenter
// distance) starts cracked: its face is pending and the first mesh_split opens it.
//
// Embedding weights (VertexMotion::embedded; built on its first use, ensure_vertex_weights): for
// the vertex X with support particles p (masses m_p, reference positions x_p, d_p = x_p − X), the mass-weighted least-squares affine fit of the
// displacement field evaluated at X is  u(X) = Σ w_p u_p  with
//   w_p = m_p/M − m_p (d_p − d̄)ᵀ D⁺ d̄,   M = Σ m,  d̄ = Σ m d / M,  D = Σ m (d − d̄)(d − d̄)ᵀ.
// Σ w_p = 1 exactly (translations are exact) and Σ w_p d_p = 0 when D has full rank (affine maps,
// rotations included, are exact). The support is the vertex's tet group; when its barycenters do not
// span 3D (a box corner has two tets) it grows by rings of tets across intact faces (≤ 3 rings); D⁺
// drops directions still below 1e-6 of the largest.
#include <Eigen/Eigenvalues>
#include <algorithm>

#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {

// mesh_split.cpp: splits every vertex whose tets are not joined through intact faces holding it;
// returns the copies made. Used only here, at setup.
std::size_t split_disconnected_vertices(WorldState& world);

void embed_vertex(WorldState& w, std::uint32_t v, const std::vector<std::uint32_t>& group) {
  EmbeddedMesh& e = w.embedded;
  const auto& x = w.particles.reference_position;
  const auto& mass = w.particles.mass;
  const Vec3 X = e.reference_vertices[v];

  std::vector<std::uint32_t> support(group.begin(), group.end());
  std::sort(support.begin(), support.end());
  Mat3 D;
  Vec3 dbar;
  double M = 0.0;
  double scale = 0.0;
  auto moments = [&] {
    M = 0.0;
    dbar.setZero();
    scale = 0.0;
    for (std::uint32_t p : support) scale = std::max(scale, (x[p] - X).norm());
    if (scale == 0.0) scale = 1.0;
    for (std::uint32_t p : support) {
      M += mass[p];
      dbar += mass[p] * (x[p] - X) / scale;
    }
    dbar /= M;
    D.setZero();
    for (std::uint32_t p : support) {
      const Vec3 d = (x[p] - X) / scale - dbar;
      D += mass[p] * d * d.transpose();
    }
  };
  auto rank = [&] {
    Eigen::SelfAdjointEigenSolver<Mat3> es(D);
    const double top = es.eigenvalues().maxCoeff();
    int r = 0;
    for (int k = 0; k < 3; ++k) r += es.eigenvalues()[k] > 1e-3 * std::max(top, 1e-300) && top > 1e-12 * M;
    return r;
  };
  moments();
  for (int ring = 0; ring < 3 && rank() < 3; ++ring) {
    std::vector<std::uint32_t> next = support;
    for (std::uint32_t t : support)
      for (int k = 0; k < 4; ++k) {
        const std::int32_t pair = e.face_pair[t][static_cast<std::size_t>(k)];
        if (pair < 0 || e.pair_state[static_cast<std::size_t>(pair)] != FaceState::intact) continue;
        next.push_back(static_cast<std::uint32_t>(e.neighbors[t][static_cast<std::size_t>(k)]));
      }
    std::sort(next.begin(), next.end());
    next.erase(std::unique(next.begin(), next.end()), next.end());
    if (next.size() == support.size()) break;
    support.swap(next);
    moments();
  }
  Eigen::SelfAdjointEigenSolver<Mat3> es(D);
  const double top = es.eigenvalues().maxCoeff();
  Mat3 pinv = Mat3::Zero();
  for (int k = 0; k < 3; ++k) {
    const double l = es.eigenvalues()[k];
    if (top > 1e-12 * M && l > 1e-6 * top) pinv += (1.0 / l) * es.eigenvectors().col(k) * es.eigenvectors().col(k).transpose();
  }
  const Vec3 g = pinv * dbar;
  const auto begin = static_cast<std::uint32_t>(e.weight_particle.size());
  for (std::uint32_t p : support) {
    const Vec3 d = (x[p] - X) / scale - dbar;
    e.weight_particle.push_back(p);
    e.weight_value.push_back(mass[p] / M - mass[p] * d.dot(g));
  }
  e.weight_rows[v] = {begin, static_cast<std::uint32_t>(e.weight_particle.size())};
}

void ensure_vertex_weights(WorldState& w) {
  EmbeddedMesh& e = w.embedded;
  const std::size_t nv = e.vertices.size();
  if (e.weight_rows.size() == nv) return;
  e.weight_rows.assign(nv, {0, 0});
  e.weight_particle.clear();
  e.weight_value.clear();
  std::vector<std::uint32_t> group;
  for (std::uint32_t v = 0; v < nv; ++v) {
    group.clear();
    for_each_holding_tet(e, v, [&](std::uint32_t t, std::uint32_t) { group.push_back(t); });
    if (!group.empty()) embed_vertex(w, v, group);
  }
}

void setup_embedded_mesh(WorldState& w, const std::vector<std::array<std::int32_t, 4>>& adjacency) {
  EmbeddedMesh& e = w.embedded;
  const TetMesh& mesh = w.mesh;
  const Bonds& b = w.bonds;
  const std::size_t nt = mesh.tets.size(), nv = mesh.vertices.size();
  e = EmbeddedMesh{};
  e.reference_vertices = mesh.vertices;
  e.vertices = mesh.vertices;
  e.vertex_velocity.assign(nv, Vec3::Zero());
  e.origin.resize(nv);
  for (std::size_t v = 0; v < nv; ++v) e.origin[v] = static_cast<std::uint32_t>(v);
  e.split_copy.assign(nv, 0);
  e.original_vertex_count = static_cast<std::uint32_t>(nv);
  e.tets = mesh.tets;
  e.neighbors = adjacency;
  e.face_pair.assign(nt, {-1, -1, -1, -1});

  auto bond_between = [&](std::uint32_t i, std::uint32_t j) {
    const auto first = b.neighbor.begin() + b.offsets[i], last = b.neighbor.begin() + b.offsets[i + 1];
    const auto it = std::lower_bound(first, last, j);
    return it != last && *it == j ? static_cast<std::uint32_t>(it - b.neighbor.begin()) : EmbeddedMesh::kNoBond;
  };
  // Pairs are numbered by (t, local face of t), t < u: a count per tet, a prefix sum, then every pair
  // filled in parallel (the bond search is a cache miss or two per pair; serial, it was a quarter of
  // this phase at 9e5 tets). Each face_pair slot is written by its one pair.
  std::vector<std::uint32_t> first_pair(nt + 1, 0);
  parallel_for_each(nt, [&](std::size_t t) {
    std::uint32_t count = 0;
    for (std::int32_t u : adjacency[t]) count += u >= 0 && static_cast<std::size_t>(u) > t;
    first_pair[t + 1] = count;
  }, 4096);
  for (std::size_t t = 0; t < nt; ++t) first_pair[t + 1] += first_pair[t];
  const std::size_t pairs = first_pair[nt];
  e.pair_tets.resize(pairs);
  e.pair_local.resize(pairs);
  e.pair_bond.resize(pairs);
  e.pair_state.resize(pairs);
  parallel_for_each(nt, [&](std::size_t t) {
    std::uint32_t pair = first_pair[t];
    for (std::uint8_t k = 0; k < 4; ++k) {
      const std::int32_t u = adjacency[t][k];
      if (u < 0 || static_cast<std::size_t>(u) <= t) continue;
      const auto uu = static_cast<std::uint32_t>(u);
      std::uint8_t ku = 0;
      while (ku < 4 && adjacency[uu][ku] != static_cast<std::int32_t>(t)) ++ku;
      e.pair_tets[pair] = {static_cast<std::uint32_t>(t), uu};
      e.pair_local[pair] = {k, ku};
      const std::uint32_t bond = bond_between(static_cast<std::uint32_t>(t), uu);
      e.pair_bond[pair] = bond;
      e.face_pair[t][k] = static_cast<std::int32_t>(pair);
      e.face_pair[uu][ku] = static_cast<std::int32_t>(pair);
      e.pair_state[pair] = bond == EmbeddedMesh::kNoBond || !b.alive[bond] ? FaceState::cracked : FaceState::intact;
      ++pair;
    }
  }, 1024);
  for (std::uint32_t pair = 0; pair < pairs; ++pair) {
    if (e.pair_state[pair] == FaceState::cracked) {
      e.fresh.push_back(pair);
      e.pending.push_back(pair);
      ++e.crack_faces_total;
    } else {
      e.watched_pairs.push_back(pair);
    }
  }

  // Original incidence CSR: tets (·4 + slot) around each vertex, in tet order.
  e.incidence_offsets.assign(nv + 1, 0);
  for (const auto& tet : mesh.tets)
    for (std::uint32_t v : tet) ++e.incidence_offsets[v + 1];
  for (std::size_t v = 0; v < nv; ++v) e.incidence_offsets[v + 1] += e.incidence_offsets[v];
  e.incidence.resize(e.incidence_offsets.back());
  std::vector<std::uint32_t> fill(e.incidence_offsets.begin(), e.incidence_offsets.end() - 1);
  for (std::uint32_t t = 0; t < nt; ++t)
    for (std::uint32_t s = 0; s < 4; ++s) e.incidence[fill[mesh.tets[t][s]]++] = t * 4 + s;

  // No embedding weights: only VertexMotion::embedded reads them (ensure_vertex_weights).
  // A vertex whose tets are not joined through intact faces that hold it (a tet hanging by a vertex or
  // an edge in the input mesh; the faces of initial cracks) is split now: later splits only look at
  // vertices of fresh crack faces, and a hanging tet has none at such a vertex, so it would stay tied
  // to the rest there after its bonds break.
  split_disconnected_vertices(w);
  start_mesh_vertices(w);
}

}  // namespace perifx::systems
