#include "perifx/world.hpp"

#include <oneapi/tbb/parallel_reduce.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <stdexcept>

#include "distributed/decomposition.hpp"
#include "distributed/local_world.hpp"
#include "distributed/runtime.hpp"
#include "io/checkpoint.hpp"
#include "scheduler.hpp"
#include "setup/world_setup.hpp"
#include "systems/field_registry.hpp"
#include "systems/parallel.hpp"
#include "systems/pipeline.hpp"
#include "systems/systems.hpp"

namespace perifx {

struct World::Impl {
  scene::Scene scene;
  std::unique_ptr<WorldState> state;
  std::unique_ptr<Scheduler> scheduler;
  systems::FieldRegistry fields = systems::step_fields();
  // Per registered field: the step its derived array was computed at (kStale: not since a change).
  static constexpr std::uint64_t kStale = std::numeric_limits<std::uint64_t>::max();
  std::vector<std::uint64_t> computed_at = std::vector<std::uint64_t>(fields.size(), kStale);
  std::vector<FieldView> computed = std::vector<FieldView>(fields.size());  // derived fields' last views
  double stable_dt = 0.0;
  std::optional<double> stable_bound;  // World::stable_time_step_bound, once computed
  std::vector<setup::PhaseTime> setup_times;  // construction phases, then the stable-step estimate
  std::unique_ptr<distributed::Runtime> runtime;  // distribute(): this rank's local world and halos
  std::uint64_t rebalances = 0;                  // re-splits of the distributed run so far
  bool embedded_mesh = false;                    // a distributed world had an embedded mesh when split
  bool profiling = false;                        // set_profiling's last word
  std::vector<SystemTime> earlier_times;         // profile of the step graphs before the last re-split
  std::size_t particles = 0, bonds = 0;  // the whole world's counts (other ranks free its arrays)
  bool shell = false;                    // WorldBuild::shell: no arrays; distribute() fills the above

  // The step's task graph on the scheduler's threads, from the state as built (the constructor; set_threads).
  void build_step_graph() {
    for (auto& system : systems::step_pipeline(*state)) scheduler->add(std::move(system));
    scheduler->build();
  }

  ~Impl() { scheduler.reset(); }  // the graph's nodes reference the state; tear them down first
};

World World::from_file(const std::filesystem::path& scene_file) { return World(scene::load_scene_file(scene_file)); }

World::World(const scene::Scene& scene, WorldBuild build) : impl_(std::make_unique<Impl>()) {
  impl_->scene = scene;
  impl_->scheduler = std::make_unique<Scheduler>(scene.threads);
  impl_->shell = build == WorldBuild::shell;
  impl_->state = setup::build_world_state(scene, *impl_->scheduler, &impl_->setup_times, impl_->shell, &impl_->stable_dt);
  // An automatic step was picked at set-up (a shell's arrives from rank 0 at the split): the scene this
  // world reports says which.
  impl_->scene.time.dt = impl_->state->clock.dt;
  impl_->build_step_graph();
}

World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;
World::~World() = default;

void World::step() {
  WorldState& w = *impl_->state;
  auto& c = w.clock;
  const bool check_broken = w.any_fracture && c.first_break_step == Clock::kNoBreak;
  // A distributed world steps its local part; its report carries the whole job's health and breaks.
  distributed::StepReport report;
  if (impl_->shell && !impl_->runtime) throw std::logic_error("World::step: a shell (WorldBuild::shell) steps once distributed");
  if (impl_->runtime) {
    report = impl_->runtime->step(check_broken);
  } else {
    impl_->scheduler->run_step();
    report.unstable_particle = w.state.unstable_particle;
  }
  ++c.step;
  c.time = static_cast<double>(c.step) * c.dt;  // no drift from summing dt
  if (report.unstable_particle != ParticleState::kAllStable) {
    if (impl_->runtime) {
      gather();  // the message names the particle's state, which rank 0 then holds
      if (rank() != 0)
        throw InstabilityError("unstable simulation at step " + std::to_string(c.step) + " (rank 0 reports it)",
                               c.step, report.unstable_particle);
      w.state.unstable_particle = report.unstable_particle;
    }
    throw_instability();
  }
  if (check_broken && (impl_->runtime ? report.any_broken : any_bond_broken())) c.first_break_step = c.step;
  if (report.rebalance) rebalance();
}

// A re-split of a distributed run (the runtime found the work per rank drifted): rank 0 gathers the
// whole world, makes every rank's new local world from it and sends each its own; the new split's local
// worlds continue from there. The same bits as without: a local world computes what one process does
// from whatever it holds.
void World::rebalance() {
  const std::vector<::perifx::distributed::Domain> domains = impl_->runtime->rebalanced_domains();
  gather();
  impl_->earlier_times = system_times();
  const RankStats before = impl_->runtime->share();
  impl_->runtime.reset();
  split(&domains, &before);
  if (impl_->profiling) impl_->runtime->scheduler().set_profiling(true);
  ++impl_->rebalances;
}

// One pass over the per-particle broken-bond counts (N_i − n_i, kept by the bond pass): run after
// every step only until the first break is seen.
bool World::any_bond_broken() const {
  const auto& broken = impl_->state->state.broken_bonds;
  bool any = false;
  impl_->scheduler->execute([&] {
    any = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, broken.size(), 4096), false,
        [&](const tbb::blocked_range<std::size_t>& r, bool found) {
          for (std::size_t i = r.begin(); i != r.end() && !found; ++i) found = broken[i] != 0;
          return found;
        },
        [](bool a, bool b) { return a || b; });
  });
  return any;
}

