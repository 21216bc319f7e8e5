// Spatially varying strength (systems/strength_field.cpp, systems/README.md §12.4): region
// multipliers, seeded noise, weak planes.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>

#include "support.hpp"

using namespace perifx;

namespace {

constexpr double kKappa = 5.0e5, kMu = 3.0e5;
const Vec3 kBar(0.06, 0.012, 0.012);

// A bar along x pulled apart by its end slabs at ±v (ramped over 2 ms), breakable.
scene::Scene pulled_bar(double cell = 0.003) {
  auto sc = test::box_scene(kBar, cell, kKappa, kMu);
  sc.materials[0].critical_stretch = 0.02;
  sc.time.dt = 5e-5;
  for (int side : {-1, 1}) {
    scene::BoundaryCondition bc;
    bc.kind = scene::BoundaryCondition::Kind::velocity;
    bc.region.kind = scene::Region::Kind::halfspace;
    bc.region.point = Vec3(side * (0.5 * kBar.x() - cell), 0, 0);
    bc.region.normal = Vec3(side, 0, 0);
    bc.velocity = Vec3(side * 0.05, 0, 0);
    bc.window = {0.0, 0.002, kInfinity};
    sc.boundary_conditions.push_back(bc);
  }
  return sc;
}

std::size_t broken(const World& w) { return w.bond_count() - w.alive_bond_count(); }

}  // namespace

TEST_CASE("strength: region factors multiply s_c of the particles they hold; noise is seeded and bounded") {
  auto sc = pulled_bar();
  scene::StrengthRegion half;
  half.region.kind = scene::Region::Kind::halfspace;
  half.region.point = Vec3::Zero();
  half.region.normal = Vec3::UnitX();
  half.factor = 0.5;
  sc.materials[0].strength.regions.push_back(half);
  World world(sc);
  const auto& md = world.state().model;
  const auto x = world.reference_positions();
  for (std::size_t i = 0; i < x.size(); ++i)
    CHECK(md.critical_stretch[i] == (x[i].x() >= 0.0 ? 0.02 * 0.5 : 0.02));

  auto noisy = pulled_bar();
  noisy.materials[0].strength.noise_amplitude = 0.4;
  noisy.materials[0].strength.noise_feature_size = 0.01;
  noisy.materials[0].strength.noise_seed = 7;
  World a(noisy);
  noisy.threads = 1;
  World b(noisy);
  noisy.materials[0].strength.noise_seed = 8;
  World c(noisy);
  const auto& sa = a.state().model.critical_stretch;
  CHECK(sa == b.state().model.critical_stretch);  // same seed, other thread count: same bits
  CHECK(sa != c.state().model.critical_stretch);
  const auto [lo, hi] = std::minmax_element(sa.begin(), sa.end());
  CHECK(*lo >= 0.02 * 0.6);
  CHECK(*hi <= 0.02 * 1.4);
  CHECK(*hi - *lo > 0.02 * 0.2);  // it does vary
  for (double t = -3; t <= 3; t += 0.37) {
    const double v = systems::strength_noise(Vec3(t, 0.3 * t, -t), 0.5, 3);
    CHECK(v >= -1.0);
    CHECK(v <= 1.0);
  }
}

TEST_CASE("strength: a weak plane at 50% sets the crossing bonds' break scale and the bar breaks there") {
  const double plane_x = 0.015;  // a quarter of the way along, away from the middle
  auto sc = pulled_bar();
  scene::WeakPlane wp;
  wp.polygon = {Vec3(plane_x, -1, -1), Vec3(plane_x, 1, -1), Vec3(plane_x, 1, 1), Vec3(plane_x, -1, 1)};
  wp.factor = 0.5;
  sc.materials[0].strength.weak_planes.push_back(wp);
  World world(sc);
  const WorldState& w = world.state();
  const auto x = world.reference_positions();
  std::size_t crossing = 0;
  for (std::size_t i = 0; i < x.size(); ++i)
    for (std::uint32_t k = w.bonds.offsets[i]; k < w.bonds.offsets[i + 1]; ++k) {
      const auto j = w.bonds.neighbor[k];
      const bool crosses = (x[i].x() - plane_x) * (x[j].x() - plane_x) < 0.0;
      CHECK(w.bonds.break_scale[k] == (crosses ? 0.5f : 1.0f));
      crossing += crosses;
    }
  CHECK(crossing > 0);

  world.step(400);  // 20 ms: far-field strain ~3 %, past 50 % of the break strain, not past 100 %
  REQUIRE(broken(world) > 0);
  std::size_t at_plane = 0;
  for (std::size_t i = 0; i < x.size(); ++i)
    for (std::uint32_t k = w.bonds.offsets[i]; k < w.bonds.offsets[i + 1]; ++k)
      if (!w.bonds.alive[k]) at_plane += (x[i].x() - plane_x) * (x[w.bonds.neighbor[k]].x() - plane_x) < 0.0;
  MESSAGE("broken bonds " << broken(world) << ", of them crossing the weak plane " << at_plane);
  CHECK(at_plane >= 0.9 * double(broken(world)));
  std::vector<std::uint32_t> ids;
  CHECK(systems::compute_fragments(w, ids) >= 2);
  std::uint32_t left = ids[0], right = ids[0];
  for (std::size_t i = 0; i < x.size(); ++i) (x[i].x() < plane_x ? left : right) = ids[i];
  for (std::size_t i = 0; i < x.size(); ++i)  // every particle on its side's piece: the cut is the plane
    if (std::abs(x[i].x() - plane_x) > 0.006) CHECK(ids[i] == (x[i].x() < plane_x ? left : right));
  CHECK(left != right);
}

TEST_CASE("strength: seeded noise: the same seed gives the same bits, other seeds other fragment patterns") {
  auto run = [](std::uint64_t seed, int threads) {
    auto sc = pulled_bar();
    sc.threads = threads;
    sc.materials[0].strength.noise_amplitude = 0.5;
    sc.materials[0].strength.noise_feature_size = 0.008;
    sc.materials[0].strength.noise_seed = seed;
    World world(sc);
    world.step(500);
    return std::make_pair(std::vector<std::uint8_t>(world.state().bonds.alive),
                          std::vector<Vec3>(world.positions().begin(), world.positions().end()));
  };
  const auto a1 = run(11, 1), a2 = run(11, 2), b = run(12, 2), c = run(13, 2);
  CHECK(a1.first == a2.first);
  CHECK(a1.second == a2.second);  // bit for bit
  CHECK(a1.first != b.first);
  CHECK(b.first != c.first);
  CHECK(std::count(a1.first.begin(), a1.first.end(), 0) > 0);
}
