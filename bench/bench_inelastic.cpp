// Full step with every inelastic system active (issue "Elastoplasticity, anisotropy, fracture and
// contact"): plasticity (Eq 11–16), the fracture check (Eq 18–19) and damage on every bond, and
// particle–particle contact, on the same bodies as BM_FullStep. The material yields (Ψ0 finite, small
// enough that deviatoric bonds of the 1e-3 pre-stretch are on the yield surface) and is breakable
// (s_c finite but far above the imposed stretch, so the check runs on every bond and nothing breaks:
// the topology, and so the work per step, stays fixed while timing).
#include "bench_support.hpp"

namespace perifx::bench {
namespace {

World& inelastic_world(std::int64_t particles, int threads) {
  static std::map<std::pair<std::int64_t, int>, std::unique_ptr<World>> worlds;
  auto& slot = worlds[{particles, threads}];
  if (!slot) {
    scene::Scene s = box_scene(cubes_for(particles), threads, bench_dt());
    s.materials[0].yield_energy = 1e20;
    s.materials[0].plastic_cap_ratio = 0.2;
    s.materials[0].critical_stretch = 0.05;
    s.contact.mode = scene::Contact::Mode::on;
    slot = std::make_unique<World>(s);
    deform(*slot, threads);
  }
  return *slot;
}

void BM_FullStepInelastic(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(1));
  World& world = inelastic_world(state.range(0), threads);
  for (auto _ : state) {
    world.step();
    benchmark::ClobberMemory();
  }
  if (!all_finite(world.state().particles.position)) state.SkipWithError("non-finite positions after stepping");
  if (world.alive_bond_count() != world.bond_count()) state.SkipWithError("bonds broke: the timed work changed");
  report(state, world, threads, static_cast<double>(world.bond_count()));
  state.counters["steps_per_second"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_FullStepInelastic)->Apply(sizes_and_threads);

}  // namespace
}  // namespace perifx::bench