std::optional<double> World::first_break_time() const {
  const auto& c = impl_->state->clock;
  if (c.first_break_step == Clock::kNoBreak) return std::nullopt;
  return static_cast<double>(c.first_break_step) * c.dt;
}

// One line naming the scene, body, particle, position, step and time, with what was expected and a
// hint (the time step against the stable limit, contact stiffness).
void World::throw_instability() const {
  const WorldState& w = *impl_->state;
  const std::size_t i = static_cast<std::size_t>(w.state.unstable_particle);
  const auto& p = w.particles;
  const std::size_t body = p.body_id[i];
  const std::string body_name = body < w.bodies.size() ? w.bodies[body].name : "?";
  const Vec3 y = p.position[i], v = p.velocity[i];
  const bool finite = std::isfinite(y.x() + y.y() + y.z() + v.x() + v.y() + v.z());
  char buf[640];
  std::snprintf(buf, sizeof buf,
                "unstable simulation: body '%s' particle %zu at (%.4g, %.4g, %.4g) m %s at step %llu, t = %.6g s "
                "(got |v| = %.3g m/s; expected finite and at most %.3g m/s, 10x the fastest wave and prescribed speed)",
                body_name.substr(0, 80).c_str(), i, y.x(), y.y(), y.z(),
                finite ? "runs away" : "has a non-finite position or velocity", static_cast<unsigned long long>(w.clock.step),
                w.clock.time, v.norm(), w.settings.max_speed);
  std::string message = impl_->scene.source.string() + ": /bodies/" + std::to_string(body) + ": " + buf;
  const double stable = stable_time_step();
  char hint[320];
  std::snprintf(hint, sizeof hint,
                "; hint: time/dt = %.3g s is %.0f%% of the stable limit %.3g s (try <= 50%%)%s", w.clock.dt,
                100.0 * w.clock.dt / stable, stable,
                w.contact.enabled || !w.settings.colliders.empty() || !w.projectiles.bodies.empty()
                    ? ", or lower contact/stiffness_factor" : "");
  throw InstabilityError(message + hint, w.clock.step, i);
}

void World::step(std::uint64_t count) {
  for (std::uint64_t k = 0; k < count; ++k) step();
}

