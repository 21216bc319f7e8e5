// Crack faces system (paper §5.2, systems/README.md §6.4: only bonds between face-adjacent
// tetrahedra put their shared triangle into the crack face set).
// Scans the watched face pairs (original face-adjacent tet pairs that are still intact and bonded,
// ≈2 per tet, one byte load each) for a broken bond; each one found becomes cracked, joins the
// pending crack faces and this step's `fresh` list, and stops being watched. Faces on the original
// boundary have no pair, so they can never become crack faces. The scan is a parallel "any broken?"
// over fixed blocks; only when one is found is the list compacted serially, in pair order, so the
// result does not depend on the thread count.
// Reads:  bond_alive.   Writes: mesh (embedded mesh: pair states, pending, fresh).
// Scheduled after fracture, only when world.any_fracture.
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_reduce.h>

#include <algorithm>

#include "systems.hpp"

namespace perifx::systems {

std::size_t collect_crack_faces(WorldState& w) {
  EmbeddedMesh& e = w.embedded;
  const auto& alive = w.bonds.alive;
  const auto& watched = e.watched_pairs;
  const bool any = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, watched.size(), 8192), false,
      [&](const tbb::blocked_range<std::size_t>& r, bool found) {
        if (found) return true;
        for (std::size_t q = r.begin(); q != r.end(); ++q)
          if (!alive[e.pair_bond[watched[q]]]) return true;
        return false;
      },
      [](bool a, bool b) { return a || b; });
  if (!any) return 0;
  std::size_t kept = 0, added = 0;
  for (std::size_t q = 0; q < watched.size(); ++q) {
    const std::uint32_t pair = watched[q];
    if (alive[e.pair_bond[pair]]) {
      e.watched_pairs[kept++] = pair;
      continue;
    }
    e.pair_state[pair] = FaceState::cracked;
    e.fresh.push_back(pair);
    ++added;
  }
  e.watched_pairs.resize(kept);
  // fresh is in pair order per call; merge into the sorted pending list.
  const auto mid = e.pending.size();
  e.pending.insert(e.pending.end(), e.fresh.end() - static_cast<std::ptrdiff_t>(added), e.fresh.end());
  std::inplace_merge(e.pending.begin(), e.pending.begin() + static_cast<std::ptrdiff_t>(mid), e.pending.end());
  e.crack_faces_total += added;
  return added;
}

SystemDecl crack_face_system(WorldState& w) {
  return {"crack_faces", {Component::bond_alive, Component::mesh}, {Component::mesh},
          [&w] { collect_crack_faces(w); }};
}

}  // namespace perifx::systems
