// Turns a typed scene into a ready WorldState. The work is split by job:
//   bodies.cpp            meshes every body, places particles (one per tet, Morton order), sizes state
//   regions.cpp           boundary-condition regions → particle index lists
//   loads.cpp             boundary patches of the mesh; each load's particles and patches
//   world_setup.cpp       resolves the scene's settings, then families, initial cracks, the embedded
//                         mesh, model constants and the initial acceleration (the setup systems)
//   stable_time_step.cpp  the largest stable explicit step (Spectra)
// The step's systems themselves are listed in systems/pipeline.cpp.
#pragma once
#include <memory>
#include <vector>

#include "components/world_state.hpp"
#include "perifx/scene.hpp"
#include "scheduler.hpp"

namespace perifx::setup {

// Wall time of one setup phase (World::setup_times, `perifx run --profile`).
struct PhaseTime {
  const char* name;
  double seconds;
};

// The whole world for `scene`; setup work runs in the scheduler's arena. Appends the wall time of
// each phase to `times` when given. `shell`: for a rank other than 0 of a distributed run, which
// receives its part from rank 0 (World::split): the settings, flags, bodies' names, boundary-condition
// and load definitions and contact settings that make a local world's non-array parts, the same as the
// whole world's, and no arrays; no body is meshed. What needs the meshes (the bodies' measures, the
// instability bound, the contact reach) it takes from rank 0 (distributed/local_world.hpp,
// take_world_frame). A scene whose step is "auto" gets it here (80 % of estimate_stable_time_step,
// fitted to the frame interval); `stable_time_step`, when given, then receives that estimate.
std::unique_ptr<WorldState> build_world_state(const scene::Scene& scene, Scheduler& scheduler,
                                              std::vector<PhaseTime>* times = nullptr, bool shell = false,
                                              double* stable_time_step = nullptr);
// Throws SceneError (/model/solver) when the scene asks an FEM solver for what only the peridynamic one
// does (yield, fracture, initial cracks); build_world_state calls it first.
void check_solver(const scene::Scene& scene);
// Frees every array for_each_array lists (a shell; a distributed run's other ranks after a split).
void release_arrays(WorldState& w);
// Frees the contact grids and pair list (every ArrayKind::contact array but the per-particle sizes) and
// marks the list unbuilt: a distributed run's rank 0 keeps the whole world for output, checkpoints and
// re-splits, but steps only its local world, whose contact buffers are its own. World::load_checkpoint
// allocates them again when one process resumes such a whole world's checkpoint.
void release_contact_buffers(WorldState& w);

// bodies.cpp: bodies, particles and their mesh (appends to w.particles, w.mesh, w.bodies, w.model.horizon).
void add_bodies(const scene::Scene& scene, WorldState& w);
// bodies.cpp: body `index`'s tet mesh, transformed and in Morton order, checked (finite coordinates
// within kMaxCoordinate, positive volumes). Throws SceneError naming /bodies/<index>/geometry.
TetMesh placed_mesh(const scene::Scene& scene, std::size_t index);
// bodies.cpp: per-particle step state (forces, dilatation, damage ...) sized to the particle count.
void allocate_step_state(WorldState& w);
// regions.cpp: w.boundary from the scene's boundary conditions.
void resolve_boundary_conditions(const std::vector<scene::BoundaryCondition>& conditions, WorldState& w);

// loads.cpp: w.surface (boundary patches of the reference mesh) and w.loads from the scene's loads.
// face_neighbors: geometry::face_neighbors of w.mesh (the boundary faces are those without one).
void resolve_loads(const std::vector<scene::Load>& loads, const std::vector<std::array<std::int32_t, 4>>& face_neighbors,
                   WorldState& w);

// loads.cpp: w.openable_faces (the tet faces a crack may open, which the colliders meet) in a
// peridynamic world with colliders and a breakable material; empty otherwise. After the bonds are
// final (initial cracks removed).
void resolve_openable_faces(const std::vector<std::array<std::int32_t, 4>>& face_neighbors, WorldState& w);

// stable_time_step.cpp: largest stable velocity-Verlet step 2/ω_max, ω_max² the largest eigenvalue
// of M⁻¹K for the linearized elastic force at the reference configuration.
double estimate_stable_time_step(const WorldState& world);
// world_setup.cpp: whether a material can yield (a finite yield energy or a positive, finite yield
// stress): the world then keeps e^p per bond (WorldState::any_plastic, the preflight's bytes per bond).
bool can_yield(const scene::Material& material);

// stable_time_step.cpp: a lower bound on that step from one pass over the bonds (peridynamics; 0 for
// the FEM solver, which has none): a time step at or below it is stable without the estimate.
double stable_time_step_bound(const WorldState& world);

}  // namespace perifx::setup
