// perifx public API: build a world from a scene file or a Scene built in code, step it, read its
// fields. A World owns all of its data and its own thread pool (a oneTBB arena); there are no globals,
// so a host can run any number of worlds side by side.
//
//   perifx::World world = perifx::World::from_file("assets/scenes/cantilever.json");
//   while (world.time() < 1.0) world.step();
//   auto y = world.positions();                       // std::span<const perifx::Vec3>
//   perifx::FieldView damage = world.field("damage");
#pragma once
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "components/field_registry.hpp"
#include "components/math.hpp"
#include "engine/scene/scene.hpp"

namespace perifx {

struct WorldState;
class Scheduler;

struct MemoryUse {
  std::size_t particle_bytes = 0;  // all per-particle arrays
  std::size_t bond_bytes = 0;      // all per-bond arrays
  std::size_t mesh_bytes = 0;      // embedded tet mesh
  double bytes_per_particle = 0.0; // particle_bytes / particles
  double bytes_per_bond = 0.0;     // bond_bytes / bonds
};

struct Diagnostics {
  double kinetic_energy = 0.0;     // J
  double elastic_energy = 0.0;     // J (notes.md energy of the elastic model; plastic work excluded)
  double gravity_energy = 0.0;     // J, −Σ m g·y
  Vec3 linear_momentum = Vec3::Zero();   // kg m/s
  Vec3 angular_momentum = Vec3::Zero();  // kg m²/s about the origin
};

class World {
 public:
  // Loads and validates a scene file (throws scene::SceneError, geometry::GeometryError).
  static World from_file(const std::filesystem::path& scene_file);
  explicit World(const scene::Scene& scene);
  World(World&&) noexcept;
  World& operator=(World&&) noexcept;
  ~World();

  void step();                     // advance by one time step dt
  void step(std::uint64_t count);  // advance by `count` steps

  double time() const;
  double dt() const;
  std::uint64_t step_count() const;
  std::size_t particle_count() const;
  std::size_t bond_count() const;       // directed bonds (each pair counts twice)
  std::size_t alive_bond_count() const;
  std::size_t fragment_count() const;  // connected components of alive bonds (computed on call)
  int threads() const;

  // The largest stable explicit step of this world's elastic model (power iteration on the
  // linearized force at the reference configuration, velocity Verlet limit 2/ω_max).
  double stable_time_step() const;
  MemoryUse memory() const;
  Diagnostics diagnostics() const;
  std::string schedule() const;    // the task graph, one system per line

  std::span<const Vec3> positions() const;
  std::span<const Vec3> reference_positions() const;
  std::span<const Vec3> velocities() const;
  std::span<Vec3> velocities_mutable();  // a host may kick the solid between steps

  std::vector<std::string> field_names() const;
  FieldView field(std::string_view name) const;  // throws std::out_of_range listing the names
  std::vector<FieldView> fields() const;

  const scene::Scene& scene() const;
  const WorldState& state() const;  // internals, for tools and tests that know the components
  WorldState& state_mutable();

 private:
  std::unique_ptr<WorldState> state_;
  std::unique_ptr<Scheduler> scheduler_;
  double stable_dt_ = 0.0;
};

}  // namespace perifx
