// Everything a world owns, as plain data. Systems get references to the parts they declare; the
// World class (public API) wraps one of these. No globals: two WorldStates never share anything.
// The scene itself is not kept here: what the step needs from it is resolved into StepSettings (and
// the other components) when the world is built (engine/setup/), so systems never read raw scene
// input. The plain scene value types (materials, colliders, regions ...) come from the public
// vocabulary header perifx/scene.hpp.
#pragma once
#include <cstdint>
#include <vector>

#include "components/bonds.hpp"
#include "components/contact.hpp"
#include "components/embedded_mesh.hpp"
#include "components/fem.hpp"
#include "components/particles.hpp"
#include "components/tet_mesh.hpp"
#include "perifx/scene.hpp"  // value types only (Material, Collider, BoundaryCondition ...)

namespace perifx {

// Time of the step being computed. Systems read it; only the clock advances it (World::step).
struct Clock {
  double time = 0.0;         // s, at the start of the current step
  double dt = 1e-4;          // s
  std::uint64_t step = 0;    // steps completed
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
  std::vector<std::uint32_t> fragment_id;  // connected component of alive bonds (smallest particle index)
  std::size_t fragment_count = 0;
};

// The scene's settings the step reads, resolved once when the world is built.
struct StepSettings {
  Vec3 gravity = Vec3::Zero();                       // m/s²
  scene::Normalization normalization = scene::Normalization::paper;
  scene::FamilyRule family = scene::FamilyRule::mesh;
  scene::Solver solver = scene::Solver::peridynamics;
  std::vector<scene::Material> materials;            // indexed by Particles::material_id
  std::vector<scene::Collider> colliders;            // kinematic colliders (systems/colliders.cpp)
  scene::Contact contact;                            // particle contact settings (systems/contact.cpp)
  std::vector<scene::Projectile> projectiles;        // initial projectiles (systems/projectiles.cpp)
  int threads = 0;                                   // worker threads of the world's arena (0 = all)
  // The embedded mesh's vertices follow the particles every step (systems/mesh_vertices.cpp) when
  // the scene writes the split mesh (obj, surface_ply, tets_vtu) or can break.
  bool mesh_output = false;
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
  DerivedFields derived;
  ContactState contact;           // particle–particle contact (systems/contact.cpp)
  ProjectileSet projectiles;      // rigid projectiles (systems/projectiles.cpp)
  bool any_plastic = false;       // some material has a finite yield energy
  bool any_anisotropic = false;   // some material has G ≠ I
  bool any_fracture = false;      // some material has a finite critical stretch
};

// Where an array's bytes are counted in memory reports (World::memory, `perifx info`).
enum class ArrayKind : std::uint8_t { particle, bond, mesh, contact, other };

// Calls f(kind, name, vector) for every array the world owns: the one list memory accounting reads
// (tests/engine/test_world.cpp checks it against the bytes the heap actually holds, so an array left
// out of it fails a test). Reflection only; no behaviour.
template <class F>
void for_each_array(const WorldState& w, F&& f) {
  using K = ArrayKind;
  const auto& p = w.particles;
  for (auto* a : {&p.reference_position, &p.position, &p.velocity, &p.acceleration}) f(K::particle, "particles", *a);
  f(K::particle, "particles.volume", p.volume);
  f(K::particle, "particles.mass", p.mass);
  f(K::particle, "particles.material_id", p.material_id);
  f(K::particle, "particles.body_id", p.body_id);
  f(K::particle, "particles.flags", p.flags);
  const auto& m = w.model;
  for (auto* a : {&m.horizon, &m.dilatation_scale, &m.a4, &m.b4, &m.beta, &m.damping, &m.yield_extension,
                  &m.plastic_cap, &m.critical_stretch, &m.damage_alpha})
    f(K::particle, "model", *a);
  const auto& s = w.state;
  for (auto* a : {&s.dilatation, &s.dilatation_coupling, &s.damage, &s.break_extension}) f(K::particle, "state", *a);
  for (auto* a : {&s.internal_force, &s.external_force, &s.contact_force}) f(K::particle, "state.force", *a);
  f(K::particle, "state.broken_bonds", s.broken_bonds);
  f(K::particle, "state.bond_end", s.bond_end);
  const auto& b = w.bonds;
  f(K::particle, "bonds.offsets", b.offsets);
  f(K::particle, "bonds.initial_count", b.initial_count);
  f(K::bond, "bonds.neighbor", b.neighbor);
  f(K::bond, "bonds.reverse", b.reverse);
  f(K::bond, "bonds.reference_length", b.reference_length);
  f(K::bond, "bonds.weight", b.weight);
  f(K::bond, "bonds.alive", b.alive);
  f(K::bond, "bonds.plastic_extension", b.plastic_extension);
  f(K::bond, "bonds.plastic_extension_mirror", b.plastic_extension_mirror);
  f(K::mesh, "mesh.vertices", w.mesh.vertices);
  f(K::mesh, "mesh.tets", w.mesh.tets);
  const auto& e = w.embedded;
  for (auto* a : {&e.reference_vertices, &e.vertices, &e.vertex_velocity}) f(K::mesh, "embedded.vertices", *a);
  f(K::mesh, "embedded.origin", e.origin);
  f(K::mesh, "embedded.split_copy", e.split_copy);
  f(K::mesh, "embedded.weight_rows", e.weight_rows);
  f(K::mesh, "embedded.weight_particle", e.weight_particle);
  f(K::mesh, "embedded.weight_value", e.weight_value);
  f(K::mesh, "embedded.tets", e.tets);
  f(K::mesh, "embedded.neighbors", e.neighbors);
  f(K::mesh, "embedded.face_pair", e.face_pair);
  f(K::mesh, "embedded.pair_tets", e.pair_tets);
  f(K::mesh, "embedded.pair_local", e.pair_local);
  f(K::mesh, "embedded.pair_bond", e.pair_bond);
  f(K::mesh, "embedded.pair_state", e.pair_state);
  for (auto* a : {&e.watched_pairs, &e.pending, &e.fresh, &e.incidence_offsets, &e.incidence})
    f(K::mesh, "embedded.lists", *a);
  const auto& fem = w.fem;
  f(K::mesh, "fem.dm_inverse", fem.dm_inverse);
  for (auto* a : {&fem.volume, &fem.lame_lambda, &fem.lame_mu}) f(K::mesh, "fem.tet", *a);
  f(K::mesh, "fem.vertex_offsets", fem.vertex_offsets);
  f(K::mesh, "fem.vertex_corners", fem.vertex_corners);
  f(K::mesh, "fem.corner_force", fem.corner_force);
  const auto& c = w.contact;
  f(K::contact, "contact.size", c.size);
  f(K::contact, "contact.grid.cell_of", c.grid.cell_of);
  f(K::contact, "contact.grid.sorted_key", c.grid.sorted_key);
  for (auto* a : {&c.grid.bucket, &c.grid.start, &c.grid.cursor, &c.grid.sorted}) f(K::contact, "contact.grid", *a);
  f(K::contact, "contact.grid.sorted_position", c.grid.sorted_position);
  for (auto* a : {&c.pairs.offsets, &c.pairs.neighbor, &c.pairs.count, &c.pairs.scratch, &c.pairs.offsets_next,
                  &c.pairs.neighbor_next})
    f(K::contact, "contact.pairs", *a);
  f(K::contact, "contact.pairs.built_position", c.pairs.built_position);
  f(K::contact, "contact.pairs.bonded_stamp", c.pairs.bonded_stamp);
  f(K::contact, "contact.pairs.alive_at_build", c.pairs.alive_at_build);
  f(K::other, "projectiles.bodies", w.projectiles.bodies);
  f(K::other, "projectiles.particle_force", w.projectiles.particle_force);
  f(K::other, "projectiles.torque", w.projectiles.torque);
  f(K::other, "boundary.constrained", w.boundary.constrained);
  for (const auto& list : w.boundary.particles) f(K::other, "boundary.particles", list);
  f(K::other, "derived.displacement", w.derived.displacement);
  f(K::other, "derived.plastic_strain", w.derived.plastic_strain);
  for (auto* a : {&w.derived.alive_bonds, &w.derived.fragment_id}) f(K::other, "derived", *a);
}

}  // namespace perifx
