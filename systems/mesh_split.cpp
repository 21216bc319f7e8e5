// Mesh split system (paper §5.2, systems/README.md §6.4): opens the crack faces that arrived
// this step.
// For each vertex of a fresh crack face, in increasing vertex index order: its incident tets (found
// among the original incidence of origin[v], keeping the slots that still hold v) are grouped by
// connectivity through shared faces that contain v and are intact (not cracked, not separated).
// k > 1 groups → k − 1 new vertex copies; the group holding the smallest tet index keeps v, every
// other group's tets are rewritten to its copy, and each group gets new embedding weights (once the
// embedded motion has built them). Only vertices of fresh faces can change their grouping (a face is
// cracked for good), so vertices that were processed before need no second look. Afterwards every
// pending face whose two tets no longer share all three vertices is separated (now two boundary
// triangles) and leaves the pending set; faces at a crack front (not yet separating) stay pending.
// Non-manifold edges (pinched cracks). Vertex splitting alone can leave an edge (p, q) on more than
// two boundary triangles: the ring of tets around it is cut into several groups by separated faces,
// yet p and q each keep one connected star through faces that do not contain the edge, so neither
// splits and two tet groups touch only along the edge. For every edge of a face separated in this
// step, the boundary triangles on it are counted; when there are more than two, the ring group with
// the fewest intact faces to open (ties: fewer tets, smaller endpoint, smaller first tet) is cut
// free at one endpoint v: the intact faces of its tets that contain v but not the other endpoint
// are torn (marked cracked, so pending, although their bond holds: a render-only crack of zero
// width), and v is split again, which gives the group its own copy of v and separates the torn
// faces; the other vertices of the torn faces are grouped again too (a torn face is never fresh, so
// nothing else would look at them). The surface stays closed (a torn face becomes two boundary
// triangles) and the edge ends with two triangles per copy. Faces separated by a repair are checked in turn (at most 16 rounds).
// At setup (split_disconnected_vertices) every vertex is grouped once the same way (the grouping in
// parallel, the splits serially in vertex order), so vertices whose
// star is not face-connected in the input mesh (hanging tets, initial cracks) start split.
// Serial and in a fixed order: the result does not depend on the thread count. Cost is proportional
// to the fresh faces (plus one pass over pending faces when there are fresh ones); nothing when no
// face cracked this step.
// Reads/writes: mesh (embedded mesh).   Scheduled after crack_faces, only when world.any_fracture.
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>

#include "systems.hpp"
#include "union_find.hpp"

