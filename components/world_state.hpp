// Everything a world owns, as plain data. Systems get references to the parts they declare; the
// World class (public API) wraps one of these. No globals: two WorldStates never share anything.
// The scene itself is not kept here: what the step needs from it is resolved into StepSettings (and
// the other components) when the world is built (engine/setup/), so systems never read raw scene
// input. The plain scene value types (materials, colliders, regions ...) come from the public
// vocabulary header perifx/scene.hpp.
#pragma once
#include <cstdint>
#include <limits>
#include <type_traits>
#include <vector>

#include "components/bonds.hpp"
#include "components/contact.hpp"
#include "components/embedded_mesh.hpp"
#include "components/fem.hpp"
#include "components/loads.hpp"
#include "components/particles.hpp"
#include "components/tet_mesh.hpp"
#include "perifx/scene.hpp"  // value types only (Material, Collider, BoundaryCondition ...)

namespace perifx {

// Time of the step being computed. Systems read it; only the clock advances it (World::step).
struct Clock {
  double time = 0.0;         // s, at the start of the current step
  double dt = 1e-4;          // s
  std::uint64_t step = 0;    // steps completed
  // The step at whose end a bond had first broken (initial cracks do not count); kNoBreak until then.
  static constexpr std::uint64_t kNoBreak = ~std::uint64_t{0};
  std::uint64_t first_break_step = kNoBreak;
};

// Particle index lists resolved at setup (regions are tested once, on reference positions).
struct BoundaryConditionSet {
  std::vector<scene::BoundaryCondition> conditions;
  std::vector<std::vector<std::uint32_t>> particles;  // per condition, sorted particle indices
  std::vector<std::uint32_t> constrained;            // union of all lists, sorted
};

// Per body: its particle range, tet mesh range and mesh measures.
struct BodyInfo {
  std::string name;
  std::uint32_t first_particle = 0, particle_count = 0;
  std::uint32_t first_vertex = 0, vertex_count = 0;
  double mean_edge_length = 0.0;  // λ
  double horizon = 0.0;           // δ
};

// Fields derived on request for output (not maintained every step).
struct DerivedFields {
  std::vector<Vec3> displacement;          // y − x, m
  std::vector<std::uint32_t> alive_bonds;  // n_i
  std::vector<double> plastic_strain;      // mean |e^p_ij|/|ξ_ij| over alive bonds (0 with none)
  // Stable piece id per particle (systems/fragments.cpp): a piece that splits keeps its id on its
  // largest part; the other parts get ids never used before (from next_fragment_id on).
  std::vector<std::uint32_t> fragment_id;
  std::vector<std::uint32_t> fragment_root;  // scratch: smallest particle index of i's component
  // The step fragment_root was last given for by a distributed run's gather (engine/distributed/pieces.hpp,
  // found by the ranks together); at that step update_piece_ids reads it instead of finding it again.
  std::uint64_t fragment_root_step = ~std::uint64_t{0};
  std::vector<std::uint32_t> fragment_size;  // scratch: per root, the component's particle count
  std::vector<std::uint32_t> fragment_keep;  // scratch: per old id, the root of the part that keeps it
  std::uint32_t next_fragment_id = 0;        // first id not yet used (starts at the particle count)
  std::size_t fragment_count = 0;
};

// The scene's settings the step reads, resolved once when the world is built.
struct StepSettings {
  Vec3 gravity = Vec3::Zero();                       // m/s²
  scene::Normalization normalization = scene::Normalization::corrected;
  scene::FamilyRule family = scene::FamilyRule::mesh;
  scene::Solver solver = scene::Solver::peridynamics;
  std::vector<scene::Material> materials;            // indexed by Particles::material_id
  std::vector<scene::Collider> colliders;            // kinematic colliders (systems/colliders.cpp)
  scene::Contact contact;                            // particle contact settings (systems/contact.cpp)
  std::vector<scene::Projectile> projectiles;        // initial projectiles (systems/projectiles.cpp)
  scene::Distributed distributed;                    // re-balancing of distributed runs (engine/distributed/)
  int threads = 0;                                   // worker threads of the world's arena (0 = all)
  // The embedded mesh's vertices follow the particles every step (systems/mesh_vertices.cpp) when
  // the scene writes the split mesh (obj, surface_ply, tets_vtu) or can break.
  bool mesh_output = false;
  // Instability bound (kick_end): a free particle faster than this, m/s, means the run blew up.
  // 10 × (fastest wave speed sqrt((κ + 4μ/3)/ρ) + every prescribed, initial, collider, projectile and
  // gravity speed), set in engine/setup/world_setup.cpp; +∞ turns the speed test off (finiteness stays).
  double max_speed = std::numeric_limits<double>::infinity();
};

struct WorldState {
  StepSettings settings;
  Clock clock;
  Particles particles;
  ParticleModel model;
  ParticleState state;
  Bonds bonds;
  // The embedded tet mesh of all bodies; tet i carries particle i (paper §5.2). In FEM mode
  // (scene.solver fem_*) the particles are the mesh vertices instead: vertex v is particle v.
  TetMesh mesh;
  // The same mesh as it cracks: split vertices, crack faces, moving vertices (systems/mesh_*.cpp).
  EmbeddedMesh embedded;
  FemModel fem;                   // FEM mode only (systems/fem_setup.cpp, fem_force.cpp)
  std::vector<BodyInfo> bodies;
  BoundaryConditionSet boundary;
  SurfacePatches surface;         // boundary faces of the reference mesh (surface loads, projectiles)
  OpenableFaces openable_faces;   // faces a crack may open, per particle (colliders)
  LoadSet loads;                  // external loads beyond gravity (systems/external_loads.cpp)
  DerivedFields derived;
  ContactState contact;           // particle–particle contact (systems/contact.cpp)
  ProjectileSet projectiles;      // rigid projectiles (systems/projectiles.cpp)
  bool any_plastic = false;       // some material has a finite yield energy
  bool any_anisotropic = false;   // some material has G ≠ I
  bool any_fracture = false;      // some material has a finite critical stretch
  // Distributed runs (engine/distributed/local_world.hpp): local particles [owned_first, owned_last)
  // are this rank's own, the others ghosts whose forces nobody reads, and global_index[i] is local
  // particle i's index in the whole world (contact sums a particle's pairs in that order). One process
  // owns everything and leaves global_index empty (the index is its own).
  std::uint32_t owned_first = 0;
  std::uint32_t owned_last = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> global_index;
  bool owns(std::size_t i) const { return i >= owned_first && i < owned_last; }
};

// Where an array's bytes are counted in memory reports (World::memory, `perifx info`).
enum class ArrayKind : std::uint8_t { particle, bond, mesh, contact, other };

// Calls f(kind, name, vector) for every array the world owns: the one list memory accounting reads
// (tests/engine/test_world.cpp checks it against the bytes the heap actually holds, so an array left
// out of it fails a test) and the list checkpoints save and restore (engine/io/checkpoint.cpp; the
// resume tests fail when one is missing). W is WorldState or const WorldState (a restore fills them).
// Reflection only; no behaviour.
template <class W, class F>
  requires std::is_same_v<std::remove_const_t<W>, WorldState>
void for_each_array(W& w, F&& f) {
  using K = ArrayKind;
  auto& p = w.particles;
  f(K::particle, "particles.reference_position", p.reference_position);
  f(K::particle, "particles.position", p.position);
  f(K::particle, "particles.velocity", p.velocity);
  f(K::particle, "particles.acceleration", p.acceleration);
  f(K::particle, "particles.volume", p.volume);
  f(K::particle, "particles.mass", p.mass);
  f(K::particle, "particles.material_id", p.material_id);
  f(K::particle, "particles.body_id", p.body_id);
  f(K::particle, "particles.flags", p.flags);
  auto& m = w.model;
  f(K::particle, "model.horizon", m.horizon);
  f(K::particle, "model.anisotropy_metric", m.anisotropy_metric);
  f(K::particle, "model.anisotropic_family", m.anisotropic_family);
  f(K::particle, "model.dilatation_scale", m.dilatation_scale);
  f(K::particle, "model.a4", m.a4);
  f(K::particle, "model.b4", m.b4);
  f(K::particle, "model.beta", m.beta);
  f(K::particle, "model.damping", m.damping);
  f(K::particle, "model.yield_extension", m.yield_extension);
  f(K::particle, "model.plastic_cap", m.plastic_cap);
  f(K::particle, "model.critical_stretch", m.critical_stretch);
  f(K::particle, "model.damage_alpha", m.damage_alpha);
  f(K::particle, "model.reference_point", m.reference_point);
  auto& s = w.state;
  f(K::particle, "state.dilatation", s.dilatation);
  f(K::particle, "state.dilatation_coupling", s.dilatation_coupling);
  f(K::particle, "state.damage", s.damage);
  f(K::particle, "state.break_extension", s.break_extension);
  f(K::particle, "state.internal_force", s.internal_force);
  f(K::particle, "state.external_force", s.external_force);
  f(K::particle, "state.contact_force", s.contact_force);
  f(K::particle, "state.broken_bonds", s.broken_bonds);
  f(K::particle, "state.bond_end", s.bond_end);
  f(K::particle, "state.surface_frame", s.surface_frame);
  f(K::particle, "state.open_faces", s.open_faces);
  f(K::particle, "state.collider_contact", s.collider_contact);
  auto& b = w.bonds;
  f(K::particle, "bonds.offsets", b.offsets);
  f(K::particle, "bonds.initial_count", b.initial_count);
  f(K::bond, "bonds.neighbor", b.neighbor);
  f(K::bond, "bonds.alive", b.alive);
  f(K::bond, "bonds.break_scale", b.break_scale);
  f(K::bond, "bonds.plastic_extension", b.plastic_extension);
  f(K::bond, "bonds.plastic_extension_mirror", b.plastic_extension_mirror);
  f(K::mesh, "mesh.vertices", w.mesh.vertices);
  f(K::mesh, "mesh.tets", w.mesh.tets);
  auto& e = w.embedded;
  f(K::mesh, "embedded.reference_vertices", e.reference_vertices);
  f(K::mesh, "embedded.vertices", e.vertices);
  f(K::mesh, "embedded.vertex_velocity", e.vertex_velocity);
  f(K::mesh, "embedded.origin", e.origin);
  f(K::mesh, "embedded.split_copy", e.split_copy);
  f(K::mesh, "embedded.weight_rows", e.weight_rows);
  f(K::mesh, "embedded.weight_particle", e.weight_particle);
  f(K::mesh, "embedded.weight_value", e.weight_value);
  f(K::mesh, "embedded.deformation", e.deformation);
  f(K::mesh, "embedded.deformation_rate", e.deformation_rate);
  f(K::mesh, "embedded.deformation_fitted", e.deformation_fitted);
  f(K::mesh, "embedded.deformation_origin", e.deformation_origin);
  f(K::mesh, "embedded.deformation_origin_velocity", e.deformation_origin_velocity);
  f(K::mesh, "embedded.vertex_anchored", e.vertex_anchored);
  f(K::mesh, "embedded.held_deformation", e.held_deformation);
  f(K::mesh, "embedded.held_tracked", e.held_tracked);
  f(K::mesh, "embedded.held_fits", e.held_fits);
  f(K::mesh, "embedded.held_broken_seen", e.held_broken_seen);
  f(K::mesh, "embedded.tets", e.tets);
  f(K::mesh, "embedded.neighbors", e.neighbors);
  f(K::mesh, "embedded.face_pair", e.face_pair);
  f(K::mesh, "embedded.pair_tets", e.pair_tets);
  f(K::mesh, "embedded.pair_local", e.pair_local);
  f(K::mesh, "embedded.pair_bond", e.pair_bond);
  f(K::mesh, "embedded.pair_state", e.pair_state);
  f(K::mesh, "embedded.watched_pairs", e.watched_pairs);
  f(K::mesh, "embedded.pending", e.pending);
  f(K::mesh, "embedded.fresh", e.fresh);
  f(K::mesh, "embedded.incidence_offsets", e.incidence_offsets);
  f(K::mesh, "embedded.incidence", e.incidence);
  auto& fem = w.fem;
  f(K::mesh, "fem.dm_inverse", fem.dm_inverse);
  f(K::mesh, "fem.volume", fem.volume);
  f(K::mesh, "fem.lame_lambda", fem.lame_lambda);
  f(K::mesh, "fem.lame_mu", fem.lame_mu);
  f(K::mesh, "fem.vertex_offsets", fem.vertex_offsets);
  f(K::mesh, "fem.vertex_corners", fem.vertex_corners);
  f(K::mesh, "fem.corner_force", fem.corner_force);
  auto& c = w.contact;
  f(K::contact, "contact.size", c.size);
  f(K::contact, "contact.grid.cell_of", c.grid.cell_of);
  f(K::contact, "contact.grid.sorted_key", c.grid.sorted_key);
  f(K::contact, "contact.grid.bucket", c.grid.bucket);
  f(K::contact, "contact.grid.start", c.grid.start);
  f(K::contact, "contact.grid.cursor", c.grid.cursor);
  f(K::contact, "contact.grid.sorted", c.grid.sorted);
  f(K::contact, "contact.grid.sorted_position", c.grid.sorted_position);
  f(K::contact, "contact.search_grid.cell_of", c.search_grid.cell_of);
  f(K::contact, "contact.search_grid.sorted_key", c.search_grid.sorted_key);
  f(K::contact, "contact.search_grid.bucket", c.search_grid.bucket);
  f(K::contact, "contact.search_grid.start", c.search_grid.start);
  f(K::contact, "contact.search_grid.cursor", c.search_grid.cursor);
  f(K::contact, "contact.search_grid.sorted", c.search_grid.sorted);
  f(K::contact, "contact.search_grid.sorted_position", c.search_grid.sorted_position);
  f(K::contact, "contact.displaced_grid.cell_of", c.displaced_grid.cell_of);
  f(K::contact, "contact.displaced_grid.sorted_key", c.displaced_grid.sorted_key);
  f(K::contact, "contact.displaced_grid.bucket", c.displaced_grid.bucket);
  f(K::contact, "contact.displaced_grid.start", c.displaced_grid.start);
  f(K::contact, "contact.displaced_grid.cursor", c.displaced_grid.cursor);
  f(K::contact, "contact.displaced_grid.sorted", c.displaced_grid.sorted);
  f(K::contact, "contact.displaced_grid.sorted_position", c.displaced_grid.sorted_position);
  f(K::contact, "contact.pairs.offsets", c.pairs.offsets);
  f(K::contact, "contact.pairs.neighbor", c.pairs.neighbor);
  f(K::contact, "contact.pairs.length", c.pairs.length);
  f(K::contact, "contact.pairs.near_count", c.pairs.near_count);
  f(K::contact, "contact.pairs.count", c.pairs.count);
  f(K::contact, "contact.pairs.scratch", c.pairs.scratch);
  f(K::contact, "contact.pairs.offsets_next", c.pairs.offsets_next);
  f(K::contact, "contact.pairs.neighbor_next", c.pairs.neighbor_next);
  f(K::contact, "contact.pairs.built_position", c.pairs.built_position);
  f(K::contact, "contact.pairs.bonded_stamp", c.pairs.bonded_stamp);
  f(K::contact, "contact.pairs.alive_at_build", c.pairs.alive_at_build);
  f(K::contact, "contact.pairs.moved", c.pairs.moved);
  f(K::contact, "contact.pairs.partner_moved", c.pairs.partner_moved);
  f(K::contact, "contact.pairs.resort", c.pairs.resort);
  f(K::contact, "contact.pairs.moved_list", c.pairs.moved_list);
  f(K::contact, "contact.pairs.moved_offsets", c.pairs.moved_offsets);
  f(K::contact, "contact.pairs.moved_neighbor", c.pairs.moved_neighbor);
  f(K::contact, "contact.pairs.found_by", c.pairs.found_by);
  f(K::contact, "contact.pairs.displaced", c.pairs.displaced);
  f(K::contact, "contact.pairs.displaced_list", c.pairs.displaced_list);
  f(K::contact, "contact.pairs.broken_seen", c.pairs.broken_seen);
  f(K::other, "projectiles.bodies", w.projectiles.bodies);
  for (auto& block : w.projectiles.block_contacts) f(K::other, "projectiles.block_contacts", block);
  f(K::other, "projectiles.contacts", w.projectiles.contacts);
  f(K::other, "global_index", w.global_index);
  f(K::other, "boundary.constrained", w.boundary.constrained);
  for (auto& list : w.boundary.particles) f(K::other, "boundary.particles", list);
  f(K::other, "surface.offsets", w.surface.offsets);
  f(K::other, "surface.area", w.surface.area);
  f(K::other, "surface.normal", w.surface.normal);
  f(K::other, "surface.offset", w.surface.offset);
  f(K::other, "surface.radius", w.surface.radius);
  f(K::other, "surface.corner", w.surface.corner);
  f(K::particle, "openable_faces.corner", w.openable_faces.corner);
  f(K::particle, "openable_faces.bond_slot", w.openable_faces.bond_slot);
  for (auto& list : w.loads.particles) f(K::other, "loads.particles", list);
  for (auto& list : w.loads.patch_offsets) f(K::other, "loads.patch_offsets", list);
  for (auto& list : w.loads.patches) f(K::other, "loads.patches", list);
  f(K::other, "derived.displacement", w.derived.displacement);
  f(K::other, "derived.plastic_strain", w.derived.plastic_strain);
  f(K::other, "derived.alive_bonds", w.derived.alive_bonds);
  f(K::other, "derived.fragment_id", w.derived.fragment_id);
  f(K::other, "derived.fragment_root", w.derived.fragment_root);
  f(K::other, "derived.fragment_size", w.derived.fragment_size);
  f(K::other, "derived.fragment_keep", w.derived.fragment_keep);
}

}  // namespace perifx
