// Domain decomposition for distributed runs (issue 17): how a world's particles split over N ranks and
// what each rank must receive from the others every step: the plan `perifx info --ranks N` prints and
// bench/README.md's projection is computed from. The MPI runtime (runtime.hpp) splits by
// split_by_work and takes its bond ghosts from bond_ghosts (its contact ghosts: local_world.hpp).
//
// Domains. The particles are in Morton order (engine/geometry, one body after another), so a
// contiguous index range is a compact piece of space. Rank r owns the range [first, last) whose
// cumulative work, Σ (listed bonds + kParticleWork) in index order, falls in the r-th N-th of the total:
// the bond passes cost per bond, integration, contact checks and output per particle. Deterministic:
// integer prefix sums only.
//
// Ghosts. A rank needs, of particles it does not own, every value its owned particles read:
//   bond ghosts:    the far ends of its owned particles' listed bonds (alive or not: a broken bond's
//                   pair is a contact candidate, and the list is fixed at set-up); in FEM mode, where
//                   the particles are the mesh vertices and have no bonds (components/fem.hpp), the
//                   other vertices of the tets at its owned vertices, and a vertex's work counts its
//                   tet corners in place of bonds;
//   contact ghosts: the particles within the contact reach (largest contact distance + skin,
//                   components/contact.hpp) of an owned particle in the current positions.
// Per step a ghost's position and velocity (after the drift), its dilatation θ (after the dilatation
// pass; P = (a4 − b4β)θ and βθ follow from constants sent once) and its break limit (from its damage)
// cross the network: kGhostBytesPerStep. Reference position, volume and model constants are static
// and are sent once (and again when the domains are re-balanced).
#pragma once
#include <cstdint>
#include <vector>

#include "components/world_state.hpp"

namespace perifx::distributed {

// Work of one particle in units of one bond (integration, contact test, output): the elastic step
// measured about 150 bonds per particle at 1.5e8 bond-updates/s and a few ns of per-particle work
// besides, so its weight is small but keeps bond-less particles from piling onto one rank.
inline constexpr std::uint64_t kParticleWork = 8;
// A particle whose held rotation is stepped (systems/mesh_rotations.cpp: tracked, i.e. with a broken
// bond, in a world with an embedded mesh) costs about 1/kHeldRotationDivisor of its alive bonds more:
// a fitting family refits every 8th step at two outer products per alive bond; BM_MeshRotations with
// every particle tracked takes 0.19 of an elastic step (bench/README.md, "Embedded-mesh costs").
inline constexpr std::uint32_t kHeldRotationDivisor = 5;
// Bytes each ghost receives per step: position and velocity (2 × 24), θ (8), break limit (8); in FEM
// mode the motion only.
inline constexpr std::uint64_t kGhostBytesPerStep = 64;
inline constexpr std::uint64_t kFemGhostBytesPerStep = 48;

struct Domain {
  std::uint32_t first = 0, last = 0;     // owned particles [first, last)
  std::uint64_t bonds = 0;               // listed bonds of the owned particles (FEM: their tet corners)
  std::uint64_t work = 0;                // Σ bonds + kParticleWork per owned particle
  std::vector<std::uint32_t> ghosts;     // not owned, read by owned particles; ascending
  std::uint32_t bond_ghosts = 0;         // of which the far ends of owned bonds
  std::uint32_t contact_ghosts = 0;      // of which within contact reach only (not bond ghosts)
  std::vector<std::uint32_t> neighbor_ranks;  // ranks owning at least one ghost; ascending
  std::uint64_t halo_bytes_per_step = 0;      // ghosts × kGhostBytesPerStep (FEM: kFemGhostBytesPerStep)
};

// Contiguous ranges of equal work; ranks ≥ 1 and ≤ particles (throws std::invalid_argument otherwise).
std::vector<Domain> split_by_work(const WorldState& w, int ranks);
// The same with the work of each particle given (a distributed run's re-balance: current_work);
// Domain::work is then that work, Domain::bonds is left 0.
std::vector<Domain> split_by_work(const std::vector<std::uint32_t>& work, int ranks);
// The current work of particles [first, first + count) of w in bond units, for a re-balance: alive
// bonds, contact candidates (when the pair list is valid), kParticleWork, and alive/kHeldRotationDivisor
// more for a particle whose held rotation is stepped.
std::vector<std::uint32_t> current_work(const WorldState& w, std::uint32_t first, std::uint32_t count);
// Every domain's bond ghosts (far ends of its owned bonds outside its range), ascending: the same
// lists on every rank, from the full world.
std::vector<std::vector<std::uint32_t>> bond_ghosts(const WorldState& w, const std::vector<Domain>& domains);
// Fills each domain's ghosts, counts, neighbour ranks and halo bytes for the current positions.
void find_ghosts(const WorldState& w, std::vector<Domain>& domains);
// Both: the plan for `ranks` ranks.
std::vector<Domain> decompose(const WorldState& w, int ranks);

}  // namespace perifx::distributed
