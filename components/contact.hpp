// Contact and rigid projectiles: plain data owned by the world (systems/contact.cpp and
// systems/projectiles.cpp read and write it; setup sizes every buffer once).
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "components/math.hpp"
#include "components/spatial_grid.hpp"

namespace perifx {

// Candidate pairs (Verlet list with a skin, as in molecular dynamics): for each particle i, the
// particles j that were within reach = largest d_c + skin of it and not joined by an alive bond when
// the pair was last decided. Every pair that can touch is in it: a particle that has moved more than
// 0.3 skin (relative to the centroid) since its own last search is searched again and its pairs are
// re-decided on both sides; when bonds break, the pairs of the broken bonds within reach + ¼ skin are added
// (systems/contact.cpp gives the argument). CSR, symmetric, in a deterministic order. An intact body
// has an empty list and costs one O(n) check per step.
struct ContactPairs {
  double skin = 0.0;                       // m
  std::vector<std::uint32_t> offsets;      // particles + 1
  std::vector<std::uint32_t> neighbor;     // candidates of i: neighbor[offsets[i], offsets[i] + length[i]);
                                           // the row may hold up to offsets[i+1] − offsets[i] (its
                                           // capacity; the rest is unused), so an update rewrites only
                                           // the rows it changes, in place
  std::vector<std::uint32_t> length;       // particles: candidates in the row
  std::vector<std::uint32_t> near_count;   // particles: the row's first near_count entries are its near
                                           // part (systems/contact.cpp: pairs that can touch before
                                           // either end is searched again), the rest its far part
  std::vector<std::uint32_t> count;        // particles: scratch for the build (candidates per particle)
  std::vector<std::uint32_t> scratch;      // particles × kScratchPerParticle: a search's first pass
                                           // keeps up to that many finds per searched particle here,
                                           // so only particles with more need a second search. The
                                           // full rebuild's forward half-search (a few finds each) uses
                                           // one row per particle; the moved-particle update (at most
                                           // particles/16 of them) two rows per moved particle.
  static constexpr std::uint32_t kScratchPerParticle = 16;
  std::vector<Vec3> built_position;        // per particle: position minus the centroid of all
                                           // particles, at the particle's last search, m
  // The moved-particle update's buffers (sized at setup; only the CSR arrays grow, when they outgrow
  // every earlier update): moved[i] = 1 when i moved more than 0.3 skin since its last search (this
  // step's test), moved_list the moved particles ascending, moved_offsets/moved_neighbor their new
  // candidates (CSR over moved_list), found_by[j] how many moved particles found unmoved j, then its
  // write cursor (all 0 between updates).
  // partner_moved[j] = 1 during an update when j's row holds a moved particle (all 0 between updates).
  // resort[i] = 1 when an update appended to i's row, which sort_rows then splits and sorts again
  // (all 0 between updates).
  std::vector<std::uint8_t> moved, partner_moved, resort;
  // The update's search (systems/contact.cpp, for_each_candidate_moved) looks particles up in
  // ContactState::search_grid, which holds their search positions as of its build. displaced[i] = 1
  // when i was searched again since (its cell there is stale); displaced_list lists those (at most
  // particles/8 + 1), whose latest search positions ContactState::displaced_grid holds.
  // search_grid_valid is false until the next update builds the grid.
  std::vector<std::uint8_t> displaced;
  std::vector<std::uint32_t> displaced_list;
  bool search_grid_valid = false;
  std::uint64_t search_grid_builds = 0;    // diagnostics
  std::uint64_t displaced_grid_builds = 0; // diagnostics
  std::vector<std::uint32_t> moved_list, moved_offsets, moved_neighbor, found_by;
  // Build scratch, one row of `particles` entries per worker thread slot: while thread t builds the
  // list of particle i it marks i's alive bond partners j with bonded_stamp[t·n + j] = stamp, so
  // "bonded?" is one load instead of a binary search. Stamps are unique per (build pass, particle).
  std::vector<std::uint64_t> bonded_stamp;
  std::size_t stamp_slots = 0;
  std::uint64_t stamp_base = 0;            // advanced by (particles + 1) per build pass
  std::uint64_t broken_at_build = 0;       // Σ broken bonds at the last build or addition
  std::vector<std::uint64_t> alive_at_build;  // bonds.alive as of then, one bit per directed bond k
                                              // (bit k % 64 of word k / 64): the bonds that broke
                                              // since are the list's only new candidates
  std::vector<std::uint32_t> broken_seen;    // per particle: its broken-bond count as of then, so
                                             // only particles with new breaks scan their bonds
  std::vector<std::uint32_t> offsets_next, neighbor_next;  // scratch: the build's forward half-list,
                                                           // and a new layout when a row outgrows its capacity
  std::uint64_t additions = 0;             // incremental updates after breaks (diagnostics)
  bool valid = false;                      // false until the first build
  std::uint64_t builds = 0;                // full rebuilds so far (diagnostics)
  std::uint64_t partial_updates = 0;       // updates that searched only the moved particles
  std::uint64_t layouts = 0;               // updates that laid the rows out anew (a row outgrew its room)
  std::uint64_t searched = 0;              // particles searched by those updates
};

struct ContactState {
  bool enabled = false;          // particle–particle contact runs this world (scene "contact")
  double distance_factor = 0.9;  // d_c = factor·(s_i + s_j)/2,  s = ∛V
  double stiffness_factor = 0.05;// k = factor·min(m_i, m_j)/max(τ, dt)²
  double time_scale = 0.0;       // τ, s: the contact time scale (settings.contact.time_scale as resolved
                                 // at set-up); 0: the step's
  double damping_ratio = 0.1;    // normal damping, fraction of critical for the pair spring
  double friction = 0.0;         // Coulomb coefficient
  double largest_distance = 0.0; // the largest d_c of any pair, m
  std::vector<double> size;      // s_i = ∛V_i per particle, m
  SpatialGrid grid;              // cell = largest d_c + skin; rebuilt with the pair list
  SpatialGrid search_grid;       // the search positions (ContactPairs::built_position) in cells of
                                 // (largest d_c + skin + 0.3 skin)(1 + 1e-6); see ContactPairs::displaced
  SpatialGrid displaced_grid;    // the displaced particles' search positions, same cells; sorted again
                                 // by every update that reads the search grid (room: particles/8 + 1)
  ContactPairs pairs;
};

// A rigid sphere with mass, integrated by the same velocity Verlet as the particles.
struct Projectile {
  double radius = 0.0;                 // m
  double mass = 0.0;                   // kg
  double inertia = 0.0;                // 2/5 m r², kg·m²
  double friction = 0.0;               // Coulomb coefficient against particles
  Vec3 center = Vec3::Zero();          // m
  Vec3 velocity = Vec3::Zero();        // m/s
  Vec3 angular_velocity = Vec3::Zero();// rad/s
  Vec3 acceleration = Vec3::Zero();    // m/s², from the last force evaluation
  Vec3 angular_acceleration = Vec3::Zero();  // rad/s²
  Vec3 contact_force = Vec3::Zero();   // N, −Σ of the forces it put on particles (last step)
};

struct ProjectileSet {
  std::vector<Projectile> bodies;
  // This step's touching particles by fixed blocks of kBlock consecutive particles (block b holds
  // particles [b·kBlock, (b+1)·kBlock)): for each touching particle of the block in increasing index,
  // for each projectile p, the force p puts on it (N) then that force's torque about p's centre,
  // arm × (−f) (N·m): 6 doubles × projectiles per particle. Blocks are filled in parallel; only
  // particles near a projectile write anything (per-particle slots for every particle and projectile
  // cost 48 B each and were rewritten every step).
  static constexpr std::size_t kBlock = 1024;
  std::vector<std::vector<double>> block_contacts;
  // The blocks' lists joined in block order, so in increasing particle index. The projectiles sum it
  // in this order; a distributed run concatenates every rank's list in rank order first, which is the
  // same order.
  std::vector<double> contacts;
};

}  // namespace perifx
