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
// FEM worlds (components/fem.hpp: the particles are the mesh vertices, no bonds): the local world
// holds the tets with an owned vertex, in increasing global order, and an owned vertex's corner list
// in the whole world's order, so its force sums the same corner forces in the same order; the ghosts
// are those tets' other vertices (decomposition.hpp), and only the motion halo runs (no θ, no break
// limits). A ghost vertex has an empty corner list.
//
// Owned bond rows keep their global order, so a rank's bonds are the global bond range
// [offsets[first], offsets[last]) as is: gathering them for output is a plain concatenation.
//
// Contact ghosts. Particle contact needs, besides the bond ghosts, every particle of another rank that
// can come within the contact distance of an owned one. Those change as pieces move, so they are
// appended after the bond ghosts and the owned range (not in global order; WorldState::global_index
// says who they are) and refreshed with a skin, as a Verlet list is: at a refresh a rank receives every
// particle within contact_layer = d_c,max + contact_skin of one of its owned particles. "Within" is
// tested on the cells of a fixed grid of size contact_layer: each rank lists the cells its owned
// particles occupy, and a particle goes to every rank that occupies one of the 27 cells around its
// own. The grid is absolute, so the selection depends on absolute positions, but only by sending more:
// two particles at most contact_layer apart differ by at most one cell along each axis, so every
// remote particle within contact_layer of an owned one at the refresh is sent (or is a bond ghost,
// whose motion comes anyway). That is all the argument below needs. Contact ghosts move with the
// motion halo; the contact system sums an owned particle's pairs in increasing global index, so its
// force has the one-process bits whichever ghosts are present (systems/contact.cpp).
//
// When the contact ghosts must be refreshed (contact_ghost_motion, contact_ghosts_stale). Let d_i be
// particle i's displacement since the last refresh, at the positions the next step's contact will
// read. A remote particle j missing from owned particle i's rank was farther than contact_layer from
// i at the refresh, so now |y_i − y_j| > contact_layer − |d_i − d_j|: the ghosts are complete as long
// as |d_i − d_j| ≤ contact_skin for every such pair, and then no missing pair is within d_c,max.
// Only differences of displacements enter: a translation of everything closes no pair. Two
// conditions each bound every difference, and the ghosts are kept when either holds:
//   (A) every particle has |d_i| ≤ contact_skin/2 (then |d_i − d_j| ≤ |d_i| + |d_j| ≤ contact_skin);
//   (B) the box that holds every particle's d_i has a diagonal ≤ contact_skin (any two points of a box
//       are at most its diagonal apart). A body falling as one, or pieces drifting together, passes
//       (B) whatever distance they travel; pieces flying apart from where they are pass (A) longer.
// The test runs after a step, when the next step's positions are not known: each particle's d_i is
// taken as a ball of radius L_i (the look-ahead, below) around its displacement now, so (A) uses
// |d_i| + L_i and (B) the box of the cubes d_i ± L_i. Each rank measures its owned particles
// (contact_ghost_motion: its (A) and its box); the runtime combines every rank's in the step's one
// MPI_Allreduce, a MIN over uint64 words (encode_contact_ghost_motion: (A) as 0/1, the box's lower
// corner in an order-preserving map of the doubles, its upper corner in the complement of that map,
// so the MIN gives the largest), and every rank decodes the same words and decides the same (a min
// or max is exact: no order of summation enters).
// The look-ahead L_i bounds how far i moves in the next step (velocity Verlet, systems/integration.cpp;
// the step runs kick_begin, boundary conditions, drift, colliders; a, v as at the end of this step):
//   the drift: y += dt·v', v' = e·v + (dt/2)·a with the damping factor e ≤ 1, so at most
//     D_i = dt|v| + dt²|a|/2. Forces (contact, projectiles, loads) act through a and enter the step
//     after; nothing else moves a particle (projectiles move themselves only).
//   colliders (systems::collider_lookahead in colliders.cpp, beside the push-out rule it bounds):
//     none: L_i = D_i. One static plane (most scenes: a ground): its depth is linear in the
//     particle's position (the centre, the faces placed by the frame of the last step and the sphere
//     of reach all move with it and meet the plane along the same normal), so the push-out, along the
//     normal, at most takes back the drift's inward part, beyond which the depth the particle had
//     before the drift is taken out at ≤ kDepenetrationSpeed (colliders.cpp): L_i = D_i + 0.5 m/s·dt.
//     Otherwise (several colliders, moving or curved ones): the push-out of one static convex collider
//     is at most the depth the drift gained (depths are 1-Lipschitz) plus that depenetration, and a
//     moving one's surface moves at most dt·(|v_c| + |ω_c|·arm); L_i = 2 D_i + dt·Σ_c (0.5 m/s +
//     |v_c| + |ω_c|·arm). Not a proof for a particle that two colliders push in the same step (the
//     second one's "before" is measured from the first one's push) or where a curved collider's
//     sphere of reach switches on; the factor 2 leaves room, as it always did.
//   boundary conditions (particles in a condition's list): the next step's prescribed velocity is the
//     condition's; L_i is at least 2 (dt|v| + dt²|a|), the look-ahead every particle had before
//     (2026-12), which follows a steady or ramped condition but not one that switches on at once.
// After a refresh the next step is not tested before it runs: a particle whose look-ahead exceeds
// contact_skin/2 (1.5 d_c,max with the default skin, more than a particle spacing in one step) could
// outrun the new ghosts in that step.
//
// Projectiles are replicated: every rank steps the same spheres; the forces they receive are summed
// over every rank's touching particles in global order (projectile_contact's gather, runtime).
//
// The embedded tet mesh stays in rank 0's full world (runtime.hpp replays its splits); a local world
// holds only the mesh's per-particle held rotations, which mesh_rotations steps from the families.
#pragma once
#include <cstdint>
#include <functional>
#include <limits>
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
  std::vector<HaloLink> contact_sends_before;  // the previous refresh's contact_sends: what each rank holds
  std::vector<Vec3> refreshed_at;         // per owned particle: its position at the last refresh, m
};

