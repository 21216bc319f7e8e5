// Fragments (pieces): connected components of the graph of alive bonds (particles are nodes). A
// particle with no alive bond is a piece. Computed on request (output frames, the run summary), not
// every step. Sequential union-find with the smaller root always winning (union_find.hpp), so every
// component's root is its smallest particle index.
// Stable ids (update_piece_ids, the `fragment_id` field): the first time, a piece's id is its root
// (so an unbroken run writes the same ids as the plain components). Later, the parts of an old piece
// (bonds never heal, so a component lies inside one old piece) are ranked: the part with the most
// particles keeps the old id, ties to the part holding the smallest particle index; every other part
// gets next_fragment_id++ (starting at the particle count, so never an id used before), handed out in
// increasing root order. Ids thus depend on the alive bonds at the steps they were requested at (one
// request per output frame in a run), never on the thread count: everything here is serial.
// A distributed run's rank 0 is handed the roots, found by all ranks from their own bonds
// (engine/distributed/pieces.hpp), with the step they hold for (derived.fragment_root_step); the ids are
// then given here as above, from the same roots.
// Reads: bond_alive.   Writes: derived (fragment_id, its scratch arrays, counts).
#include "field_registry.hpp"
#include "systems.hpp"
#include "union_find.hpp"

namespace perifx::systems {

std::size_t compute_fragments(const WorldState& w, std::vector<std::uint32_t>& id) {
  const Bonds& b = w.bonds;
  const std::size_t n = w.particles.count();
  UnionFind sets(id, n);
  for (std::uint32_t i = 0; i < n; ++i)
    for (std::uint32_t k = b.offsets[i], end = b.offsets[i + 1]; k < end; ++k) {
      const std::uint32_t j = b.neighbor[k];
      if (j <= i || !b.alive[k]) continue;
      sets.unite(i, j);
    }
  return sets.flatten();
}

std::size_t update_piece_ids(WorldState& w) {
  DerivedFields& d = w.derived;
  const std::size_t n = w.particles.count();
  std::size_t count = 0;
  if (d.fragment_root_step == w.clock.step && d.fragment_root.size() == n) {  // given by the ranks
    for (std::uint32_t i = 0; i < n; ++i) count += d.fragment_root[i] == i;
  } else {
    count = compute_fragments(w, d.fragment_root);
  }
  constexpr std::uint32_t kNone = 0xFFFFFFFFu;
  if (d.fragment_id.size() != n) {  // first request: ids are the roots
    d.fragment_id = d.fragment_root;
    d.next_fragment_id = static_cast<std::uint32_t>(n);
    return count;
  }
  d.fragment_size.assign(n, 0);
  for (std::uint32_t i = 0; i < n; ++i) ++d.fragment_size[d.fragment_root[i]];
  d.fragment_keep.assign(d.next_fragment_id, kNone);
  for (std::uint32_t r = 0; r < n; ++r) {  // roots in increasing order: ties go to the smaller root
    if (d.fragment_root[r] != r) continue;
    std::uint32_t& keep = d.fragment_keep[d.fragment_id[r]];
    if (keep == kNone || d.fragment_size[r] > d.fragment_size[keep]) keep = r;
  }
  // New id per root, written in place over the root's old id (the root is visited before its
  // members, which read it through fragment_root).
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t r = d.fragment_root[i];
    if (r == i) {
      if (d.fragment_keep[d.fragment_id[i]] != i) d.fragment_id[i] = d.next_fragment_id++;
    } else {
      d.fragment_id[i] = d.fragment_id[r];
    }
  }
  return count;
}

void register_fragment_fields(FieldRegistry& r) {
  r.push_back(make_field("fragment_id", FieldType::u32, 1, "1",
                         "stable piece id (component of alive bonds): the smallest particle index at first, "
                         "kept by a piece's largest part when it splits; other parts get new ids (>= particle count)",
                         [](WorldState& w, FieldView& v) {
    w.derived.fragment_count = update_piece_ids(w);
    view_array(v, w.derived.fragment_id);
  }, true));
}

}  // namespace perifx::systems