double World::time() const { return impl_->state->clock.time; }
double World::dt() const { return impl_->state->clock.dt; }
std::uint64_t World::step_count() const { return impl_->state->clock.step; }
std::size_t World::particle_count() const {
  return impl_->runtime ? impl_->particles : impl_->state->particles.count();
}
std::size_t World::bond_count() const { return impl_->runtime ? impl_->bonds : impl_->state->bonds.count(); }
std::size_t World::alive_bond_count() const {
  const auto& alive = impl_->state->bonds.alive;
  std::size_t count = 0;
  impl_->scheduler->execute([&] {
    count = deterministic_sum(alive.size(), std::size_t(0), [&](std::size_t k) { return std::size_t(alive[k]); });
  });
  return count;
}
int World::threads() const { return impl_->scheduler->threads(); }
void World::set_threads(int threads) {
  if (impl_->runtime) throw std::logic_error("World::set_threads: a distributed world's threads are fixed at distribute()");
  impl_->scheduler.reset();  // its graph's nodes reference the state
  impl_->scheduler = std::make_unique<Scheduler>(threads);
  impl_->build_step_graph();
  impl_->scheduler->set_profiling(impl_->profiling);
  impl_->scene.threads = threads;
  impl_->state->settings.threads = threads;
}
std::size_t World::fragment_count() const {
  field("fragment_id");
  return impl_->state->derived.fragment_count;
}

double World::contact_time_scale() const {
  const WorldState& w = *impl_->state;
  const bool touches = w.contact.enabled || !w.projectiles.bodies.empty();
  return touches ? w.settings.contact.time_scale : 0.0;
}

double World::stable_time_step() const {
  if (impl_->stable_dt == 0.0) {
    // A world whose stiffness matrix cannot be analysed (overflowing constants) has no stable step:
    // NaN, which every "dt <= limit" test refuses.
    const auto start = std::chrono::steady_clock::now();
    try {
      impl_->scheduler->execute([&] { impl_->stable_dt = setup::estimate_stable_time_step(*impl_->state); });
    } catch (const std::runtime_error&) {
      impl_->stable_dt = std::numeric_limits<double>::quiet_NaN();
    }
    impl_->setup_times.push_back(
        {"stable time step", std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()});
  }
  return impl_->stable_dt;
}

double World::stable_time_step_bound() const {
  if (!impl_->stable_bound) {
    const auto start = std::chrono::steady_clock::now();
    impl_->scheduler->execute([&] { impl_->stable_bound = setup::stable_time_step_bound(*impl_->state); });
    impl_->setup_times.push_back(
        {"stable time step bound", std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()});
  }
  return *impl_->stable_bound;
}

std::vector<SystemTime> World::setup_times() const {
  std::vector<SystemTime> out;
  for (const auto& t : impl_->setup_times) out.push_back({t.name, t.seconds, 1, {}});
  return out;
}

std::vector<DomainView> World::decompose(int ranks) const {
  std::vector<distributed::Domain> domains;
  impl_->scheduler->execute([&] { domains = distributed::decompose(*impl_->state, ranks); });
  std::vector<DomainView> out;
  out.reserve(domains.size());
  for (const auto& d : domains)
    out.push_back({d.first, d.last - d.first, d.bonds, static_cast<std::uint32_t>(d.ghosts.size()), d.bond_ghosts,
                   d.contact_ghosts, static_cast<std::uint32_t>(d.neighbor_ranks.size()), d.halo_bytes_per_step});
  return out;
}

void World::distribute() {
  if (impl_->runtime) throw std::logic_error("World::distribute: already distributed");
  split(nullptr);
}

void World::split(const std::vector<::perifx::distributed::Domain>* domains, const RankStats* before) {
  // Rank 0 holds the whole world (as built, loaded from a checkpoint or gathered); the others hold a
  // shell or released arrays. Its counts, clock and whether it has a mesh are everybody's.
  WorldState& w = *impl_->state;
  const bool lead = distributed::job_rank() == 0;
  // Rank 0 never steps the whole world: its contact grids and pair list (a fifth of the whole world's
  // arrays in the glass-wall shot) go before the local worlds are made, which lowers rank 0's peak.
  if (lead) setup::release_contact_buffers(w);
  std::vector<char> frame = lead ? distributed::pack_world_frame(w) : std::vector<char>{};
  std::array<std::uint64_t, 4> whole{w.particles.count(), w.bonds.count(),
                                     impl_->embedded_mesh || !w.embedded.tets.empty(), frame.size()};
  // At the first split the other ranks have waited here through rank 0's set-up: asleep, so that rank
  // 0 can set up on their cores (setup::setup_threads).
  distributed::broadcast_bytes(whole.data(), sizeof whole, distributed::Wait::asleep);
  frame.resize(whole[3]);
  distributed::broadcast_bytes(frame.data(), frame.size());
  if (!lead) distributed::take_world_frame(w, frame);  // the clock, bounds and bodies' measures
  impl_->scene.time.dt = w.clock.dt;  // a shell's automatic step is rank 0's
  impl_->particles = whole[0];
  impl_->bonds = whole[1];
  impl_->embedded_mesh = whole[2] != 0;
  try {
    // Rank 0 makes every rank's local world and sends each its own.
    impl_->runtime = std::make_unique<distributed::Runtime>(w, impl_->scheduler->threads(), domains, before);
  } catch (const std::invalid_argument& e) {  // what the runtime cannot split yet, by JSON pointer
    throw std::invalid_argument(impl_->scene.source.string() + ": " + e.what());
  }
  // Rank 0 writes the output from its whole world; the others step their local worlds only.
  if (impl_->runtime->rank() != 0) setup::release_arrays(w);
}

