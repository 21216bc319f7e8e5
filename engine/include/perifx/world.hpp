// perifx public API: build a world from a scene file or a Scene built in code, step it, read its
// fields, surfaces and pieces. A World owns all of its data and its own thread pool (a oneTBB
// arena); there are no globals, so a host can run any number of worlds side by side.
//
//   perifx::World world = perifx::World::from_file("assets/scenes/cantilever.json");
//   while (world.time() < 1.0) world.step();
//   auto y = world.positions();                       // std::span<const perifx::Vec3>
//   perifx::FieldView damage = world.field("damage");
//
// This header and the ones it includes (engine/include/perifx/) are the whole public interface;
// they need only this directory and Eigen on the include path. Errors: perifx/errors.hpp.
#pragma once
#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "perifx/errors.hpp"
#include "perifx/fields.hpp"
#include "perifx/math.hpp"
#include "perifx/mesh.hpp"
#include "perifx/scene.hpp"

namespace perifx {

struct WorldState;
namespace distributed {
struct Domain;  // engine/distributed/decomposition.hpp (private)
}
class Scheduler;

// Bytes held by the world's arrays (their capacities), by kind.
struct MemoryUse {
  std::size_t particle_bytes = 0;  // per-particle arrays (positions, model constants, state, CSR offsets)
  std::size_t bond_bytes = 0;      // per-bond arrays
  std::size_t mesh_bytes = 0;      // tet mesh, embedded (cracking) mesh, FEM data
  std::size_t contact_bytes = 0;   // contact grid and pair list
  std::size_t other_bytes = 0;     // projectiles, boundary lists, derived output fields
  std::size_t total_bytes = 0;     // sum of the above
  double bytes_per_particle = 0.0; // particle_bytes / particles
  double bytes_per_bond = 0.0;     // bond_bytes / bonds
};

struct Diagnostics {
  double kinetic_energy = 0.0;     // J
  double elastic_energy = 0.0;     // J (energy of the elastic model; plastic work excluded)
  double gravity_energy = 0.0;     // J, −Σ m g·y
  Vec3 linear_momentum = Vec3::Zero();   // kg m/s
  Vec3 angular_momentum = Vec3::Zero();  // kg m²/s about the origin
};

struct BodyView {
  std::string name;
  std::uint32_t first_particle = 0, particle_count = 0;
  double mean_edge_length = 0.0;   // λ, m
  double horizon = 0.0;            // δ, m
};

struct ProjectileView {
  double radius = 0.0, mass = 0.0;  // m, kg
  Vec3 center = Vec3::Zero(), velocity = Vec3::Zero(), angular_velocity = Vec3::Zero();
  Vec3 contact_force = Vec3::Zero();  // N, on the projectile from the particles (last step)
};

// The tet mesh the particles live in. Peridynamics: tet t carries particle t, and vertices split as
// cracks open (paper §5.2). FEM: the reference mesh, whose vertex v is particle v.
struct TetMeshView {
  std::span<const Vec3> vertices;
  std::span<const std::array<std::uint32_t, 4>> tets;
  std::span<const Vec3> reference_vertices;  // rest positions of `vertices` (FEM: particles' reference)
};

struct ContactCounters {
  std::uint64_t list_builds = 0;     // particle-contact pair list: full rebuilds (motion)
  std::uint64_t list_additions = 0;  // incremental additions of broken bonds' pairs
  std::uint64_t list_partial_updates = 0;  // updates that searched only the particles that moved
  std::uint64_t list_searched = 0;         // particles searched by those updates
};

// One rank's share of a distributed run and its traffic over the run (World::rank_stats).
struct RankStats {
  std::uint32_t owned_particles = 0;  // now
  std::uint32_t bond_ghosts = 0;      // now: far ends of its owned bonds (FEM: the other vertices of its
                                      // vertices' tets), owned by other ranks
  std::uint32_t contact_ghosts = 0;   // as of the last refresh: other ranks' particles within contact reach
  std::uint64_t halo_bytes = 0;       // received by the per-step halo exchanges and the contact-ghost refreshes
  std::uint64_t steps = 0;            // steps it took part in (halo_bytes / steps: bytes per step)
  std::uint64_t contact_ghost_refreshes = 0;
  ContactCounters contact;            // its own pair list's
  // Gathers of the state to rank 0 (every frame, every re-split), label rounds of the distributed
  // pieces search in them, and wall seconds of rank 0's mesh-split replay, the gather and the pieces search.
  std::uint64_t state_gathers = 0, piece_rounds = 0;
  double replay_seconds = 0.0, gather_seconds = 0.0, piece_seconds = 0.0;
};

// Wall time of one system of the step's task graph while profiling was on (World::set_profiling).
struct SystemTime {
  std::string name;        // the system's name, as in World::schedule()
  double seconds = 0.0;    // summed over the profiled steps (a profiled step runs its systems one at a time)
  std::uint64_t runs = 0;  // profiled steps it ran in
  // Distributed runs (World::all_ranks_system_times, on rank 0): every rank's seconds, by rank.
  std::vector<double> rank_seconds;
};

// One rank's share of the world in a distributed run over N ranks (World::decompose; issue 17 and
// engine/distributed/decomposition.hpp): a contiguous range of the Morton order with 1/N of the work,
// and the ghosts it must receive every step.
struct DomainView {
  std::uint32_t first_particle = 0, particle_count = 0;
  std::uint64_t bonds = 0;                 // listed (directed) bonds of the owned particles
  std::uint32_t ghosts = 0;                // particles it reads but does not own
  std::uint32_t bond_ghosts = 0;           // of which far ends of owned bonds
  std::uint32_t contact_ghosts = 0;        // of which only within contact reach (distance + skin)
  std::uint32_t neighbor_ranks = 0;        // ranks it receives from
  std::uint64_t halo_bytes_per_step = 0;   // bytes it receives per step
};

// What World's constructor builds. `shell`: for a rank other than 0 of a distributed run, which
// receives its part of the world from rank 0 at distribute() and so need not build the whole world
// (nor hold it: its families, bonds and embedded mesh are rank 0's alone). A shell holds the scene's
// settings, the clock and the bodies' names and measures, and no arrays; it can only distribute().
enum class WorldBuild : std::uint8_t { whole, shell };

class World {
 public:
  // Loads and validates a scene file (throws scene::SceneError, geometry::GeometryError).
  static World from_file(const std::filesystem::path& scene_file);
  explicit World(const scene::Scene& scene, WorldBuild build = WorldBuild::whole);
  World(World&&) noexcept;
  World& operator=(World&&) noexcept;
  ~World();

