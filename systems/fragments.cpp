// Fragments: connected components of the graph of alive bonds (particles are nodes). Computed on
// request for output frames and the run summary, not every step. Sequential union-find with the
// smaller root always winning, so every component's root is its smallest particle index: the ids
// are deterministic and independent of thread count. A particle with no alive bond is a fragment.
// Reads: bond_alive.   Writes: nothing in the world (the caller's fragment_id array).
#include <numeric>

#include "field_registry.hpp"
#include "systems.hpp"

namespace perifx::systems {

std::size_t compute_fragments(const WorldState& w, std::vector<std::uint32_t>& id) {
  const Bonds& b = w.bonds;
  const std::size_t n = w.particles.count();
  id.resize(n);
  std::iota(id.begin(), id.end(), 0u);
  auto find = [&](std::uint32_t a) {
    while (id[a] != a) {
      id[a] = id[id[a]];  // path halving
      a = id[a];
    }
    return a;
  };
  for (std::uint32_t i = 0; i < n; ++i)
    for (std::uint32_t k = b.offsets[i], end = b.offsets[i + 1]; k < end; ++k) {
      const std::uint32_t j = b.neighbor[k];
      if (j <= i || !b.alive[k]) continue;
      const std::uint32_t ri = find(i), rj = find(j);
      if (ri < rj) id[rj] = ri;
      else if (rj < ri) id[ri] = rj;
    }
  std::size_t count = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    id[i] = id[id[i]];  // roots precede their members, so one pass flattens every path
    count += id[i] == i;
  }
  return count;
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