namespace perifx::systems {
namespace {

constexpr std::uint32_t kNone = 0xFFFFFFFFu;

std::array<std::uint32_t, 3> sorted_face(const std::array<std::uint32_t, 4>& tet, int k) {
  std::array<std::uint32_t, 3> f{};
  int n = 0;
  for (int i = 0; i < 4; ++i)
    if (i != k) f[static_cast<std::size_t>(n++)] = tet[static_cast<std::size_t>(i)];
  std::sort(f.begin(), f.end());
  return f;
}

// The tets that currently hold v (in tet order) and v's slot in each.
void holding(const EmbeddedMesh& e, std::uint32_t v, std::vector<std::uint32_t>& tets, std::vector<std::uint32_t>& slot) {
  tets.clear();
  slot.clear();
  for_each_holding_tet(e, v, [&](std::uint32_t t, std::uint32_t s) { tets.push_back(t), slot.push_back(s); });
}

int slot_of(const std::array<std::uint32_t, 4>& tet, std::uint32_t v) {
  for (int i = 0; i < 4; ++i)
    if (tet[static_cast<std::size_t>(i)] == v) return i;
  return -1;
}

struct Scratch {
  std::vector<std::uint32_t> tets, slot, group_of, parent, group;
};

// Groups v's tets (sc.tets, sc.slot) by the intact faces containing v (sc.group_of); returns how many
// groups there are. Reads the mesh only.
std::uint32_t group_tets(const EmbeddedMesh& e, std::uint32_t v, Scratch& sc) {
  auto& tets = sc.tets;
  auto& slot = sc.slot;
  holding(e, v, tets, slot);
  const std::size_t n = tets.size();
  if (n < 2) return static_cast<std::uint32_t>(n);
  auto local = [&](std::uint32_t t) {  // tets is sorted (incidence is in tet order)
    const auto it = std::lower_bound(tets.begin(), tets.end(), t);
    return it != tets.end() && *it == t ? static_cast<std::size_t>(it - tets.begin()) : n;
  };
  // Groups: v's tets joined by the intact faces they share through v.
  UnionFind sets(sc.parent, n);
  for (std::size_t a = 0; a < n; ++a) {
    const std::uint32_t t = tets[a];
    for (std::uint32_t k = 0; k < 4; ++k) {
      if (k == slot[a]) continue;  // the face opposite v does not contain v
      const std::int32_t pair = e.face_pair[t][k];
      if (pair < 0 || e.pair_state[static_cast<std::size_t>(pair)] != FaceState::intact) continue;
      const std::size_t b = local(static_cast<std::uint32_t>(e.neighbors[t][k]));
      if (b < n) sets.unite(static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b));
    }
  }
  return sets.label(sc.group_of);
}

// Groups v's tets by intact faces containing v and gives every group but the first its own copy.
std::size_t split_vertex(WorldState& w, std::uint32_t v, Scratch& sc) {
  EmbeddedMesh& e = w.embedded;
  const std::uint32_t groups = group_tets(e, v, sc);
  if (groups < 2) return 0;
  const auto& tets = sc.tets;
  const auto& slot = sc.slot;
  const auto& group_of = sc.group_of;
  auto& group = sc.group;
  const std::size_t n = tets.size();
  const bool weights = !e.weight_rows.empty();  // the embedded motion's (ensure_vertex_weights)
  std::size_t copies = 0;
  const std::uint32_t o = e.origin[v];
  for (std::uint32_t g = 0; g < groups; ++g) {
    group.clear();
    for (std::size_t a = 0; a < n; ++a)
      if (group_of[a] == g) group.push_back(tets[a]);
    std::uint32_t target = v;
    if (g > 0) {
      target = static_cast<std::uint32_t>(e.vertices.size());
      e.reference_vertices.push_back(e.reference_vertices[v]);
      e.vertices.push_back(e.vertices[v]);
      e.vertex_velocity.push_back(e.vertex_velocity[v]);
      e.origin.push_back(o);
      e.split_copy.push_back(1);
      if (weights) e.weight_rows.push_back({0, 0});
      for (std::size_t a = 0; a < n; ++a)
        if (group_of[a] == g) e.tets[tets[a]][slot[a]] = target;
      ++copies;
    }
    if (weights) embed_vertex(w, target, group);
  }
  return copies;
}

// Separates the pending faces whose tets no longer share them; appends those pairs to `separated`.
void separate_pending(EmbeddedMesh& e, std::vector<std::uint32_t>& separated) {
  std::size_t kept = 0;
  for (std::uint32_t pair : e.pending) {
    if (face_pair_shared(e, pair)) {
      e.pending[kept++] = pair;
    } else {
      e.pair_state[pair] = FaceState::separated;
      separated.push_back(pair);
    }
  }
  e.pending.resize(kept);
}

// Boundary triangles on edge (p, q), and when there are more than two, the repair: the endpoint to
// split and the intact faces to tear (appended to `tear`). Returns the endpoint, or kNone.
std::uint32_t pinched_edge(const EmbeddedMesh& e, std::uint32_t p, std::uint32_t q, Scratch& sc,
                           std::vector<std::uint32_t>& tear) {
  // Ring: the tets holding both p and q.
  holding(e, p, sc.tets, sc.slot);
  std::vector<std::uint32_t> ring;
  for (std::uint32_t t : sc.tets)
    if (slot_of(e.tets[t], q) >= 0) ring.push_back(t);
  std::size_t triangles = 0;
  auto ring_faces = [&](std::uint32_t t, int out[2]) {
    const int sp = slot_of(e.tets[t], p), sq = slot_of(e.tets[t], q);
    int n = 0;
    for (int k = 0; k < 4; ++k)
      if (k != sp && k != sq) out[n++] = k;
  };
  auto open_face = [&](std::uint32_t t, int k) {  // a boundary triangle of t
    const std::int32_t pair = e.face_pair[t][static_cast<std::size_t>(k)];
    return pair < 0 || e.pair_state[static_cast<std::size_t>(pair)] == FaceState::separated;
  };
  for (std::uint32_t t : ring) {
    int f[2];
    ring_faces(t, f);
    triangles += open_face(t, f[0]) + open_face(t, f[1]);
  }
  if (triangles <= 2) return kNone;
  // Groups of the ring: tets joined by ring faces they still share (intact or pending).
  const std::size_t n = ring.size();
  UnionFind sets(sc.parent, n);
  for (std::size_t a = 0; a < n; ++a) {
    const std::uint32_t t = ring[a];
    int f[2];
    ring_faces(t, f);
    for (int k : f) {
      if (open_face(t, k)) continue;
      const auto u = static_cast<std::uint32_t>(e.neighbors[t][static_cast<std::size_t>(k)]);
      const auto it = std::lower_bound(ring.begin(), ring.end(), u);
      if (it != ring.end() && *it == u) sets.unite(static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(it - ring.begin()));
    }
  }
  std::vector<std::uint32_t> group_of;
  const std::uint32_t groups = sets.label(group_of);
  if (groups < 2) return kNone;
  // Candidates (endpoint v, group g): faces of g's tets holding v but not the other endpoint.
  struct Best { std::size_t cost = ~std::size_t{0}, size = 0; std::uint32_t v = kNone, first = kNone, g = 0; } best;
  for (std::uint32_t v : {std::min(p, q), std::max(p, q)}) {
    const std::uint32_t other = v == p ? q : p;
    for (std::uint32_t g = 0; g < groups; ++g) {
      std::size_t cost = 0, size = 0;
      std::uint32_t first = kNone;
      for (std::size_t a = 0; a < n; ++a) {
        if (group_of[a] != g) continue;
        const std::uint32_t t = ring[a];
        first = std::min(first, t);
        ++size;
        const std::int32_t pair = e.face_pair[t][static_cast<std::size_t>(slot_of(e.tets[t], other))];
        cost += pair >= 0 && e.pair_state[static_cast<std::size_t>(pair)] == FaceState::intact;
      }
      const bool better = cost < best.cost || (cost == best.cost && (size < best.size || (size == best.size &&
                          (v < best.v || (v == best.v && first < best.first)))));
      if (better) best = {cost, size, v, first, g};
    }
  }
  const std::uint32_t other = best.v == p ? q : p;
  for (std::size_t a = 0; a < n; ++a) {
    if (group_of[a] != best.g) continue;
    const std::uint32_t t = ring[a];
    const std::int32_t pair = e.face_pair[t][static_cast<std::size_t>(slot_of(e.tets[t], other))];
    if (pair >= 0 && e.pair_state[static_cast<std::size_t>(pair)] == FaceState::intact) tear.push_back(static_cast<std::uint32_t>(pair));
  }
  return best.v;
}

}  // namespace