  // Advance by one time step dt. Throws InstabilityError (perifx/errors.hpp) when the step left a
  // particle non-finite or running away; the world's state is then not usable.
  void step();
  void step(std::uint64_t count);  // advance by `count` steps

  double time() const;
  double dt() const;
  std::uint64_t step_count() const;
  std::size_t particle_count() const;
  std::size_t bond_count() const;       // directed bonds (each pair counts twice)
  std::size_t alive_bond_count() const;
  std::size_t fragment_count() const;  // connected components of alive bonds
  // Simulated time at the end of the step in which a bond first broke (initial cracks do not count);
  // empty while none has. Kept across resume.
  std::optional<double> first_break_time() const;
  int threads() const;
  // Steps (and the world's own work: the stable-step estimate, derived fields) run on `threads` threads
  // from now on (≤ 0: all hardware threads); the state and every result are the same for any count.
  // `perifx run` under mpirun builds rank 0's world with the threads of the ranks waiting for it on its
  // machine, then sets its own count before distribute(). Throws std::logic_error once distributed.
  void set_threads(int threads);

  // The largest stable explicit step of this world's elastic model (the largest eigenfrequency of
  // the linearized force at the reference configuration; velocity Verlet limit 2/ω_max).
  double stable_time_step() const;
  // A lower bound on that step from one pass over the bonds (0 for the FEM solver: no bound): any
  // time step at or below it is stable, and checking it costs a fraction of the estimate above, which
  // needs some 20–30 applications of the force (tens of seconds at 1e6 particles).
  double stable_time_step_bound() const;
  // The contact time scale τ, s, set at set-up (the scene's contact/time_scale; "auto": the automatic
  // step before it is fitted to the frames): the contact and projectile springs are
  // stiffness_factor·m/max(τ, dt)². 0 when nothing in the world touches (no contact, no projectile).
  double contact_time_scale() const;
  MemoryUse memory() const;
  // How this world would split over `ranks` ranks now (throws std::invalid_argument unless
  // 1 ≤ ranks ≤ particles). A plan: the world itself keeps running in one process.
  std::vector<DomainView> decompose(int ranks) const;

