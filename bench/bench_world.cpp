// Whole-step and setup benchmarks.
#include <memory>
#include <optional>

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

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
    ->Args({998250, 2})  // c = 55: the "set-up at 1e6"
    ->Iterations(1)
    ->UseRealTime()
    ->Unit(benchmark::kSecond);

// The full elastic and inelastic steps on a 3e6-particle body (c = 79: 2,958,234 particles, about
// 4.5e8 directed bonds): nothing of it fits in a cache. One such world is kept at a time (each holds
// about 5 GB), rebuilt when the thread count or the kind changes; its set-up (about a minute) is
// outside the timing.
void BM_FullStepLarge(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(1));
  const bool inelastic = state.range(2) != 0;
  static std::unique_ptr<World> world;
  static std::pair<int, bool> built{0, false};
  if (!world || built != std::pair<int, bool>{threads, inelastic}) {
    world.reset();
    scene::Scene s = box_scene(cubes_for(state.range(0)), threads, bench_dt());
    if (inelastic) make_inelastic(s);
    world = std::make_unique<World>(s);
    deform(*world, threads);
    built = {threads, inelastic};
  }
  for (auto _ : state) {
    world->step();
    benchmark::ClobberMemory();
  }
  if (!all_finite(world->state().particles.position)) state.SkipWithError("non-finite positions after stepping");
  report(state, *world, threads, static_cast<double>(world->bond_count()));
  state.counters["inelastic"] = inelastic;
}
BENCHMARK(BM_FullStepLarge)
    ->ArgNames({"particles", "threads", "inelastic"})
    ->Args({2958234, 1, 0})
    ->Args({2958234, 2, 0})
    ->Args({2958234, 1, 1})
    ->Args({2958234, 2, 1})
    ->Iterations(5)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// STREAM-like memory bandwidth of the machine (McCalpin's triad a = b + s·c over three arrays of 2^25
// doubles, 768 MiB in all, far beyond any cache), on 1 and 2 threads: the ceiling the bond passes are
// compared against in bench/README.md. bytes_per_second counts 24 bytes per element (two reads, one
// write; write-allocate traffic not counted, as STREAM does).
void BM_StreamTriad(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  constexpr std::size_t kN = std::size_t{1} << 25;
  static std::vector<double> a(kN, 0.0), b(kN, 1.0), c(kN, 2.0);
  tbb::task_arena& team = arena(threads);
  const double scalar = 3.0;
  for (auto _ : state) {
    team.execute([&] {
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, kN, kN / 64), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i < r.end(); ++i) a[i] = b[i] + scalar * c[i];
      });
    });
    benchmark::DoNotOptimize(a.data());
    benchmark::ClobberMemory();
  }
  state.counters["bytes_per_second"] =
      benchmark::Counter(24.0 * double(kN) * double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["threads"] = threads;
}
BENCHMARK(BM_StreamTriad)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace perifx::bench
