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
// Contact ghosts. Particle contact needs, besides the bond ghosts, every particle of another rank that
// can come within the contact distance of an owned one. Those change as pieces move, so they are
// appended after the bond ghosts and the owned range (not in global order; WorldState::global_index
// says who they are) and refreshed with a skin, as a Verlet list is: at a refresh a rank receives every
// particle within contact_layer = d_c,max + contact_skin of one of its owned particles, and the set
// stays complete until some particle anywhere has moved more than contact_skin/2 since (then two
// particles have closed by at most contact_skin). "Within" is tested on cells of size contact_layer:
// each rank lists the cells its owned particles occupy, and a particle goes to every rank that
// occupies one of the 27 cells around its own. Contact ghosts move with the motion halo; the contact
// system sums an owned particle's pairs in increasing global index, so its force has the one-process
// bits whichever ghosts are present (systems/contact.cpp).
//
// Projectiles are replicated: every rank steps the same spheres; the forces they receive are summed
// over every rank's touching particles in global order (projectile_contact's gather, runtime).
//
// The embedded tet mesh stays in rank 0's full world (runtime.hpp replays its splits); a local world
// holds only the mesh's per-particle held rotations, which mesh_rotations steps from the families.
#pragma once
#include <cstdint>
#include <memory>
#include <utility>
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

  // Contact ghosts (worlds with particle contact; see above). global_of grows by them, in the order
  // they were appended: by sending rank, each rank's in increasing global index.
  std::uint32_t base_count = 0;           // owned particles and bond ghosts: the local particles before them
  double contact_layer = 0.0;             // m
  double contact_skin = 0.0;              // m
  std::vector<HaloLink> contact_sends;    // owned particles other ranks hold as contact ghosts, by rank
  std::vector<HaloLink> contact_receives; // this rank's contact ghosts, by owning rank
  std::vector<Vec3> refreshed_at;         // per owned particle: its position at the last refresh, m
};

// The layout of `rank` among `domains` (ghost lists from bond_ghosts).
LocalLayout make_layout(const WorldState& full, const std::vector<Domain>& domains, int rank);

// The local world of a layout: a copy of the owned particles and their bond ghosts, their bonds,
// boundary conditions, loads, contact settings and projectiles, remapped to local indices. Sets the
// layout's contact layer and skin.
std::unique_ptr<WorldState> make_local_world(const WorldState& full, LocalLayout& layout);

// A contact ghost refresh, in four steps: every rank lists its occupied cells (contact_cells); the
// lists go to every rank; each rank finds what it sends (find_contact_sends), packs it
// (pack_contact_ghosts: whole particle records, every per-particle array), and the receiver appends
// what it got (set_contact_ghosts), which replaces the previous contact ghosts. The transport is the
// runtime's (or the in-process test's).
std::vector<std::uint64_t> contact_cells(const WorldState& local, const LocalLayout& layout);
void find_contact_sends(const WorldState& local, LocalLayout& layout,
                        const std::vector<std::vector<std::uint64_t>>& cells_by_rank);
std::vector<char> pack_contact_ghosts(const WorldState& local, const HaloLink& link);
void set_contact_ghosts(WorldState& local, LocalLayout& layout,
                        const std::vector<std::pair<int, std::vector<char>>>& received_by_rank);
// This rank's half of the refresh test: some owned particle may, after the next step's drift, be more
// than contact_skin/2 from where it was at the last refresh (the bound is 2 × (dt|v| + dt²|a|), twice
// the drift's own displacement, which leaves room for boundary conditions and colliders).
bool contact_ghosts_stale(const WorldState& local, const LocalLayout& layout);

}  // namespace perifx::distributed