void World::gather() {
  if (!impl_->runtime) return;
  impl_->runtime->gather(*impl_->state);
  std::fill(impl_->computed_at.begin(), impl_->computed_at.end(), Impl::kStale);
}

bool World::broadcast(bool flag) { return impl_->runtime ? impl_->runtime->broadcast(flag) : flag; }
int World::rank() const { return impl_->runtime ? impl_->runtime->rank() : 0; }
std::uint64_t World::rebalances() const { return impl_->rebalances; }
int World::ranks() const { return impl_->runtime ? impl_->runtime->ranks() : 1; }
bool World::distributed() const { return impl_->runtime != nullptr; }
bool World::shell() const { return impl_->shell; }

MemoryUse World::memory() const {
  MemoryUse m;
  for_each_array(*impl_->state, [&](ArrayKind kind, const char*, const auto& array) {
    const std::size_t bytes = array.capacity() * sizeof(array[0]);
    switch (kind) {
      case ArrayKind::particle: m.particle_bytes += bytes; break;
      case ArrayKind::bond: m.bond_bytes += bytes; break;
      case ArrayKind::mesh: m.mesh_bytes += bytes; break;
      case ArrayKind::contact: m.contact_bytes += bytes; break;
      case ArrayKind::other: m.other_bytes += bytes; break;
    }
  });
  m.total_bytes = m.particle_bytes + m.bond_bytes + m.mesh_bytes + m.contact_bytes + m.other_bytes;
  const std::size_t n = particle_count(), b = bond_count();
  m.bytes_per_particle = n ? double(m.particle_bytes) / double(n) : 0.0;
  m.bytes_per_bond = b ? double(m.bond_bytes) / double(b) : 0.0;
  return m;
}

Diagnostics World::diagnostics() const {
  Diagnostics d;
  const WorldState& w = *impl_->state;
  const auto& p = w.particles;
  const Vec3 g = w.settings.gravity;
  impl_->scheduler->execute([&] {
    const std::size_t n = p.count();
    d.kinetic_energy = deterministic_sum(n, 0.0, [&](std::size_t i) { return 0.5 * p.mass[i] * p.velocity[i].squaredNorm(); });
    d.gravity_energy = deterministic_sum(n, 0.0, [&](std::size_t i) { return -p.mass[i] * g.dot(p.position[i]); });
    d.linear_momentum = deterministic_sum(n, Vec3(Vec3::Zero()), [&](std::size_t i) { return Vec3(p.mass[i] * p.velocity[i]); });
    d.angular_momentum = deterministic_sum(n, Vec3(Vec3::Zero()), [&](std::size_t i) {
      return Vec3(p.mass[i] * p.position[i].cross(p.velocity[i]));
    });
    d.elastic_energy = systems::elastic_energy(w);
  });
  return d;
}

std::string World::schedule() const { return impl_->scheduler->describe(); }

// A distributed world profiles this rank's step graph (its local world and halo exchanges); a re-split
// builds a new graph, whose times add to the earlier ones'.
void World::set_profiling(bool on) {
  impl_->profiling = on;
  impl_->scheduler->set_profiling(on);
  if (impl_->runtime) impl_->runtime->scheduler().set_profiling(on);
}

