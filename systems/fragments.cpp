// Fragments: connected components of the graph of alive bonds (particles are nodes). Computed on
// request for output frames and the run summary, not every step. Sequential union-find with the
// smaller root always winning (union_find.hpp), so every component's root is its smallest particle
// index: the ids are deterministic and independent of thread count. A particle with no alive bond
// is a fragment.
// Reads: bond_alive.   Writes: nothing in the world (the caller's fragment_id array).
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


void register_fragment_fields(FieldRegistry& r) {
  r.push_back(make_field("fragment_id", FieldType::u32, 1, "1",
                         "connected component of alive bonds: its smallest particle index",
                         [](WorldState& w, FieldView& v) {
    w.derived.fragment_count = compute_fragments(w, w.derived.fragment_id);
    view_array(v, w.derived.fragment_id);
  }, true));
}

}  // namespace perifx::systems