bool face_pair_shared(const EmbeddedMesh& e, std::uint32_t pair) {
  const auto [t, u] = e.pair_tets[pair];
  return sorted_face(e.tets[t], e.pair_local[pair][0]) == sorted_face(e.tets[u], e.pair_local[pair][1]);
}

std::size_t split_mesh_vertices(WorldState& w) {
  EmbeddedMesh& e = w.embedded;
  if (e.fresh.empty()) return 0;
  std::vector<std::uint32_t> touched;
  touched.reserve(3 * e.fresh.size());
  for (std::uint32_t pair : e.fresh) {
    const auto f = sorted_face(e.tets[e.pair_tets[pair][0]], e.pair_local[pair][0]);
    touched.insert(touched.end(), f.begin(), f.end());
  }
  e.fresh.clear();

  Scratch sc;
  std::size_t copies = 0;
  std::vector<std::uint32_t> separated, tear, edges_p, edges_q;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;
  for (int round = 0; round < 16 && !touched.empty(); ++round) {
    std::sort(touched.begin(), touched.end());
    touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
    std::size_t made = 0;
    for (std::uint32_t v : touched) made += split_vertex(w, v, sc);
    copies += made;
    touched.clear();
    if (made == 0) break;  // nothing new separates
    separated.clear();
    separate_pending(e, separated);
    // Edges of the faces separated now (as each side's tet labels them), checked once each.
    edges.clear();
    for (std::uint32_t pair : separated)
      for (int side = 0; side < 2; ++side) {
        const auto f = sorted_face(e.tets[e.pair_tets[pair][static_cast<std::size_t>(side)]], e.pair_local[pair][static_cast<std::size_t>(side)]);
        edges.push_back({f[0], f[1]});
        edges.push_back({f[0], f[2]});
        edges.push_back({f[1], f[2]});
      }
    std::sort(edges.begin(), edges.end());
    edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
    tear.clear();
    for (const auto& [p, q] : edges) {
      const std::uint32_t v = pinched_edge(e, p, q, sc, tear);
      if (v != kNone) touched.push_back(v);
    }
    if (touched.empty()) break;
    std::sort(tear.begin(), tear.end());
    tear.erase(std::unique(tear.begin(), tear.end()), tear.end());
    for (std::uint32_t pair : tear) {
      e.pair_state[pair] = FaceState::cracked;
      // A torn face never becomes fresh (it is no longer watched), so all its vertices are grouped
      // again now: a torn face can disconnect the star of any of them.
      const auto f = sorted_face(e.tets[e.pair_tets[pair][0]], e.pair_local[pair][0]);
      touched.insert(touched.end(), f.begin(), f.end());
    }
    if (!tear.empty()) {
      e.watched_pairs.erase(std::remove_if(e.watched_pairs.begin(), e.watched_pairs.end(),
                                           [&](std::uint32_t pair) { return std::binary_search(tear.begin(), tear.end(), pair); }),
                            e.watched_pairs.end());
      const auto mid = e.pending.size();
      e.pending.insert(e.pending.end(), tear.begin(), tear.end());
      std::inplace_merge(e.pending.begin(), e.pending.begin() + static_cast<std::ptrdiff_t>(mid), e.pending.end());
      e.torn_faces_total += tear.size();
    }
  }
  e.vertex_copies_total += copies;
  return copies;
}

