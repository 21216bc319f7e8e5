// Everything a world owns, as plain data. Systems get references to the parts they declare; the
// World class (public API) wraps one of these. No globals: two WorldStates never share anything.
#pragma once
#include <cstdint>
#include <vector>

#include "components/bonds.hpp"
#include "components/contact.hpp"
#include "components/embedded_mesh.hpp"
#include "components/fem.hpp"
#include "components/particles.hpp"
#include "components/tet_mesh.hpp"
#include "scene/scene.hpp"

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

struct WorldState {
  scene::Scene scene;
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

}  // namespace perifx