std::vector<SystemTime> World::system_times() const {
  std::vector<SystemTime> out = impl_->earlier_times;
  const Scheduler& s = impl_->runtime ? impl_->runtime->scheduler() : *impl_->scheduler;
  for (const auto& t : s.profile()) {
    auto at = std::find_if(out.begin(), out.end(), [&](const SystemTime& e) { return e.name == t.name; });
    if (at == out.end()) out.push_back({t.name, t.seconds, t.runs, {}});
    else at->seconds += t.seconds, at->runs += t.runs;
  }
  return out;
}

std::vector<SystemTime> World::all_ranks_system_times() {
  std::vector<SystemTime> times = system_times();
  if (!impl_->runtime) return times;
  std::vector<double> mine;
  for (const auto& t : times) mine.push_back(t.seconds);
  const std::vector<double> all = impl_->runtime->gather_values(mine);
  const std::size_t ranks = static_cast<std::size_t>(this->ranks());
  if (all.size() == mine.size() * ranks)
    for (std::size_t k = 0; k < times.size(); ++k)
      for (std::size_t r = 0; r < ranks; ++r) times[k].rank_seconds.push_back(all[r * mine.size() + k]);
  return times;
}

std::vector<RankStats> World::rank_stats() {
  if (!impl_->runtime) {
    RankStats one;
    one.owned_particles = static_cast<std::uint32_t>(particle_count());
    one.steps = step_count();
    one.contact = contact_counters();
    return {one};
  }
  return impl_->runtime->gather_shares();
}

std::span<const Vec3> World::positions() const { return impl_->state->particles.position; }
std::span<const Vec3> World::reference_positions() const { return impl_->state->particles.reference_position; }
std::span<const Vec3> World::velocities() const { return impl_->state->particles.velocity; }
std::span<Vec3> World::velocities_mutable() { return impl_->state->particles.velocity; }

std::vector<FieldView> World::field_catalog() {
  std::vector<FieldView> out;
  for (const auto& entry : systems::step_fields()) out.push_back(entry.info);
  return out;
}

std::vector<FieldView> World::fields() const {
  std::vector<FieldView> out;
  for (const auto& entry : impl_->fields) out.push_back(field(entry.info.name));
  return out;
}

std::vector<std::string> World::field_names() const {
  std::vector<std::string> names;
  for (const auto& entry : impl_->fields) names.push_back(entry.info.name);
  return names;
}

FieldView World::field(std::string_view name) const {
  Impl& im = *impl_;
  for (std::size_t f = 0; f < im.fields.size(); ++f) {
    const auto& entry = im.fields[f];
    if (entry.info.name != name) continue;
    // A derived array is recomputed only when the state moved on since it was last computed; a plain
    // array is just pointed at.
    if (entry.derived && im.computed_at[f] == im.state->clock.step) return im.computed[f];
    FieldView view = entry.info;
    im.scheduler->execute([&] { entry.bind(*im.state, view); });
    if (entry.derived) im.computed_at[f] = im.state->clock.step, im.computed[f] = view;
    return view;
  }
  std::string known;
  for (const auto& entry : im.fields) known += (known.empty() ? "" : ", ") + entry.info.name;
  throw std::out_of_range("no field named '" + std::string(name) + "'; fields: " + known);
}

std::vector<BodyView> World::bodies() const {
  std::vector<BodyView> out;
  for (const auto& b : impl_->state->bodies)
    out.push_back({b.name, b.first_particle, b.particle_count, b.mean_edge_length, b.horizon});
  return out;
}

std::vector<ProjectileView> World::projectiles() const {
  std::vector<ProjectileView> out;
  for (const auto& p : impl_->state->projectiles.bodies)
    out.push_back({p.radius, p.mass, p.center, p.velocity, p.angular_velocity, p.contact_force});
  return out;
}

ContactCounters World::contact_counters() const {
  const auto& pairs = impl_->state->contact.pairs;
  return {pairs.builds, pairs.additions, pairs.partial_updates, pairs.searched};
}

bool World::has_embedded_mesh() const { return impl_->embedded_mesh || !impl_->state->embedded.tets.empty(); }

