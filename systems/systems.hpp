// Every system of perifx and the kernels they wrap. One .cpp per system; each file's header comment
// names the paper's equations it implements (systems/README.md) and the components it reads and
// writes. The step's systems and their order are listed once, in pipeline.cpp.
// The separate systems (plasticity, elastic_force, fracture, damage) are the test oracle for bond_pass
// (same bits; tests/systems/test_fracture.cpp); the step itself does not use them.
#pragma once
#include <functional>
#include <vector>

#include "components/world_state.hpp"
#include "system.hpp"

namespace perifx::systems {

// Calls f(t, s) for every tet t that currently holds embedded-mesh vertex v, in tet order, s being v's
// slot in t: the entries of the incidence of v's original (EmbeddedMesh::origin) whose slot still
// names v after splitting (a copy's group is the part of its original's incidence it took).
template <class F>
void for_each_holding_tet(const EmbeddedMesh& e, std::uint32_t v, F&& f) {
  const std::uint32_t o = e.origin[v];
  for (std::uint32_t q = e.incidence_offsets[o]; q < e.incidence_offsets[o + 1]; ++q) {
    const std::uint32_t t = e.incidence[q] / 4, s = e.incidence[q] % 4;
    if (e.tets[t][s] == v) f(t, s);
  }
}

// ---- setup (run once, not part of the step graph) ----
// family_build.cpp: families and bond data from reference positions, horizons and, for the mesh
// rule, the face adjacency of the embedded tet mesh (paper §5.2, systems/README.md §6.2).
void build_families(WorldState& world, const std::vector<std::array<std::int32_t, 4>>& tet_face_neighbors);
// initial_cracks.cpp: removes the bonds whose reference segment crosses a crack polygon (both
// directions); returns the number of directed bonds removed.
std::size_t remove_cracked_bonds(WorldState& world, const std::vector<scene::Crack>& cracks);
// model_constants.cpp: ParticleModel::reference_point from particles.reference_position and volume
// (set-up, once the particles are placed and ordered; the bond kernels gather it) ...
void pack_reference_points(WorldState& world);
// ... and per-particle a, b, θ scale and β for the paper or discrete normalization.
void compute_model_constants(WorldState& world);
// ParticleModel::anisotropic_family from the materials and the bonds (after build_families).
void mark_anisotropic_families(WorldState& world);
// Physical parameters → model values (systems/README.md §12): s_c for a fracture energy G_c (J/m²)
// at horizon δ, and the yield extension Y for a yield stress σ_y (Pa). ∞ in gives ∞ out.
// The continuum relation G = K δ s_c² under-counts what a running crack dissipates by a factor
// that the notched-bar measurement fixes (§12.1); s_c = √(G_c / (kFractureEnergyFactor · K δ)).
inline constexpr double kFractureEnergyFactor = 1.675;
double critical_stretch_from_energy(double fracture_energy, double kappa, double mu, double horizon);
double yield_extension_from_stress(double yield_stress, double mu);
// Spatially varying strength (strength_field.cpp): scales model.critical_stretch per particle and fills
// bonds.break_scale; after compute_model_constants, before compute_fracture_thresholds.
void apply_strength_field(WorldState& world);
double strength_noise(const Vec3& x, double feature_size, std::uint64_t seed);  // in [−1, 1]
// contact.cpp / projectiles.cpp: resolve the scene's contact settings and projectiles, size buffers.
// A distributed run's local world passes the whole world's largest contact distance (its pair
// list's reach and skin must be the whole world's); 0: this world's own.
void setup_contact(WorldState& world, double largest_distance = 0.0);
// Its settings, particle sizes and reach only, without the pair list's buffers (a distributed run's
// shell world, engine/setup/world_setup.hpp).
void resolve_contact(WorldState& world, double largest_distance = 0.0);
// Whether particle–particle contact runs in this world (the scene's contact/enabled, or automatic: at
// least two bodies or a breakable material); resolve_contact sets ContactState::enabled from it.
bool contact_runs(const WorldState& world);
void setup_projectiles(WorldState& world);
// A distributed run's contact-ghost refresh replaced the particles from `kept` on (engine/distributed/
// local_world.cpp): keeps the pair list's pairs among the first `kept` particles, drops those with the
// others, sizes the buffers for the new count and has the next step search the new particles (an
// update of the list, not a full rebuild); the settings and largest distance stay.
void replace_contact_tail(WorldState& world, std::size_t kept);
void resize_projectiles(WorldState& world);
// embedded_mesh.cpp: WorldState::embedded from WorldState::mesh, its face adjacency and the bonds
// (after initial cracks: face pairs without a bond start as crack faces). Run after the bonds exist.
void setup_embedded_mesh(WorldState& world, const std::vector<std::array<std::int32_t, 4>>& tet_face_neighbors);
// Embedding weights of vertex v over the particles of its tet group (grown by rings when degenerate).
void embed_vertex(WorldState& world, std::uint32_t v, const std::vector<std::uint32_t>& group);
// The weights of every vertex, over its current tet group, when they are not there yet: only
// VertexMotion::embedded reads them, so they are built on its first update (mesh_vertices.cpp)
// and kept current by mesh_split from then on.
void ensure_vertex_weights(WorldState& world);

// ---- kernels (also used by the stability estimate and the tests) ----
// θ_i (Eq 6) and P_i for positions y; theta and coupling sized particle count.
void compute_dilatation(const WorldState& world, const std::vector<Vec3>& y, std::vector<double>& theta,
                        std::vector<double>& coupling);
// Internal force on every particle (Eq 2–4, 8–10/12, paired as in systems/README.md §2.1), N.
void compute_internal_force(const WorldState& world, const std::vector<Vec3>& y,
                            const std::vector<double>& coupling, std::vector<Vec3>& force);
// Virial stress per particle from its own force state (the state-based stress σ = ∫ T⟨ξ⟩ ⊗ ξ dV):
// σ_i = ½ Σ_j A_ij n_ij ⊗ ξ_ij V_j, Pa. (Using the paired ½(A_ij + A_ji) instead would mix in the
// neighbours' constants, which differ between the lattice's tet types.)
// Elastic energy of the current state (J); FEM mode: the FEM energy.
double elastic_energy(const WorldState& world);
void compute_virial_stress(const WorldState& world, const std::vector<Vec3>& y,
                           const std::vector<double>& coupling, std::vector<Mat3>& stress);
// external_loads.cpp: gravity plus the scene's loads at time t, as the mean force over [a, b] (the
// time this force stands for in velocity Verlet), into world.state.external_force.
void compute_external_force(WorldState& world, double t, double a, double b);
// plasticity.cpp: Eq 11–16 consistent return, in place on bonds.plastic_extension (and its mirror
// copy), for positions y and the dilatations in world.state.
void update_plastic_extension(WorldState& world, const std::vector<Vec3>& y);
// fracture.cpp: the symmetric break predicate of the physical bond containing directed bond k of
// particle `owner` (Eq 18–19, systems/README.md §5), and the pass that applies it to every alive bond.
bool bond_breaks(const WorldState& world, const std::vector<Vec3>& y, std::uint32_t owner, std::uint32_t k);
void update_fracture(WorldState& world, const std::vector<Vec3>& y);
// damage.cpp: φ and broken_bonds per particle from the bonds; fracture thresholds
// (1 + αφ) s_c per particle from the damage.
void compute_damage(WorldState& world);
void compute_fracture_thresholds(WorldState& world);
// bond_pass.cpp: plasticity, elastic force, fracture test and damage fused in one pass over the bonds
// (same bits as the separate kernels); force for positions y.
void run_bond_pass(WorldState& world, const std::vector<Vec3>& y, std::vector<Vec3>& force);
// fragments.cpp: connected components of alive bonds; id = smallest particle index in the
// component. Returns the number of components.
std::size_t compute_fragments(const WorldState& world, std::vector<std::uint32_t>& fragment_id);
// Stable piece ids in world.derived.fragment_id (fragments.cpp); returns the piece count.
std::size_t update_piece_ids(WorldState& world);
// Embedded mesh (§5.2; crack_faces.cpp, mesh_split.cpp, mesh_vertices.cpp, mesh_surface.cpp):
// new crack faces from broken face-pair bonds (returns how many); vertex splitting of the fresh
// crack faces (returns copies made); vertex motion (Eq 20–22, or the embedding); boundary triangles.
std::size_t collect_crack_faces(WorldState& world);
std::size_t split_mesh_vertices(WorldState& world);
void update_mesh_vertices(WorldState& world, double dt);
// Set-up of the vertex motion (mesh_vertices.cpp): the embedding weights' users and Eq 20–22 start
// from a first update; the default (deformation) motion only needs its held rotations and arrays,
// since at set-up y = x and the vertices already sit at their reference places.
void start_mesh_vertices(WorldState& world);
// mesh_rotations.cpp: the held rotations of particles whose family does not fit (step state of
// VertexMotion::deformation); init at setup, update every step. family_fits: ≥ 4 alive bonds and K
// well conditioned; deformation_conditioned: det F > 0 and ‖F‖², ‖F⁻¹‖² ≤ 12.
void init_held_rotations(WorldState& world);
void update_held_rotations(WorldState& world);
bool family_fits(const Mat3& K, std::uint32_t alive);
bool deformation_conditioned(const Mat3& F);
// The first moments of a family (ω V weights): Σ ω V_j, Σ ω V_j ξ, Σ ω V_j η, Σ ω V_j (v_j − v_p).
struct FamilyMoments {
  double weight = 0.0;
  Vec3 xi = Vec3::Zero(), eta = Vec3::Zero(), velocity = Vec3::Zero();
};
// An affine fit of a family's motion, η ≈ offset + gradient ξ.
struct FamilyFit {
  Vec3 offset;
  Mat3 gradient;
};
// Residual scale s of the reweighted family sums: a bond whose end lies |ξ|/4 off a prior fit weighs
// half. A bond that far off holds a strain error of a quarter against its family's motion: a
// neighbour hanging on by a stretched bond, or jostled at an impact (mesh_vertices.cpp).
inline constexpr double robust_residual_scale = 0.25;
// K = Σ ω ξ⊗ξ V_j and N = Σ ω η⊗ξ V_j over p's bonds (alive ones only, or all), and with `rate` also
// Ṅ = Σ ω (v_j − v_p)⊗ξ V_j (F = N K⁻¹, Ḟ = Ṅ K⁻¹ when family_fits) and, when given, the first
// moments; with `rate` and `prior` every weight ω V is multiplied by s²|ξ|² / (s²|ξ|² + |η − c − F ξ|²)
// (c, F the prior fit, s = robust_residual_scale). Returns the number of bonds summed. Lane-strided
// SIMD sums in a fixed order (mesh_rotations.cpp).
std::uint32_t family_sums(const WorldState& w, std::size_t p, bool alive_only, Mat3& K, Mat3& N,
                          Mat3* rate = nullptr, FamilyMoments* moments = nullptr, const FamilyFit* prior = nullptr);
// F = N K⁻¹ when the family fits, replaced by its rotation when badly stretched or inverted; false
// (F untouched) when the family does not fit. The held rotations and the surface frames use it.
bool fitted_deformation(const Mat3& K, const Mat3& N, std::uint32_t alive, Mat3& F);
// surface_frames.cpp: the deformation of each particle whose boundary faces may reach a collider in the
// next step (ParticleState::surface_frame); at set-up, at the end of every step (surface_frame_system).
void update_surface_frames(WorldState& world);
bool face_pair_shared(const EmbeddedMesh& mesh, std::uint32_t pair);
void extract_surface(const WorldState& world, const std::vector<std::uint32_t>* fragment_id, SurfaceMesh& out,
                     std::uint32_t min_piece_tets = 0);
// Tets (= particles) per piece id, indexed by id (mesh_surface.cpp): the one count that decides which
// pieces are dust (fewer than min_piece_tets), for the surface and for the dust points.
std::vector<std::uint32_t> piece_tet_counts(const std::vector<std::uint32_t>& fragment_id);
// Particles of the pieces with fewer than min_piece_tets tets, in increasing order (none when 0).
std::vector<std::uint32_t> dust_particles(const std::vector<std::uint32_t>& fragment_id, std::uint32_t min_piece_tets);
// crack_smoothing.cpp: Laplacian smoothing (2 steps per iteration) of the crack surface's reference
// positions (output only);
// iterations 0 restores the unsmoothed positions. Returns the original vertices moved.
std::size_t smooth_crack_faces(WorldState& world, int iterations);
// fem_setup.cpp / fem_force.cpp: the FEM reference solver (components/fem.hpp), particles = vertices.
void setup_fem(WorldState& world);
void compute_fem_force(const WorldState& world, const std::vector<Vec3>& y, std::vector<Vec3>& corner_scratch,
                       std::vector<Vec3>& force);
double fem_elastic_energy(const WorldState& world, const std::vector<Vec3>& y);
Mat3 polar_rotation(const Mat3& F);  // rotation factor R of F = R S, det R = +1
// I⁻¹ L (rad/s) for a set of particles' inertia I = Σ m (|r|² 1 − r rᵀ) and angular momentum
// L = Σ m r × (v − v̄) about their centre, leaving out directions with (nearly) no inertia (a rod or a
// single particle cannot tell its spin about its own axis): 0 where I vanishes.
Vec3 angular_velocity(const Mat3& inertia, const Vec3& momentum);

// ---- per-step systems ----
SystemDecl kick_begin_system(WorldState& world);
SystemDecl boundary_condition_system(WorldState& world);
SystemDecl drift_system(WorldState& world);
SystemDecl collider_system(WorldState& world);
// How far particle i may be from its position now after the next step, at most (m): its own drift D
// (dt|v| + dt²|a|/2, the caller's) plus what the colliders' push-out may add to it (colliders.cpp, from
// the rule that moves a particle out: the depth the drift made, and earlier depth at no more than
// kDepenetrationSpeed). The MPI contact-ghost refresh test (engine/distributed) looks ahead with it.
double collider_lookahead(const WorldState& world, std::size_t i, double drift);
SystemDecl surface_frame_system(WorldState& world);
SystemDecl dilatation_system(WorldState& world);
SystemDecl elastic_force_system(WorldState& world);  // test oracle for bond_pass
SystemDecl external_load_system(WorldState& world);
SystemDecl kick_end_system(WorldState& world);
SystemDecl contact_system(WorldState& world);
SystemDecl projectile_drift_system(WorldState& world);
// `gather`, when set (a distributed run), turns this rank's list of projectile contacts
// (ProjectileSet::contacts) into every rank's, in rank order, before the projectiles sum it.
SystemDecl projectile_contact_system(WorldState& world,
                                     const std::function<void(std::vector<double>&)>* gather = nullptr);
SystemDecl plasticity_system(WorldState& world);  // test oracle for bond_pass
SystemDecl fracture_system(WorldState& world);  // test oracle for bond_pass
SystemDecl damage_system(WorldState& world);  // test oracle for bond_pass
SystemDecl fracture_threshold_system(WorldState& world);
SystemDecl bond_pass_system(WorldState& world);  // fused plasticity + elastic_force + fracture + damage
SystemDecl crack_face_system(WorldState& world);
SystemDecl mesh_split_system(WorldState& world);
SystemDecl mesh_vertex_system(WorldState& world);
SystemDecl mesh_rotation_system(WorldState& world);
SystemDecl fem_force_system(WorldState& world);  // FEM mode: replaces dilatation + elastic_force

}  // namespace perifx::systems
