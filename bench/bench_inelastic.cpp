// Full step with every inelastic system active (issue "Elastoplasticity, anisotropy, fracture and
// contact"): plasticity (Eq 11–16), the fracture check (Eq 18–19) and damage on every bond, and
// particle–particle contact, on the same bodies as BM_FullStep. The material yields (Ψ0 finite, small
// enough that deviatoric bonds of the 1e-3 pre-stretch are on the yield surface) and is breakable
// (s_c finite but far above the imposed stretch, so the check runs on every bond and nothing breaks:
// the topology, and so the work per step, stays fixed while timing).
#include <algorithm>
#include <tuple>

#include "bench_support.hpp"

namespace perifx::bench {
namespace {

// The inelastic body, cached per size and thread count; `anisotropic` gives it a material with G = 2
// along a tilted axis (Eq 17), whose rows take the anisotropic form of the bond kernels.
World& inelastic_world(std::int64_t particles, int threads, bool anisotropic = false) {
  static std::map<std::tuple<std::int64_t, int, bool>, std::unique_ptr<World>> worlds;
  auto& slot = worlds[{particles, threads, anisotropic}];
  if (!slot) {
    scene::Scene s = box_scene(cubes_for(particles), threads, bench_dt());
    make_inelastic(s);
    if (anisotropic) {
      const Vec3 a = Vec3(1.0, 1.0, 0.5).normalized();
      s.materials[0].anisotropy = 2.0 * a * a.transpose() + (Mat3::Identity() - a * a.transpose());
    }
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

// The fused bond pass alone (plasticity both sides, force, fracture test, damage: bond_pass.cpp) on
// the inelastic body's current positions, one pass over all directed bonds per iteration.
void time_bond_pass(benchmark::State& state, World& world, int threads) {
  WorldState& w = world.state_mutable();
  auto& a = arena(threads);
  for (auto _ : state) {
    a.execute([&] { systems::run_bond_pass(w, w.particles.position, w.state.internal_force); });
    benchmark::DoNotOptimize(w.state.internal_force.data());
    benchmark::ClobberMemory();
  }
  if (!all_finite(w.state.internal_force)) state.SkipWithError("non-finite internal force");
  if (world.alive_bond_count() != world.bond_count()) state.SkipWithError("bonds broke: the timed work changed");
  report(state, world, threads, static_cast<double>(world.bond_count()));
}
void BM_BondPass(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(1));
  time_bond_pass(state, inelastic_world(state.range(0), threads), threads);
}
BENCHMARK(BM_BondPass)->Apply(sizes_and_threads);

// The same on the anisotropic body: the cost of anisotropy beside BM_BondPass. form:1 is the shipped
// marking (one material, so every row is RowForm::shared_metric: one weighted length per bond);
// form:0 forces the general form (ℓ_ij and ℓ_ji each from its particle's metric, the far metric
// gathered), which a row at a boundary between two anisotropic materials takes. Both give the same
// bits (test_anisotropy.cpp).
void BM_BondPassAnisotropic(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(1));
  World& world = inelastic_world(state.range(0), threads, true);
  auto& family = world.state_mutable().model.anisotropic_family;
  const auto form = state.range(2) ? RowForm::shared_metric : RowForm::anisotropic;
  std::fill(family.begin(), family.end(), static_cast<std::uint8_t>(form));
  time_bond_pass(state, world, threads);
}
BENCHMARK(BM_BondPassAnisotropic)->Apply([](benchmark::internal::Benchmark* b) {
  b->ArgNames({"particles", "threads", "form"});
  for (int cubes : {12, 37})
    for (int threads : {1, 2})
      for (int form : {0, 1}) b->Args({6LL * cubes * cubes * cubes, threads, form});
  b->UseRealTime();
  b->Unit(benchmark::kMillisecond);
});

// The two bond kernels of a step (dilatation, then the fused bond pass) on a brittle 3e5 body (the
// inelastic body without plasticity: breakable, contact on, as the glass scenes) broken into cubic
// fragments: every bond crossing a plane x, y or z = multiple of `fragment` cells
// is broken (both directions), as a shattered body keeps its broken bonds in the rows. fragment:0 is
// the intact body. The rate counts every directed bond, broken or not, per iteration (the step's
// definition), so a kernel that skips broken bonds reads faster than the intact body;
// `broken_fraction` says how many of them are broken. What it measures: how much of a shattered
// body's broken bonds the kernels' dead-chunk skip (bond_rules.hpp, DeadChunks) saves.
World& shattered_world(int fragment, int threads) {
  static std::map<std::pair<int, int>, std::unique_ptr<World>> worlds;
  auto& slot = worlds[{fragment, threads}];
  if (!slot) {
    scene::Scene s = box_scene(cubes_for(303918), threads, bench_dt());
    make_inelastic(s);
    s.materials[0].yield_energy = kInfinity;  // brittle: no plasticity (no e^p arrays)
    slot = std::make_unique<World>(s);
    deform(*slot, threads);
    if (fragment > 0) {
      WorldState& w = slot->state_mutable();
      const double size = fragment * kCell;
      const auto cell = [&](std::size_t i) {
        const Vec3& x = w.particles.reference_position[i];
        return Eigen::Vector3i(int(std::floor(x.x() / size)), int(std::floor(x.y() / size)), int(std::floor(x.z() / size)));
      };
      for (std::size_t i = 0; i < w.particles.count(); ++i) {
        const Eigen::Vector3i own = cell(i);
        for (std::uint32_t k = w.bonds.offsets[i]; k < w.bonds.offsets[i + 1]; ++k)
          if (own != cell(w.bonds.neighbor[k])) w.bonds.alive[k] = 0;
      }
    }
  }
  return *slot;
}
void BM_ShatteredBondKernels(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(1));
  World& world = shattered_world(static_cast<int>(state.range(0)), threads);
  WorldState& w = world.state_mutable();
  auto& a = arena(threads);
  const std::size_t alive = world.alive_bond_count();
  for (auto _ : state) {
    a.execute([&] {
      systems::compute_dilatation(w, w.particles.position, w.state.dilatation, w.state.dilatation_coupling);
      systems::run_bond_pass(w, w.particles.position, w.state.internal_force);
    });
    benchmark::DoNotOptimize(w.state.internal_force.data());
    benchmark::ClobberMemory();
  }
  if (!all_finite(w.state.internal_force)) state.SkipWithError("non-finite internal force");
  if (world.alive_bond_count() != alive) state.SkipWithError("bonds broke: the timed work changed");
  report(state, world, threads, static_cast<double>(world.bond_count()));
  state.counters["broken_fraction"] = 1.0 - static_cast<double>(alive) / static_cast<double>(world.bond_count());
}
BENCHMARK(BM_ShatteredBondKernels)
    ->ArgNames({"fragment", "threads"})
    ->Args({0, 1})
    ->Args({8, 1})
    ->Args({4, 1})
    ->Args({2, 1})
    ->Args({2, 2})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// Particle–particle contact alone (contact.cpp) on the intact inelastic body, step-equivalent rate
// (the body's bonds per iteration), to compare with the bond kernels.
//   BM_Contact:        a step whose pair list is still valid (the common case: an O(n) staleness
//                      check, and an empty list for an intact body);
//   BM_ContactRebuild: the list rebuilt every iteration, as in a step after bonds broke (grid, count
//                      and fill passes: every particle searches its 27 cells).
void contact_benchmark(benchmark::State& state, bool rebuild) {
  const int threads = static_cast<int>(state.range(1));
  World& world = inelastic_world(state.range(0), threads);
  WorldState& w = world.state_mutable();
  const SystemDecl contact = systems::contact_system(w);
  auto& a = arena(threads);
  for (auto _ : state) {
    if (rebuild) w.contact.pairs.valid = false;
    a.execute([&] { contact.run(); });
    benchmark::DoNotOptimize(w.state.contact_force.data());
    benchmark::ClobberMemory();
  }
  if (!all_finite(w.state.contact_force)) state.SkipWithError("non-finite contact force");
  report(state, world, threads, static_cast<double>(world.bond_count()));
}
void BM_Contact(benchmark::State& state) { contact_benchmark(state, false); }
void BM_ContactRebuild(benchmark::State& state) { contact_benchmark(state, true); }
BENCHMARK(BM_Contact)->Apply(sizes_and_threads);
BENCHMARK(BM_ContactRebuild)->Apply(sizes_and_threads);

}  // namespace
}  // namespace perifx::bench
