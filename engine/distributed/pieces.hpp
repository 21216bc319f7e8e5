// Pieces of a distributed run (issue 17): the connected components of the alive-bond graph found by
// the ranks together, each from its own bonds, with the same result as one process
// (systems/fragments.cpp: every particle's root is the smallest global index in its component). No
// MPI here; the runtime (mpi/runtime_mpi.cpp) moves the labels, the in-process test copies them.
//
// 1. Local: a union-find over the rank's base particles (owned and bond ghosts) joined by the alive
//    bonds of its owned rows. Local order is global order there (local_world.hpp), so each local
//    component's root is its smallest global index, and that is its first label.
// 2. Rounds: every owner sends, over the bond-halo links, the label of the component each of its
//    shared particles is in to the ranks holding it as a ghost, and a receiver lowers the label of
//    the component holding that ghost to the smaller value. When a round lowers no label on any rank,
//    every component carries the smallest global index of the global component it lies in: a label
//    moves along bonds, and it keeps moving while two components joined by a particle disagree.
//    One direction is enough: bonds are listed both ways, so when rank A holds B's particle g as a
//    ghost through a bond (a, g), B holds a as a ghost through (g, a), and a's component on B is
//    g's; what A knows about g's piece reaches B through a.
// The number of rounds is at most the longest chain of ranks a piece crosses, plus one to see that
// nothing changed. A bond between two ranks is held by both owners with the same alive state
// (bond_rules.hpp), so both see the same graph.
//
// Contact ghosts have no bonds on a rank and take no part. The stable ids (which part of a split
// piece keeps its id) are then given on rank 0 from the gathered roots (systems::update_piece_ids):
// that step is a pass over particles, not bonds.
#pragma once
#include <cstdint>
#include <vector>

#include "components/world_state.hpp"
#include "distributed/local_world.hpp"

namespace perifx::distributed {

struct PieceLabels {
  std::vector<std::uint32_t> root;   // per base particle (local index < layout.base_count): its local component's root
  std::vector<std::uint32_t> label;  // per local root: the smallest global index known to be in the component
};

// Step 1: the local components and their first labels.
void label_local_pieces(const WorldState& local, const LocalLayout& layout, PieceLabels& pieces);

// The label of base particle `i`'s component.
inline std::uint32_t piece_label(const PieceLabels& pieces, std::uint32_t i) { return pieces.label[pieces.root[i]]; }

// Lowers the label of `i`'s component to `label` if that is smaller; true when it did.
inline bool lower_piece_label(PieceLabels& pieces, std::uint32_t i, std::uint32_t label) {
  std::uint32_t& mine = pieces.label[pieces.root[i]];
  if (label >= mine) return false;
  mine = label;
  return true;
}

// After the rounds: the global root (smallest global index of the component) of every owned
// particle, in owned order, into `out` (layout.owned_count entries).
void owned_piece_roots(const PieceLabels& pieces, const LocalLayout& layout, std::uint32_t* out);

}  // namespace perifx::distributed
