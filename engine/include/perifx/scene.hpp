// perifx public API: the typed scene: what a validated scene JSON turns into. Everything downstream of the scene loader
// reads these structs, never raw JSON. All quantities SI (m, kg, s, Pa).
// The JSON format, with every key's type, default, range and meaning, is generated from the spec in
// schema.cpp (`perifx spec` prints it; docs copy: assets/scenes/FORMAT.md).
#pragma once
#include <array>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "perifx/errors.hpp"
#include "perifx/math.hpp"

namespace perifx::scene {

enum class Normalization { paper, discrete, corrected };  // systems/README.md §2.4: paper constants, per-particle discrete sums, or discrete with a surface correction
enum class FamilyRule { mesh, distance };  // systems/README.md §6.2: distance + face-connectivity, or distance only
// peridynamics: the paper's model (particles at tet barycenters). fem_*: reference FEM on the same
// tet mesh, particles at the mesh vertices (components/fem.hpp).
enum class Solver { peridynamics, fem_linear, fem_corotated };

// A region of particles, tested on reference positions (after the body transform).
struct Region {
  enum class Kind { all, box, sphere, halfspace };
  Kind kind = Kind::all;
  Vec3 min = Vec3::Zero(), max = Vec3::Zero();   // box
  Vec3 center = Vec3::Zero();                    // sphere
  double radius = 0.0;                           // sphere
  Vec3 point = Vec3::Zero(), normal = Vec3::UnitY();  // halfspace: particles with (x − point)·normal ≥ 0
  int body = -1;                                 // restrict to one body (index), −1 = any body
};

// Spatially varying strength of a material (issue 12 item 6): the break threshold s_c of a particle
// is multiplied by every region factor that contains it and by 1 + amplitude·n(x/feature_size), n a
// seeded value noise in [−1, 1]; bonds whose reference segment crosses a weak-plane polygon break at
// `factor` times their threshold (systems/strength_field.cpp).
struct StrengthRegion {
  Region region;
  double factor = 1.0;                 // multiplier of s_c (> 0)
};
struct WeakPlane {
  std::vector<Vec3> polygon;           // planar polygon, m (validated like a crack)
  double factor = 0.5;                 // multiplier of s_c of the bonds crossing it, in (0, 1]
};
struct StrengthField {
  std::vector<StrengthRegion> regions;
  double noise_amplitude = 0.0;        // in [0, 1): s_c × (1 + amplitude·n(x)), n in [−1, 1]
  double noise_feature_size = 0.0;     // m, lattice spacing of the value noise (0 = no noise)
  std::uint64_t noise_seed = 1;
  std::vector<WeakPlane> weak_planes;
  bool empty() const { return regions.empty() && !(noise_amplitude > 0.0) && weak_planes.empty(); }
};

struct Material {
  std::string name;
  double density = 1000.0;             // ρ, kg/m³
  double bulk_modulus = 0.0;           // κ, Pa (given directly or from E, ν)
  double shear_modulus = 0.0;          // μ, Pa
  double yield_energy = kInfinity;     // Ψ0 (Eq 13); ∞ = purely elastic
  double plastic_cap_ratio = 0.0;      // γ/|ξ| (Eq 16)
  double critical_stretch = kInfinity; // s_c (Eq 19); ∞ = unbreakable
  // Physical alternatives (systems/README.md §12): when > 0 they replace critical_stretch / yield_energy,
  // converted per particle for its horizon by compute_model_constants.
  double fracture_energy = 0.0;        // G_c, J/m² (0: use critical_stretch)
  double yield_stress = 0.0;           // σ_y, Pa (0: use yield_energy); +∞ = purely elastic
  // σ_p0.2, Pa (0: not given): the 0.2 % offset yield stress, what datasheets list as yield strength.
  // When given (and yield_stress is 0), set-up converts it to the flow stress σ_y of the paper's
  // per-bond law (systems/yield_law.hpp) and the world yields from that.
  double offset_yield_stress = 0.0;
  std::string preset;                  // the `preset` it was filled from ("" = none), for messages
  StrengthField strength;              // spatial variation of s_c (empty = uniform)
  double damage_alpha = 0.0;           // α (Eq 19, systems/README.md §5 reading)
  Mat3 anisotropy = Mat3::Identity();  // G (Eq 17)
  double damping = 0.0;                // mass-proportional velocity damping, 1/s (0 = none)
};

struct Geometry {
  enum class Kind { box, sphere, cylinder, tetgen, gmsh, surface };
  Kind kind = Kind::box;
  Vec3 size = Vec3(1, 1, 1);           // box: full edge lengths, m
  double radius = 0.5;                 // sphere, cylinder, m
  double height = 1.0;                 // cylinder, m (along `axis`)
  int axis = 2;                        // cylinder axis: 0 x, 1 y, 2 z
  std::filesystem::path path;          // tetgen: the .node (.ele beside it); gmsh: .msh; surface: .obj/.ply/.stl/.off; absolute
  double edge_length = 0.0;            // structured mesher, surface: target cell / tet edge size, m (0 = unset)
  int resolution = 0;                  // structured mesher, surface: cells along the longest extent
  long long particles = 0;             // surface: target tet count (0 = unset)
  double jitter = 0.0;                 // box, sphere, cylinder: vertex offset / shortest edge (geometry/jitter.cpp)
  long long seed = 1;                  // jitter seed
  std::array<bool, 3> mirror = {false, false, false};  // box, sphere, cylinder: mesh and jitter mirror-
                                       // symmetric about the centre plane ⟂ x, y, z (geometry/structured.cpp, jitter.cpp)
};

struct Transform {
  Vec3 translation = Vec3::Zero();     // m
  Mat3 rotation = Mat3::Identity();
  double scale = 1.0;
};

struct Body {
  std::string name;
  Geometry geometry;
  int material = 0;                    // index into Scene::materials
  Transform transform;
  Vec3 velocity = Vec3::Zero();        // initial, m/s
  Vec3 angular_velocity = Vec3::Zero();// initial, rad/s about the body's reference centroid
  double horizon_factor = 1.45;        // δ = factor·λ (λ = mean edge length of the tet mesh)
  double horizon_length = 0.0;         // δ in metres; when > 0 it overrides horizon_factor
};

// Time window with a linear ramp: strength 0 before `start`, rising linearly to 1 over `ramp`
// seconds, 1 until `end`, then the condition is released.
struct TimeWindow {
  double start = 0.0;
  double ramp = 0.0;
  double end = kInfinity;
};

struct BoundaryCondition {
  enum class Kind { anchor, velocity, displacement };
  Kind kind = Kind::anchor;
  Region region;
  TimeWindow window;
  // velocity: v = ramp(t)·(velocity + angular_velocity × (x − center))
  // displacement: u = ramp(t)·(displacement + (R(angle·axis) − I)(x − center))  (R: rotation)
  Vec3 velocity = Vec3::Zero();
  Vec3 angular_velocity = Vec3::Zero();
  Vec3 displacement = Vec3::Zero();
  Vec3 rotation_axis = Vec3::UnitX();  // displacement rotation axis (unit)
  double rotation_angle = 0.0;         // radians
  Vec3 center = Vec3::Zero();
  // The world axes the condition prescribes (x, y, z). An axis left out keeps its free motion under
  // the forces, so {x} alone is a roller: a grip that pulls along x and lets the section contract,
  // or (anchor) a symmetry plane.
  std::array<bool, 3> axes = {true, true, true};
};

// An external load (systems/external_loads.cpp, systems/README.md §8.6): a force applied on top of
// gravity, scaled by its time window (strength 0 before `start`, a linear ramp over `ramp`, 1 until
// `end`). Each step applies the window's mean over the time the step's force stands for, so the
// impulse a load delivers is exact for any dt.
struct Load {
  enum class Kind { traction, body_force, blast, radial_impulse, directional, noise };
  Kind kind = Kind::body_force;
  Region region;                       // surface loads: the boundary faces whose centroid is inside;
                                       // body loads: the particles inside (reference positions)
  TimeWindow window;
  // traction: stress, Pa (positive along `direction`, or outward = pulling when along the normal).
  // blast: peak pressure, Pa. radial_impulse: impulse per area, Pa·s. noise: amplitude (m/s² or N/m³).
  double magnitude = 0.0;
  bool along_normal = true;            // traction: along each face's outward normal
  Vec3 direction = Vec3::UnitX();      // traction (when !along_normal), noise drift: unit vector
  Vec3 vector = Vec3::Zero();          // body_force: acceleration (m/s²) or force density (N/m³);
                                       // directional: wind velocity, m/s
  bool per_volume = false;             // body_force, noise: `vector`/`magnitude` is N/m³, not m/s²
  // blast, radial_impulse: p = P·(radius/max(r, radius))^falloff·g(t − start − r/front_speed),
  // g(s) = 1 − s/duration on [0, duration) (duration 0: an impulse), zero beyond `cutoff`.
  Vec3 center = Vec3::Zero();          // m
  double radius = 0.0;                 // m; blast, radial_impulse: peak radius
  double depth = 0.0;                  // m; traction: depth of the loaded layer below the faces (0: faces only)
  double falloff = 2.0;
  double cutoff = kInfinity;           // m
  double duration = 0.0;               // s
  double front_speed = kInfinity;      // m/s
  // directional: force on an exposed face = (drag + quadratic_drag·|u|)·projected area·u, with u the
  // wind velocity relative to the particle.
  double drag = 0.0;                   // Pa per m/s
  double quadratic_drag = 0.0;         // Pa per (m/s)²
  // noise: a smooth value-noise vector field of cell size `feature_size`, drifting at `speed`.
  double feature_size = 1.0;           // m
  double speed = 0.0;                  // m/s along `direction`
  std::uint64_t seed = 0;
};

struct Collider {
  enum class Kind { plane, sphere, box };
  Kind kind = Kind::plane;
  Vec3 point = Vec3::Zero();           // plane: a point on it
  Vec3 normal = Vec3::UnitY();         // plane: outward unit normal (solid side is below)
  Vec3 center = Vec3::Zero();          // sphere, box: initial center
  double radius = 0.5;                 // sphere
  Vec3 half_extents = Vec3(0.5, 0.5, 0.5);  // box
  Mat3 orientation = Mat3::Identity(); // box: initial orientation
  Vec3 velocity = Vec3::Zero();        // prescribed linear velocity, m/s
  Vec3 angular_velocity = Vec3::Zero();// prescribed angular velocity about its center, rad/s
  double friction = 0.0;               // Coulomb coefficient
  double restitution = 0.0;            // normal restitution in [0, 1]
};

// An initial crack (paper Fig. 17): a planar polygon; bonds whose reference segment crosses it are
// not created. Validated on load: at least 3 vertices, planar, non-degenerate.
struct Crack {
  std::vector<Vec3> polygon;           // vertices in order around the boundary, m
};

// Particle–particle contact between particles not joined by an alive bond (systems/contact.cpp).
struct Contact {
  enum class Mode { automatic, on, off };
  Mode mode = Mode::automatic;         // automatic: on when there are ≥ 2 bodies or a breakable material
  double distance_factor = 0.9;        // d_c = factor·(∛V_i + ∛V_j)/2
  double stiffness_factor = 0.05;      // pair stiffness k = factor·min(m_i, m_j)/max(τ, dt)²
  double time_scale = 0.0;             // τ, s; 0: "auto", resolved at set-up (engine/setup/world_setup.cpp)
  double damping_ratio = 0.1;          // normal damping, fraction of critical
  double friction = 0.0;               // Coulomb coefficient
};

// A rigid projectile with mass (systems/projectiles.cpp). Only spheres.
struct Projectile {
  Vec3 center = Vec3::Zero();          // initial, m
  double radius = 0.1;                 // m
  double mass = 1.0;                   // kg (from density·volume when the scene gives a density)
  Vec3 velocity = Vec3::Zero();        // initial, m/s
  Vec3 angular_velocity = Vec3::Zero();// initial, rad/s
  double friction = 0.0;               // Coulomb coefficient against particles
};

// Distributed runs (mpirun; engine/distributed/): when the ranks' shares of the work are re-split.
struct Distributed {
  double rebalance_drift = 0.2;        // re-split when the busiest rank's work exceeds the mean by this
  std::uint64_t rebalance_interval = 100;  // steps between two checks
};

struct Time {
  double dt = 1e-4;                    // s; 0 while auto_dt is unresolved
  // "dt": "auto" (the default): a World picks dt at set-up (80 % of the estimated stable limit, fitted
  // to the frame interval; setup/world_setup.cpp) and writes it into its copy of the scene.
  bool auto_dt = false;
  double duration = 1.0;               // s
  double frame_rate = 24.0;            // frames per second of output
};

struct Output {
  std::filesystem::path directory = "out";   // absolute after loading (relative paths: to the cwd)
  bool vtu = true;                     // particles as VTU + a .pvd series (ParaView)
  bool ply = true;                     // particles as binary PLY points (Houdini, Blender)
  // Embedded tet mesh output (engine/io/surface.cpp): surface.NNNN.obj (+ surface.mtl; groups
  // surface/crack), surface.NNNN.ply (binary, per-face crack + fragment), tets.NNNN.vtu (+ tets.pvd).
  bool obj = false;
  bool surface_ply = false;
  bool surface_vtp = false;            // surface.NNNN.vtp + surface.pvd (ParaView)
  bool tets_vtu = false;
  // At the end of the run (engine/animation.hpp): `cache` writes animation.obj + animation.pc2 (the
  // final surface and every vertex's position per frame, Blender's Mesh Cache modifier), `gltf`
  // animation.glb (rigid pieces); either also writes pieces.csv (per-piece motion per frame).
  bool cache = false;
  bool gltf = false;
  bool surfaces_by_default = false;    // obj + surface_ply + cache were added because `formats` was not given
  std::vector<std::string> fields;     // particle fields to write; empty = all registered fields
  int smooth_cracks = 3;               // smoothing iterations (2 Laplacian steps each) on the crack faces' reference positions (0: off)
  std::uint64_t checkpoint_every = 10; // frames between checkpoints (perifx run --resume); 0 = never
  std::uint32_t min_piece_tets = 0;    // surface files leave out pieces with fewer tets (0: keep all)
  bool dust_points = false;            // "dust": "points": the left-out pieces' particles as dust.NNNN.ply
};

struct Scene {
  std::string name;
  std::filesystem::path source;        // the file it came from ("<memory>" when built in code)
  std::string text;                    // the JSON text it was loaded from (empty when built in code);
                                       // checkpoints record its hash so a resume sees a changed scene
  Time time;
  int threads = 0;                     // 0 = all hardware threads
  Vec3 gravity = Vec3(0, -9.81, 0);    // m/s² (Y is up)
  Normalization normalization = Normalization::corrected;  // the accurate default (§2.4); the paper scenes say `paper`
  FamilyRule family = FamilyRule::mesh;
  Solver solver = Solver::peridynamics;
  std::vector<Material> materials;
  std::vector<Body> bodies;
  std::vector<BoundaryCondition> boundary_conditions;
  std::vector<Load> loads;
  std::vector<Collider> colliders;
  Contact contact;
  std::vector<Projectile> projectiles;
  std::vector<Crack> cracks;
  Distributed distributed;
  Output output;
};

// Reads, validates and converts a scene file. Throws SceneError (parse errors name line and column).
Scene load_scene_file(const std::filesystem::path& file);
// Same from text; `file` names the source in messages and resolves relative mesh paths.
Scene load_scene_text(const std::string& text, const std::filesystem::path& file);
// Limits that keep every run finite (README "Limits"): at most kMaxSteps steps and kMaxFrames frames,
// a frame interval of at least one step (frame_rate <= 1/dt), speeds below kMaxSpeed and coordinates
// within kMaxCoordinate. check_time throws SceneError naming /time/dt or /time/frame_rate; `frames`,
// when non-zero, replaces duration × frame_rate (perifx run --frames).
inline constexpr double kMaxSteps = 1e9;
inline constexpr double kMaxFrames = 1e6;
inline constexpr double kMaxSpeed = 3e8;        // m/s
inline constexpr double kMaxCoordinate = 1e9;   // m
inline constexpr double kMaxWaveSpeed = 1e6;    // m/s, sqrt((κ + 4μ/3)/ρ) of a material
void check_time(const Scene& scene, std::uint64_t frames = 0);
// Whether a material can break: a finite critical stretch or a positive, finite fracture energy.
bool can_break(const Material& material);
// The scene format reference (markdown), generated from the spec.
std::string scene_format_markdown();

}  // namespace perifx::scene