// A rank's local world as bytes (its layout's local order, counts and halo links, and every array but
// the contact buffers), made by rank 0 from the whole world; and that local world rebuilt from them on
// its rank, which holds a shell of the world (WorldBuild::shell, or a whole world whose arrays World::split
// released): the non-array parts (settings, clock, boundary conditions, load definitions, contact
// settings) come from it. `layout` must hold rank, ranks and domains; local_world_from fills in the
// rest, so that layout and world equal what make_layout and make_local_world give from the whole
// world. Every split sends each rank this (runtime.hpp).
// It travels as a sequence of pieces (a value, or an array's count and then its elements):
// write_local_world hands them to `put` in order, read_local_world asks `take` for the same sizes in
// the same order, so the runtime sends each piece as its own message and neither side holds the whole
// message beside the world (runtime_mpi.cpp); pack_local_world and local_world_from do the same
// through one buffer.
using PutBytes = std::function<void(const void* data, std::size_t bytes)>;
using TakeBytes = std::function<void(void* data, std::size_t bytes)>;
void write_local_world(const WorldState& local, const LocalLayout& layout, const PutBytes& put);
std::unique_ptr<WorldState> read_local_world(const WorldState& shell, LocalLayout& layout, const TakeBytes& take);
std::vector<char> pack_local_world(const WorldState& local, const LocalLayout& layout);
std::unique_ptr<WorldState> local_world_from(const WorldState& shell, LocalLayout& layout,
                                             const std::vector<char>& message);

// What a shell (WorldBuild::shell) cannot know without meshing the bodies, from the whole world: its
// clock, the instability bound (it depends on the bodies' extent), the contact reach and skin (the
// largest particle), the contact time scale (from the stable-step estimate), and every body's particle and vertex ranges, mean edge length and horizon.
// World::split broadcasts it from rank 0 before every split.
std::vector<char> pack_world_frame(const WorldState& whole);
void take_world_frame(WorldState& shell, const std::vector<char>& message);