TetMeshView World::tet_mesh() const {
  WorldState& w = *impl_->state;
  if (w.settings.solver != scene::Solver::peridynamics)
    return {w.particles.position, w.mesh.tets, w.particles.reference_position};
  // The default vertex motion is evaluated on demand (systems/mesh_vertices.cpp).
  if (!w.embedded.tets.empty() && w.embedded.motion == VertexMotion::deformation)
    impl_->scheduler->execute([&] {
      if (w.any_fracture) systems::smooth_crack_faces(w, impl_->scene.output.smooth_cracks);
      systems::update_mesh_vertices(w, 0.0);
    });
  return {w.embedded.vertices, w.embedded.tets, w.embedded.reference_vertices};
}

TetMeshView World::reference_mesh() const {
  const WorldState& w = *impl_->state;
  return {w.mesh.vertices, w.mesh.tets, w.mesh.vertices};
}

std::vector<std::uint32_t> World::dust_particles() const {
  field("fragment_id");  // current in derived.fragment_id
  return systems::dust_particles(impl_->state->derived.fragment_id, impl_->scene.output.min_piece_tets);
}

SurfaceMesh World::surface() const {
  WorldState& w = *impl_->state;
  SurfaceMesh surface;
  if (w.embedded.tets.empty()) return surface;
  field("fragment_id");  // current in w.derived.fragment_id
  impl_->scheduler->execute([&] {
    if (w.any_fracture) systems::smooth_crack_faces(w, impl_->scene.output.smooth_cracks);
    systems::update_mesh_vertices(w, 0.0);  // dt = 0: vertices current without moving them again
    systems::extract_surface(w, &w.derived.fragment_id, surface, impl_->scene.output.min_piece_tets);
  });
  return surface;
}

namespace {
const char* solver_text(scene::Solver s) {
  switch (s) {
    case scene::Solver::peridynamics: return "peridynamics";
    case scene::Solver::fem_linear: return "fem_linear";
    case scene::Solver::fem_corotated: return "fem_corotated";
  }
  return "?";
}
}  // namespace

void World::save_checkpoint(const std::filesystem::path& file, const std::string& note) const {
  io::CheckpointHeader h;
  h.scene_text = impl_->scene.text;
  h.scene_hash = io::scene_hash(h.scene_text);
  h.solver = solver_text(impl_->scene.solver);
  h.note = note;
  io::write_checkpoint(file, *impl_->state, std::move(h));
}

std::string World::load_checkpoint(const std::filesystem::path& file) {
  // Before the header's counts are compared: a shell's are not known until it is distributed.
  if (impl_->shell && !impl_->runtime)
    throw std::logic_error("World::load_checkpoint: a shell loads a checkpoint only once distributed");
  const io::CheckpointHeader h = io::read_checkpoint_header(file);
  const std::string why =
      io::checkpoint_mismatch(h, impl_->scene.text, dt(), impl_->state->settings.contact.time_scale,
                              solver_text(impl_->scene.solver), particle_count(), bond_count());
  if (!why.empty())
    throw scene::SceneError(impl_->scene.source.string(), "", "cannot resume from checkpoint '" + file.string() + "': " + why);
  impl_->stable_dt = 0.0;
  impl_->stable_bound.reset();
  if (!impl_->runtime) {
    WorldState& w = state_mutable();
    io::read_checkpoint(file, w);
    // Written from a distributed run's whole world, whose contact buffers were released
    // (setup::release_contact_buffers): allocate them again; the list is built by the next step, with
    // the same forces (contact sums each particle's pairs in index order).
    if (w.contact.enabled && w.contact.pairs.offsets.empty()) systems::setup_contact(w, w.contact.largest_distance);
    return h.note;
  }
  // Rank 0 reads the whole world (the other ranks only the header) and splits it again from the
  // checkpoint's state; the others take its clock with their part.
  if (rank() == 0) io::read_checkpoint(file, state_mutable());
  impl_->runtime.reset();
  split(nullptr);
  return h.note;
}

const scene::Scene& World::scene() const { return impl_->scene; }
const WorldState& World::state() const { return *impl_->state; }
WorldState& World::state_mutable() {
  std::fill(impl_->computed_at.begin(), impl_->computed_at.end(), Impl::kStale);
  return *impl_->state;
}

}  // namespace perifx
