// Mesh split system (paper §5.2, systems/README.md §6.4): opens the crack faces that arrived
// this step.
// For each vertex of a fresh crack face, in increasing vertex index order: its incident tets (found
// among the original incidence of origin[v], keeping the slots that still hold v) are grouped by
// connectivity through shared faces that contain v and are intact (not cracked, not separated).
// k > 1 groups → k − 1 new vertex copies; the group holding the smallest tet index keeps v, every
// other group's tets are rewritten to its copy, and each group gets new embedding weights. Only
// vertices of fresh faces can change their grouping (a face is cracked for good), so vertices that
// were processed before need no second look. Afterwards every pending face whose two tets no longer
// share all three vertices is separated (now two boundary triangles) and leaves the pending set;
// faces at a crack front (not yet separating) stay pending.
// Serial and in a fixed order: the result does not depend on the thread count. Cost is proportional
// to the fresh faces (plus one pass over pending faces when there are fresh ones); nothing when no
// face cracked this step.
// Reads/writes: mesh (embedded mesh).   Scheduled after crack_faces, only when world.any_fracture.
#include <algorithm>

#include "systems.hpp"

namespace perifx::systems {
namespace {

std::array<std::uint32_t, 3> sorted_face(const std::array<std::uint32_t, 4>& tet, int k) {
  std::array<std::uint32_t, 3> f{};
  int n = 0;
  for (int i = 0; i < 4; ++i)
    if (i != k) f[static_cast<std::size_t>(n++)] = tet[static_cast<std::size_t>(i)];
  std::sort(f.begin(), f.end());
  return f;
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
  std::sort(touched.begin(), touched.end());
  touched.erase(std::unique(touched.begin(), touched.end()), touched.end());

  std::size_t copies = 0;
  std::vector<std::uint32_t> tets, slot, group_of, queue, group;
  for (std::uint32_t v : touched) {
    tets.clear();
    slot.clear();
    const std::uint32_t o = e.origin[v];
    for (std::uint32_t q = e.incidence_offsets[o]; q < e.incidence_offsets[o + 1]; ++q) {
      const std::uint32_t t = e.incidence[q] / 4, s = e.incidence[q] % 4;
      if (e.tets[t][s] == v) tets.push_back(t), slot.push_back(s);
    }
    const std::size_t n = tets.size();
    if (n < 2) continue;
    auto local = [&](std::uint32_t t) {  // tets is sorted (incidence is in tet order)
      const auto it = std::lower_bound(tets.begin(), tets.end(), t);
      return it != tets.end() && *it == t ? static_cast<std::size_t>(it - tets.begin()) : n;
    };
    constexpr std::uint32_t kNone = 0xFFFFFFFFu;
    group_of.assign(n, kNone);
    std::uint32_t groups = 0;
    for (std::size_t seed = 0; seed < n; ++seed) {
      if (group_of[seed] != kNone) continue;
      group_of[seed] = groups;
      queue.assign(1, static_cast<std::uint32_t>(seed));
      while (!queue.empty()) {
        const std::uint32_t a = queue.back();
        queue.pop_back();
        const std::uint32_t t = tets[a];
        for (std::uint32_t k = 0; k < 4; ++k) {
          if (k == slot[a]) continue;  // the face opposite v does not contain v
          const std::int32_t pair = e.face_pair[t][k];
          if (pair < 0 || e.pair_state[static_cast<std::size_t>(pair)] != FaceState::intact) continue;
          const std::size_t b = local(static_cast<std::uint32_t>(e.neighbors[t][k]));
          if (b < n && group_of[b] == kNone) group_of[b] = groups, queue.push_back(static_cast<std::uint32_t>(b));
        }
      }
      ++groups;
    }
    if (groups < 2) continue;
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
        e.weight_rows.push_back({0, 0});
        for (std::size_t a = 0; a < n; ++a)
          if (group_of[a] == g) e.tets[tets[a]][slot[a]] = target;
        ++copies;
      }
      embed_vertex(w, target, group);
    }
  }
  e.vertex_copies_total += copies;
  if (copies) {
    std::size_t kept = 0;
    for (std::uint32_t pair : e.pending) {
      if (face_pair_shared(e, pair)) {
        e.pending[kept++] = pair;
      } else {
        e.pair_state[pair] = FaceState::separated;
      }
    }
    e.pending.resize(kept);
  }
  return copies;
}

SystemDecl mesh_split_system(WorldState& w) {
  return {"mesh_split", {Component::mesh}, {Component::mesh}, [&w] { split_mesh_vertices(w); }};
}

}  // namespace perifx::systems