// The layout of `rank` among `domains` (ghost lists from bond_ghosts, or `ghosts` when given: its
// result for these domains, which a caller making several ranks' layouts computes once).
LocalLayout make_layout(const WorldState& full, const std::vector<Domain>& domains, int rank,
                        const std::vector<std::vector<std::uint32_t>>* ghosts = nullptr);

// The local world of a layout: a copy of the owned particles and their bond ghosts, their bonds,
// boundary conditions, loads, contact settings and projectiles, remapped to local indices. Sets the
// layout's contact layer and skin.
// `to_send`: made by rank 0 for pack_local_world, which sends neither the contact buffers nor the
// projectiles' per-block lists, so they are not made (nor the layout's contact layer).
std::unique_ptr<WorldState> make_local_world(const WorldState& full, LocalLayout& layout, bool to_send = false);

// A contact ghost refresh, in four steps: every rank lists its occupied cells (contact_cells); the
// lists go to every rank; each rank finds what it sends (find_contact_sends), packs it
// (pack_contact_ghosts), and the receiver sets what it got (set_contact_ghosts), which replaces the
// previous contact ghosts. The transport is the runtime's (or the in-process test's).
// Incremental: a message holds the sender's whole list to the receiver as global indices (a uint32
// count, then the indices, in increasing order) but the records (every per-particle array) only of the
// particles that enter the list, those not in the previous refresh's list to that rank
// (contact_sends_before; the receiver holds exactly those as its contact_receives from the sender).
// The receiver keeps the records of the others as it has them: their motion arrived with this step's
// halo, and nothing reads anything else of a contact ghost that changes after set-up (contact.cpp reads
// its position, velocity, reference position, mass, size and body). The new ghosts are then exactly
// those a whole-record refresh gives, in the same order, so the contact list and forces are too.
std::vector<std::uint64_t> contact_cells(const WorldState& local, const LocalLayout& layout);
void find_contact_sends(const WorldState& local, LocalLayout& layout,
                        const std::vector<std::vector<std::uint64_t>>& cells_by_rank);
std::vector<char> pack_contact_ghosts(const WorldState& local, const LocalLayout& layout, const HaloLink& link);
void set_contact_ghosts(WorldState& local, LocalLayout& layout,
                        const std::vector<std::pair<int, std::vector<char>>>& messages);
// The refresh test (see "When the contact ghosts must be refreshed" above). One rank's measure of its
// owned particles: (A) and the box of the displacements widened by their look-ahead. No owned
// particles: (A) holds and the box is empty (low +inf, high −inf). A non-finite value (or no refresh
// yet) fails both: (A) false, the box infinite.
struct ContactGhostMotion {
  bool within_half_skin = true;  // (A): |d_i| + L_i ≤ contact_skin/2 for every particle measured
  Vec3 low = Vec3::Constant(std::numeric_limits<double>::infinity());    // (B): min of d_i − L_i, m
  Vec3 high = Vec3::Constant(-std::numeric_limits<double>::infinity());  //      max of d_i + L_i, m
};
ContactGhostMotion contact_ghost_motion(const WorldState& local, const LocalLayout& layout);
// Every rank's measures at once: (A) of all, the box around all.
ContactGhostMotion combine(const ContactGhostMotion& a, const ContactGhostMotion& b);
// The measure as words whose elementwise minimum over ranks is the encoding of the ranks' combine
// (the runtime's MPI_Allreduce with MPI_MIN over MPI_UINT64_T), and back.
constexpr std::size_t kContactGhostMotionWords = 7;
void encode_contact_ghost_motion(const ContactGhostMotion& motion, std::uint64_t* words);
ContactGhostMotion decode_contact_ghost_motion(const std::uint64_t* words);
// Neither (A) nor (B) holds for the combined measure of every rank: refresh.
bool contact_ghosts_stale(const ContactGhostMotion& everyone, double contact_skin);
// One step's look-ahead L_i of local particle i (above); `constrained`: i is in a boundary condition's list.
double contact_ghost_lookahead(const WorldState& local, std::uint32_t i, bool constrained);

}  // namespace perifx::distributed
