// Shared fixtures for the perifx benchmark suite (see bench/README.md).
//
// Bodies are boxes of c×c×c cubes meshed by the structured mesher (6 tets per cube, one particle per
// tet), with the default horizon δ = 1.45 λ. A benchmark argument `particles` is 6·c³:
//   10368 (c = 12), 105456 (c = 26), 303918 (c = 37).
// Worlds are built once per (size, threads) and cached for the whole run: setup of the 3e5 body takes
// seconds and must never run inside a timing loop. Each cached world is given a small non-trivial
// deformation so the force is non-zero (see deform()).
#pragma once
#include <benchmark/benchmark.h>
#include <oneapi/tbb/task_arena.h>

#include <cmath>
#include <cstdint>
#include <map>
#include <memory>
#include <utility>
#include <vector>

#include "perifx/world.hpp"
#include "systems/systems.hpp"
#include "components/world_state.hpp"

namespace perifx::bench {

inline constexpr double kCell = 0.01;  // cube edge, m (λ of the tet mesh is a fixed multiple of it)

// Cubes per side of the body with 6·c³ particles (the benchmark's `particles` argument).
inline int cubes_for(std::int64_t particles) {
  return static_cast<int>(std::lround(std::cbrt(static_cast<double>(particles) / 6.0)));
}

// One steel-like box body, no gravity, no boundary conditions, no output. Elastic only (no yield,
// no fracture, isotropic): the step graph is kick_begin, boundary_conditions, drift, colliders,
// dilatation, elastic_force, external_loads, kick_end.
inline scene::Scene box_scene(int cubes, int threads, double dt) {
  scene::Scene s;
  s.name = "bench_box";
  s.source = "<memory>";
  s.gravity = Vec3::Zero();
  s.threads = threads;
  s.time.dt = dt;
  scene::Material m;
  m.name = "steel";
  m.density = 7850.0;
  m.bulk_modulus = 160e9;
  m.shear_modulus = 80e9;
  s.materials.push_back(m);
  scene::Body b;
  b.name = "box";
  b.material = 0;
  b.geometry.kind = scene::Geometry::Kind::box;
  b.geometry.size = Vec3::Constant(cubes * kCell);
  b.geometry.edge_length = kCell;
  s.bodies.push_back(b);  // horizon_factor stays at its default 1.45
  return s;
}

// Half the stable step of this material and cell size, from the library's own estimate on a small
// body (the limit is local, so it does not depend on the body's size). Keeps long full-step runs
// bounded; the timing itself does not depend on dt.
inline double bench_dt() {
  static const double dt = [] {
    const World probe(box_scene(6, 0, 1e-7));
    return 0.5 * probe.stable_time_step();
  }();
  return dt;
}

// A task arena of `threads` slots, for calling kernels outside World::step() with the same
// concurrency a world with scene.threads = threads would use.
inline tbb::task_arena& arena(int threads) {
  static std::map<int, std::unique_ptr<tbb::task_arena>> arenas;
  auto& a = arenas[threads];
  if (!a) {
    a = std::make_unique<tbb::task_arena>(threads);
    a->initialize();
  }
  return *a;
}

// Positions y = (1 + 1e-3)·x + 2e-4·(x_y, x_z, x_x) (a stretch plus a shear, so both the dilatational
// and the deviatoric parts of the force are non-zero), a small smooth velocity field, and the
// dilatation, force and acceleration made consistent with them (what the first kick of the step uses).
inline void deform(World& world, int threads) {
  WorldState& w = world.state_mutable();
  auto& p = w.particles;
  const std::size_t n = p.count();
  double extent = 0.0;
  for (const Vec3& x : p.reference_position) extent = std::max(extent, x.cwiseAbs().maxCoeff());
  const double k = kPi / std::max(extent, 1e-300);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3& x = p.reference_position[i];
    p.position[i] = (1.0 + 1e-3) * x + 2e-4 * Vec3(x.y(), x.z(), x.x());
    p.velocity[i] = 0.05 * Vec3(std::sin(k * x.y()), std::sin(k * x.z()), std::sin(k * x.x()));
  }
  arena(threads).execute([&] {
    systems::compute_dilatation(w, p.position, w.state.dilatation, w.state.dilatation_coupling);
    systems::compute_internal_force(w, p.position, w.state.dilatation_coupling, w.state.internal_force);
  });
  for (std::size_t i = 0; i < n; ++i)
    p.acceleration[i] = (w.state.internal_force[i] + w.state.external_force[i]) / p.mass[i];
}

// Every inelastic system on (BM_FullStepInelastic, BM_FullStepLarge): the material yields (Ψ0 finite,
// small enough that deviatoric bonds of the 1e-3 pre-stretch are on the yield surface) and is breakable
// (s_c far above the imposed stretch: the check runs on every bond and nothing breaks), with contact.
inline void make_inelastic(scene::Scene& s) {
  s.materials[0].yield_energy = 1e20;
  s.materials[0].plastic_cap_ratio = 0.2;
  s.materials[0].critical_stretch = 0.05;
  s.contact.mode = scene::Contact::Mode::on;
}

// The cached, deformed world with 6·c³ particles and `threads` threads.
inline World& world_for(std::int64_t particles, int threads) {
  static std::map<std::pair<int, int>, std::unique_ptr<World>> worlds;
  const int cubes = cubes_for(particles);
  auto& slot = worlds[{cubes, threads}];
  if (!slot) {
    slot = std::make_unique<World>(box_scene(cubes, threads, bench_dt()));
    deform(*slot, threads);
  }
  return *slot;
}

inline bool all_finite(const std::vector<Vec3>& v) {
  for (const Vec3& a : v)
    if (!a.allFinite()) return false;
  return true;
}

// The suite's counters. `bonds_per_iteration` directed bonds are processed once per iteration.
inline void report(benchmark::State& state, const World& world, int threads, double bonds_per_iteration) {
  using benchmark::Counter;
  const double updates = bonds_per_iteration * static_cast<double>(state.iterations());
  const double particles = static_cast<double>(world.particle_count());
  state.counters["bond_updates_per_second"] = Counter(updates, Counter::kIsRate);
  state.counters["per_core"] = Counter(updates / threads, Counter::kIsRate);
  state.counters["bonds_per_particle"] = static_cast<double>(world.bond_count()) / particles;
  state.counters["particles"] = particles;
  state.counters["threads"] = threads;
}

// Arguments {particles, threads} for every size and thread count; wall-clock time (the work runs on
// TBB threads, so the main thread's CPU time would under-count it).
inline void sizes_and_threads(benchmark::internal::Benchmark* b) {
  b->ArgNames({"particles", "threads"});
  for (int cubes : {12, 26, 37})
    for (int threads : {1, 2}) b->Args({6LL * cubes * cubes * cubes, threads});
  b->UseRealTime();
  b->Unit(benchmark::kMillisecond);
}

}  // namespace perifx::bench
