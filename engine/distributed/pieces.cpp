// Distributed pieces, the MPI-free part (pieces.hpp explains the algorithm).
#include "distributed/pieces.hpp"

#include "systems/union_find.hpp"

namespace perifx::distributed {

void label_local_pieces(const WorldState& w, const LocalLayout& layout, PieceLabels& pieces) {
  const Bonds& b = w.bonds;
  const std::uint32_t n = layout.base_count;
  systems::UnionFind sets(pieces.root, n);
  // Ghost rows are empty, so only owned rows join anything; a bond to a ghost joins the ghost.
  for (std::uint32_t i = layout.owned_begin, end = layout.owned_begin + layout.owned_count; i < end; ++i)
    for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k)
      if (b.alive[k]) sets.unite(i, b.neighbor[k]);
  sets.flatten();
  // Roots are the smallest local index of their component, and global_of is increasing over the base
  // particles, so the root's global index is the component's smallest.
  pieces.label.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) pieces.label[i] = layout.global_of[i];
}

void owned_piece_roots(const PieceLabels& pieces, const LocalLayout& layout, std::uint32_t* out) {
  for (std::uint32_t m = 0; m < layout.owned_count; ++m) out[m] = piece_label(pieces, layout.owned_begin + m);
}

}  // namespace perifx::distributed
