// Per-system benchmarks: the bond kernels (dilatation, elastic force) and the integration systems,
// each called directly on a cached, deformed world inside a task arena of the benchmark's thread count.
#include "bench_support.hpp"

namespace perifx::bench {
namespace {

// θ and P for every particle (Eq 6): one pass over all directed bonds, outputs into the world's
// dilatation arrays, as the dilatation system does.
void BM_Dilatation(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(1));
  World& world = world_for(state.range(0), threads);
  WorldState& w = world.state_mutable();
  auto& a = arena(threads);
  for (auto _ : state) {
    a.execute([&] {
      systems::compute_dilatation(w, w.particles.position, w.state.dilatation, w.state.dilatation_coupling);
    });
    benchmark::DoNotOptimize(w.state.dilatation.data());
    benchmark::ClobberMemory();
  }
  report(state, world, threads, static_cast<double>(world.bond_count()));
}
BENCHMARK(BM_Dilatation)->Apply(sizes_and_threads);

// Internal force for every particle (Eq 2–4, 8, paired): one pass over all directed bonds, reading
// the P computed by the dilatation pass, outputs into the world's internal_force array.
void BM_ElasticForce(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(1));
  World& world = world_for(state.range(0), threads);
  WorldState& w = world.state_mutable();
  auto& a = arena(threads);
  for (auto _ : state) {
    a.execute([&] {
      systems::compute_internal_force(w, w.particles.position, w.state.dilatation_coupling, w.state.internal_force);
    });
    benchmark::DoNotOptimize(w.state.internal_force.data());
    benchmark::ClobberMemory();
  }
  if (!all_finite(w.state.internal_force)) state.SkipWithError("non-finite internal force");
  report(state, world, threads, static_cast<double>(world.bond_count()));
}
BENCHMARK(BM_ElasticForce)->Apply(sizes_and_threads);

// The velocity Verlet systems of one step (kick_begin, drift, kick_end), run through their own
// SystemDecl::run. They touch no bonds; the bond-update rate is the step-equivalent one (bonds of the
// body per iteration), to compare with the kernels, and particles_per_second is their own rate.
// Positions, velocities and accelerations are restored afterwards (outside the timing): without a
// force update in between, the drift would otherwise leave the cached world far from equilibrium.
void BM_Integration(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(1));
  World& world = world_for(state.range(0), threads);
  WorldState& w = world.state_mutable();
  auto& p = w.particles;
  const auto saved_position = p.position, saved_velocity = p.velocity, saved_acceleration = p.acceleration;
  const SystemDecl kick_begin = systems::kick_begin_system(w);
  const SystemDecl drift = systems::drift_system(w);
  const SystemDecl kick_end = systems::kick_end_system(w);
  auto& a = arena(threads);
  for (auto _ : state) {
    a.execute([&] {
      kick_begin.run();
      drift.run();
      kick_end.run();
    });
    benchmark::DoNotOptimize(p.position.data());
    benchmark::ClobberMemory();
  }
  p.position = saved_position;
  p.velocity = saved_velocity;
  p.acceleration = saved_acceleration;
  report(state, world, threads, static_cast<double>(world.bond_count()));
  state.counters["particles_per_second"] = benchmark::Counter(
      static_cast<double>(world.particle_count()) * static_cast<double>(state.iterations()),
      benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Integration)->Apply(sizes_and_threads);

}  // namespace
}  // namespace perifx::bench
