// Whole-step and setup benchmarks.
#include <optional>

#include "bench_support.hpp"

namespace perifx::bench {
namespace {

// World::step(): the full TBB flow graph (kick_begin → boundary_conditions → drift → colliders →
// dilatation → elastic_force, external_loads, → kick_end) on the world's own arena. A step touches
// every directed bond twice (dilatation and force passes); bond_updates_per_second counts each
// directed bond once per step, the definition (floor: ≥ 5e7/s per core at 3e5 particles).
void BM_FullStep(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(1));
  World& world = world_for(state.range(0), threads);
  if (world.threads() != threads) {
    state.SkipWithError("world has a different thread count than requested");
    return;
  }
  for (auto _ : state) {
    world.step();
    benchmark::ClobberMemory();
  }
  if (!all_finite(world.state().particles.position)) state.SkipWithError("non-finite positions after stepping");
  report(state, world, threads, static_cast<double>(world.bond_count()));
  state.counters["steps_per_second"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_FullStep)->Apply(sizes_and_threads);

// World construction at ~1e5 particles: meshing, Morton order, face adjacency, family build (mesh
// rule), model constants and the initial force evaluation. The destructor is not timed.
void BM_Setup(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(1));
  const scene::Scene scene = box_scene(cubes_for(state.range(0)), threads, 1e-7);
  double particles = 0.0, bonds = 0.0;
  for (auto _ : state) {
    std::optional<World> world;
    world.emplace(scene);
    state.PauseTiming();
    particles = static_cast<double>(world->particle_count());
    bonds = static_cast<double>(world->bond_count());
    world.reset();
    state.ResumeTiming();
  }
  state.counters["particles"] = particles;
  state.counters["bonds_per_particle"] = bonds / particles;
  state.counters["threads"] = threads;
  state.counters["particles_per_second"] =
      benchmark::Counter(particles * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Setup)
    ->ArgNames({"particles", "threads"})
    ->Args({105456, 1})
    ->Args({105456, 2})
    ->Iterations(1)
    ->UseRealTime()
    ->Unit(benchmark::kSecond);

}  // namespace
}  // namespace perifx::bench
