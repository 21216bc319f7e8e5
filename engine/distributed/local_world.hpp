// One rank's world in a distributed run (issue 17): its owned particles (a contiguous range of the
// global Morton order, decomposition.hpp) and its ghosts, as an ordinary WorldState that the ordinary
// step pipeline runs on. No MPI here; engine/distributed/mpi/ moves the halo between ranks.
//
// Local order. Local particles are the owned range and the ghosts, sorted by global index: ghosts
// below the range, the owned range, ghosts above it. The map is increasing, so every family keeps its
// neighbours in the same order as in one process, every per-particle sum runs in the same order and
// the owned particles compute the same bits as in one process.
//
// Ghost rows are empty. A ghost has no bonds here, so the systems compute nothing meaningful for it;
// its flags carry kPrescribed (integration leaves it alone, colliders skip it) and the halo overwrites
// what the owned particles read of it, each step, before they read it:
//   motion     after the drift and colliders: position, velocity            (6 doubles)
//   dilatation after the dilatation pass:      θ; the receiver recomputes P = (a4 − b4β)θ (1 double)
//   threshold  after the fracture threshold:   break extension               (1 double)
// 8 doubles, 64 bytes, per ghost and step (decomposition.hpp's kGhostBytesPerStep).
// Everything else an owned particle reads of a neighbour (reference position, volume, model
// constants) is copied once here. A bond across two ranks is held by both owners; each decides its
// plasticity and break from the same values, as the two ends of a bond do in one process
// (systems/bond_rules.hpp).
//
// Owned bond rows keep their global order, so a rank's bonds are the global bond range
// [offsets[first], offsets[last]) as is: gathering them for output is a plain concatenation.
//
// What a local world does not hold (yet): the embedded tet mesh, particle contact and projectiles
// (make_local_world refuses worlds that use the latter two).
#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include "components/world_state.hpp"
#include "distributed/decomposition.hpp"

namespace perifx::distributed {

// Which local particles one rank sends to, or receives from, one other rank at each halo stage.
struct HaloLink {
  int rank = 0;                      // the other rank
  std::vector<std::uint32_t> local;  // local indices, in increasing global order (both sides agree)
};

struct LocalLayout {
  int rank = 0, ranks = 1;
  std::vector<Domain> domains;            // every rank's owned range (same on every rank)
  std::vector<std::uint32_t> global_of;   // local → global index, increasing
  std::uint32_t owned_begin = 0;          // local index of the first owned particle
  std::uint32_t owned_count = 0;
  std::uint64_t bond_begin = 0;           // global index of the first owned bond
  std::vector<HaloLink> sends;            // owned particles other ranks hold as ghosts, by rank
  std::vector<HaloLink> receives;         // this rank's ghosts, by owning rank
  std::size_t ghost_count() const { return global_of.size() - owned_count; }
};

// The layout of `rank` among `domains` (ghost lists from bond_ghosts).
LocalLayout make_layout(const WorldState& full, const std::vector<Domain>& domains, int rank);

// The local world of a layout: a copy of the owned particles and their ghosts, their bonds, boundary
// conditions and loads, remapped to local indices. Throws std::invalid_argument for worlds that use
// particle contact or projectiles (not distributed yet).
std::unique_ptr<WorldState> make_local_world(const WorldState& full, const LocalLayout& layout);

}  // namespace perifx::distributed