std::size_t split_disconnected_vertices(WorldState& w) {
  EmbeddedMesh& e = w.embedded;
  const auto nv = static_cast<std::uint32_t>(e.vertices.size());
  // Which vertices split is decided in parallel (read-only), the splits are made serially in vertex
  // order. That is the same result as splitting every vertex in turn: a split rewrites only the slots
  // that held the split vertex, so it changes no other original vertex's tets or faces.
  std::vector<std::uint8_t> splits(nv, 0);
  constexpr std::size_t kBlock = 4096;
  tbb::parallel_for(std::size_t{0}, (std::size_t{nv} + kBlock - 1) / kBlock, [&](std::size_t block) {
    Scratch local;
    const auto end = static_cast<std::uint32_t>(std::min<std::size_t>(nv, (block + 1) * kBlock));
    for (auto v = static_cast<std::uint32_t>(block * kBlock); v < end; ++v) splits[v] = group_tets(e, v, local) > 1;
  });
  Scratch sc;
  std::size_t copies = 0;
  for (std::uint32_t v = 0; v < nv; ++v)
    if (splits[v]) copies += split_vertex(w, v, sc);
  if (copies) {
    std::vector<std::uint32_t> separated;
    separate_pending(e, separated);
  }
  e.vertex_copies_total += copies;
  return copies;
}

SystemDecl mesh_split_system(WorldState& w) {
  return {"mesh_split", {Component::mesh}, {Component::mesh}, [&w] { split_mesh_vertices(w); }};
}

}  // namespace perifx::systems