  // Distributed runs (issue 17; a PERIFX_MPI build started by mpirun). distribute() splits this world
  // over the MPI job's ranks, every rank calling it on a world of the same scene: rank 0's whole world
  // (WorldBuild::whole), the others' shells (WorldBuild::shell, which saves them building and holding
  // the whole world) or whole worlds. Rank 0 makes every rank's part and sends it. From then on step()
  // advances this rank's share and exchanges halos with the others, bit-identical to one process. On
  // rank 0 the accessors show the whole world as of the last gather(); on other ranks the world holds
  // no arrays and only the clock, scene and counts of step() remain. The FEM solvers are distributed
  // too (a rank owns vertices; its ghosts are the other vertices of their tets). A build without MPI
  // throws std::runtime_error. All four calls are collective: every rank makes them in the same order.
  void distribute();
  void gather();                    // rank 0's view of every particle and bond becomes current
  bool broadcast(bool flag);        // rank 0's flag, on every rank (the same answer in one process)
  int rank() const;                 // 0 in one process
  int ranks() const;                // 1 in one process (and before distribute())
  bool distributed() const;
  bool shell() const;  // built as WorldBuild::shell
  // Re-splits so far: step() re-splits a distributed world when the work per rank drifts (the scene's
  // "distributed" settings), which changes no result bit.
  std::uint64_t rebalances() const;
  Diagnostics diagnostics() const;
  std::string schedule() const;    // the task graph, one system per line
  // Per-system wall time of the steps taken while profiling is on (off by default; costs two clock
  // reads per system per step, and the step runs its systems one at a time, each with every thread, so
  // each time is that system's own). `perifx run --profile` prints it.
  void set_profiling(bool on);
  std::vector<SystemTime> system_times() const;  // in schedule() order
  // The same, with every rank's seconds in rank_seconds on rank 0 of a distributed run (collective;
  // other ranks get their own times back). Where ranks wait for each other shows as halo time.
  std::vector<SystemTime> all_ranks_system_times();
  // Wall time of each phase of building this world (bodies, families, embedded mesh, model
  // constants ...) and, once stable_time_step() has run, of the stable-step estimate; runs = 1.
  std::vector<SystemTime> setup_times() const;

  std::span<const Vec3> positions() const;
  std::span<const Vec3> reference_positions() const;
  std::span<const Vec3> velocities() const;
  std::span<Vec3> velocities_mutable();  // a host may kick the solid between steps

  // Fields, as registered by the systems that produce them. A derived field (displacement,
  // alive_bonds, plastic_strain, fragment_id) is computed when asked for, once per step.
  std::vector<std::string> field_names() const;
  FieldView field(std::string_view name) const;  // throws std::out_of_range listing the names
  std::vector<FieldView> fields() const;
  // The registered fields without data (name, type, components, unit, doc), for documentation.
  static std::vector<FieldView> field_catalog();

  std::vector<BodyView> bodies() const;
  std::vector<ProjectileView> projectiles() const;
  ContactCounters contact_counters() const;  // this process's list (a distributed run's: rank_stats())
  // Every rank's share and traffic over the run, by rank, on rank 0 of a distributed run (collective;
  // other ranks get their own); one entry in one process (no ghosts, no halo).
  std::vector<RankStats> rank_stats();
  bool has_embedded_mesh() const;   // peridynamics worlds (the FEM solver has no cracking mesh)
  TetMeshView tet_mesh() const;       // the cracking mesh, current vertex positions (see TetMeshView)
  TetMeshView reference_mesh() const; // the mesh as built, before any split, at rest
  // Particles of the pieces surface() leaves out (fewer than output.min_piece_tets tets), increasing.
  std::vector<std::uint32_t> dust_particles() const;
  SurfaceMesh surface() const;      // boundary triangles of the (split) mesh, with piece ids; pieces below output.min_piece_tets left out

  // Checkpoints: the complete state (every array and counter) in one file, written atomically, from
  // which a world built from the same scene continues byte-identically, on any thread count. `note`
  // is kept verbatim (the runner keeps its frame bookkeeping there). load_checkpoint throws
  // io::IoError when the file is not a readable checkpoint, scene::SceneError when it was written for
  // another scene (naming the top-level keys that changed, or the time step or solver); it returns
  // the note.
  void save_checkpoint(const std::filesystem::path& file, const std::string& note = {}) const;
  std::string load_checkpoint(const std::filesystem::path& file);

  const scene::Scene& scene() const;
  const WorldState& state() const;  // internals, for tools and tests that know the components
  WorldState& state_mutable();      // tests only: invalidates cached derived fields

 private:
  [[noreturn]] void throw_instability() const;
  // distribute() by `domains` (null: equal bonds); `before`: the replaced runtime's share, at a re-split
  // (rank 0 then sends each rank its local world).
  void split(const std::vector<::perifx::distributed::Domain>* domains, const RankStats* before = nullptr);
  void rebalance();                                              // step(): the runtime's re-split
  bool any_bond_broken() const;  // any particle has a broken bond now (step(): the first break)
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace perifx
