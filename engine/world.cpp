#include "perifx/world.hpp"

#include <stdexcept>

#include "model/setup.hpp"
#include "scheduler.hpp"
#include "systems/parallel.hpp"
#include "systems/systems.hpp"
#include "world_state.hpp"

namespace perifx {

World World::from_file(const std::filesystem::path& scene_file) { return World(scene::load_scene_file(scene_file)); }

World::World(const scene::Scene& scene) : scheduler_(std::make_unique<Scheduler>(scene.threads)) {
  state_ = model::build_world_state(scene, *scheduler_);
  model::add_step_systems(*state_, *scheduler_);
  scheduler_->build();
}

World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;
World::~World() {
  scheduler_.reset();  // the graph's nodes reference state_; tear them down first
}

void World::step() {
  scheduler_->run_step();
  auto& c = state_->clock;
  ++c.step;
  c.time = static_cast<double>(c.step) * c.dt;  // no drift from summing dt
}

void World::step(std::uint64_t count) {
  for (std::uint64_t k = 0; k < count; ++k) step();
}

double World::time() const { return state_->clock.time; }
double World::dt() const { return state_->clock.dt; }
std::uint64_t World::step_count() const { return state_->clock.step; }
std::size_t World::particle_count() const { return state_->particles.count(); }
std::size_t World::bond_count() const { return state_->bonds.count(); }
std::size_t World::alive_bond_count() const {
  const auto& alive = state_->bonds.alive;
  return deterministic_sum(alive.size(), std::size_t(0), [&](std::size_t k) { return std::size_t(alive[k]); });
}
int World::threads() const { return scheduler_->threads(); }
std::size_t World::fragment_count() const {
  std::vector<std::uint32_t> id;
  return systems::compute_fragments(*state_, id);
}

double World::stable_time_step() const {
  if (stable_dt_ == 0.0) {
    double dt = 0.0;
    scheduler_->execute([&] { dt = model::estimate_stable_time_step(*state_); });
    const_cast<World*>(this)->stable_dt_ = dt;
  }
  return stable_dt_;
}

MemoryUse World::memory() const {
  const auto& p = state_->particles;
  const auto& md = state_->model;
  const auto& s = state_->state;
  const auto& b = state_->bonds;
  auto bytes = [](const auto& v) { return v.size() * sizeof(v[0]); };
  MemoryUse m;
  m.particle_bytes = bytes(p.reference_position) + bytes(p.position) + bytes(p.velocity) + bytes(p.acceleration) +
                     bytes(p.volume) + bytes(p.mass) + bytes(p.material_id) + bytes(p.body_id) + bytes(p.flags) +
                     bytes(md.horizon) + bytes(md.dilatation_scale) + bytes(md.a4) + bytes(md.b4) + bytes(md.beta) +
                     bytes(md.damping) + bytes(s.dilatation) + bytes(s.dilatation_coupling) + bytes(s.internal_force) +
                     bytes(s.external_force) + bytes(s.damage) + bytes(b.offsets) + bytes(b.initial_count);
  m.bond_bytes = bytes(b.neighbor) + bytes(b.reverse) + bytes(b.reference_length) + bytes(b.weight) + bytes(b.alive) +
                 bytes(b.plastic_extension);
  m.mesh_bytes = bytes(state_->mesh.vertices) + bytes(state_->mesh.tets);
  m.bytes_per_particle = p.count() ? double(m.particle_bytes) / double(p.count()) : 0.0;
  m.bytes_per_bond = b.count() ? double(m.bond_bytes) / double(b.count()) : 0.0;
  return m;
}

Diagnostics World::diagnostics() const {
  Diagnostics d;
  const auto& p = state_->particles;
  const Vec3 g = state_->scene.gravity;
  scheduler_->execute([&] {
    const std::size_t n = p.count();
    d.kinetic_energy = deterministic_sum(n, 0.0, [&](std::size_t i) { return 0.5 * p.mass[i] * p.velocity[i].squaredNorm(); });
    d.gravity_energy = deterministic_sum(n, 0.0, [&](std::size_t i) { return -p.mass[i] * g.dot(p.position[i]); });
    d.linear_momentum = deterministic_sum(n, Vec3(Vec3::Zero()), [&](std::size_t i) { return Vec3(p.mass[i] * p.velocity[i]); });
    d.angular_momentum = deterministic_sum(n, Vec3(Vec3::Zero()), [&](std::size_t i) {
      return Vec3(p.mass[i] * p.position[i].cross(p.velocity[i]));
    });
    d.elastic_energy = model::elastic_energy(*state_);
  });
  return d;
}

std::string World::schedule() const { return scheduler_->describe(); }

std::span<const Vec3> World::positions() const { return state_->particles.position; }
std::span<const Vec3> World::reference_positions() const { return state_->particles.reference_position; }
std::span<const Vec3> World::velocities() const { return state_->particles.velocity; }
std::span<Vec3> World::velocities_mutable() { return state_->particles.velocity; }

std::vector<FieldView> World::fields() const {
  WorldState& w = *state_;
  const auto& p = w.particles;
  const std::size_t n = p.count();
  // Derived fields are refreshed on request, not every step.
  w.derived.displacement.resize(n);
  w.derived.alive_bonds.resize(n);
  w.derived.plastic_strain.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    w.derived.displacement[i] = p.position[i] - p.reference_position[i];
    std::uint32_t alive = 0;
    double plastic = 0.0;
    for (std::uint32_t k = w.bonds.offsets[i]; k < w.bonds.offsets[i + 1]; ++k) {
      if (!w.bonds.alive[k]) continue;
      ++alive;
      plastic += std::abs(w.bonds.plastic_extension[k]) / w.bonds.reference_length[k];
    }
    w.derived.alive_bonds[i] = alive;
    w.derived.plastic_strain[i] = alive ? plastic / double(alive) : 0.0;
  }
  // damage and broken_bonds are kept current by the damage system (damage.cpp) or the bond pass.
  w.derived.fragment_count = systems::compute_fragments(w, w.derived.fragment_id);
  auto vec = [n](const char* name, const std::vector<Vec3>& a, const char* unit, const char* doc) {
    return FieldView{name, FieldType::f64, 3, FieldLocation::particle, a.data(), n, unit, doc};
  };
  auto f64 = [n](const char* name, const std::vector<double>& a, const char* unit, const char* doc) {
    return FieldView{name, FieldType::f64, 1, FieldLocation::particle, a.data(), n, unit, doc};
  };
  return {
      vec("position", p.position, "m", "current position y"),
      vec("velocity", p.velocity, "m/s", "velocity"),
      vec("displacement", w.derived.displacement, "m", "y − x"),
      vec("acceleration", p.acceleration, "m/s^2", "acceleration from the last force evaluation"),
      f64("dilatation", w.state.dilatation, "1", "θ (Eq 6)"),
      f64("damage", w.state.damage, "1", "φ = 1 − n/N (Eq 19)"),
      FieldView{"alive_bonds", FieldType::u32, 1, FieldLocation::particle, w.derived.alive_bonds.data(), n, "1",
                "bonds still holding"},
      FieldView{"broken_bonds", FieldType::u32, 1, FieldLocation::particle, w.state.broken_bonds.data(), n, "1",
                "N − n: bonds broken since setup"},
      f64("plastic_strain", w.derived.plastic_strain, "1", "mean |e^p|/|ξ| over alive bonds (Eq 11–16)"),
      FieldView{"fragment_id", FieldType::u32, 1, FieldLocation::particle, w.derived.fragment_id.data(), n, "1",
                "connected component of alive bonds: its smallest particle index"},
      f64("volume", p.volume, "m^3", "particle volume V"),
      f64("mass", p.mass, "kg", "particle mass"),
      FieldView{"material_id", FieldType::u16, 1, FieldLocation::particle, p.material_id.data(), n, "1",
                "index into the scene's materials"},
      FieldView{"body_id", FieldType::u16, 1, FieldLocation::particle, p.body_id.data(), n, "1",
                "index into the scene's bodies"},
  };
}

std::vector<std::string> World::field_names() const {
  std::vector<std::string> names;
  for (const auto& f : fields()) names.push_back(f.name);
  return names;
}

FieldView World::field(std::string_view name) const {
  std::string known;
  for (auto& f : fields()) {
    if (f.name == name) return f;
    known += (known.empty() ? "" : ", ") + f.name;
  }
  throw std::out_of_range("no field named '" + std::string(name) + "'; fields: " + known);
}

const scene::Scene& World::scene() const { return state_->scene; }
const WorldState& World::state() const { return *state_; }
WorldState& World::state_mutable() { return *state_; }

}  // namespace perifx
