// Spatial hash grid (systems/spatial_grid.hpp): the neighbourhood visits against brute force.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include "systems/spatial_grid.hpp"

using namespace perifx;

TEST_CASE("spatial grid: the forward half-neighbourhood visits every pair within reach exactly once") {
  // Points in a small box (so many share cells, and cells hash onto each other in a small table),
  // with a tight cluster and far outliers. A search of every point over its forward half must visit
  // each pair closer than the reach once, from one end: the contact list's full rebuild relies on it.
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> u(-0.05, 0.05);
  std::vector<Vec3> points;
  for (int i = 0; i < 1500; ++i) points.emplace_back(u(rng), u(rng), u(rng));
  for (int i = 0; i < 100; ++i) points.emplace_back(1e-3 * u(rng), 1e-3 * u(rng), 1e-3 * u(rng));
  points.emplace_back(40.0, -3.0, 7.0);
  points.emplace_back(40.001, -3.0, 7.0);
  const double reach = 0.013;
  SpatialGrid g;
  systems::allocate_grid(g, points.size(), reach);
  systems::build_grid(g, points);

  std::vector<std::pair<std::uint32_t, std::uint32_t>> forward, full, brute;
  for (std::uint32_t i = 0; i < points.size(); ++i) {
    systems::for_each_near_forward(g, points[i], i, [&](std::uint32_t q) {
      const std::uint32_t j = g.sorted[q];
      CHECK(j != i);
      if ((points[j] - points[i]).squaredNorm() < reach * reach) forward.emplace_back(std::min(i, j), std::max(i, j));
    });
    systems::for_each_near(g, points[i], [&](std::uint32_t q) {
      const std::uint32_t j = g.sorted[q];
      if (j > i && (points[j] - points[i]).squaredNorm() < reach * reach) full.emplace_back(i, j);
    });
    for (std::uint32_t j = i + 1; j < points.size(); ++j)
      if ((points[j] - points[i]).squaredNorm() < reach * reach) brute.emplace_back(i, j);
  }
  std::sort(forward.begin(), forward.end());
  std::sort(full.begin(), full.end());
  CHECK(brute.size() > 2000);  // the test exercises many pairs
  CHECK(std::adjacent_find(forward.begin(), forward.end()) == forward.end());  // none twice
  CHECK(forward == brute);
  CHECK(full == brute);
}

TEST_CASE("spatial grid: the within-radius visits are the neighbourhood visits filtered by distance, in the same order") {
  // for_each_within(_forward) test the distance of a chunk of slots without branches and visit the
  // passing ones afterwards (the contact search's inner loop). They must visit exactly the slots the
  // plain visit yields that lie within the radius, in the same order (the contact list's order, and so
  // its bits, depends on it), including a NaN point, which passes as the callers' tests let it.
  std::mt19937_64 rng(777);
  std::uniform_real_distribution<double> u(-0.04, 0.04);
  std::vector<Vec3> points;
  for (int i = 0; i < 3000; ++i) points.emplace_back(u(rng), u(rng), u(rng));
  for (int i = 0; i < 200; ++i) points.emplace_back(0.01 * u(rng), 0.01 * u(rng), 0.01 * u(rng));  // > 64 slots a cell
  points.emplace_back(std::nan(""), 0.0, 0.0);
  const double reach = 0.011, r2 = reach * reach;
  SpatialGrid g;
  systems::allocate_grid(g, points.size(), reach);
  systems::build_grid(g, points);
  std::size_t visits = 0;
  for (std::uint32_t i = 0; i < points.size(); ++i) {
    std::vector<std::uint32_t> plain, within, plain_forward, within_forward;
    systems::for_each_near(g, points[i], [&](std::uint32_t q) {
      if (!((g.sorted_position[q] - points[i]).squaredNorm() >= r2)) plain.push_back(q);
    });
    systems::for_each_within(g, points[i], r2, [&](std::uint32_t q) { within.push_back(q); });
    systems::for_each_near_forward(g, points[i], i, [&](std::uint32_t q) {
      if (!((g.sorted_position[q] - points[i]).squaredNorm() >= r2)) plain_forward.push_back(q);
    });
    systems::for_each_within_forward(g, points[i], i, r2, [&](std::uint32_t q) { within_forward.push_back(q); });
    CHECK(within == plain);
    CHECK(within_forward == plain_forward);
    visits += within.size();
  }
  CHECK(visits > 30000);  // about 20 points within reach of each
}

TEST_CASE("spatial grid: a grid of a subset finds exactly the subset's points within reach, by their own index") {
  // build_grid_of (the contact update's grid of the particles searched since the search grid was
  // built): a subset of every third point, in a grid allocated for fewer points than the whole set (so
  // its table is sized for the subset, not for the allocation), built twice with subsets of different
  // sizes: every query must find exactly the subset's points within the reach, named by their index in
  // the whole set, each once.
  std::mt19937_64 rng(4242);
  std::uniform_real_distribution<double> u(-0.05, 0.05);
  std::vector<Vec3> points;
  for (int i = 0; i < 6000; ++i) points.emplace_back(u(rng), u(rng), u(rng));
  const double reach = 0.012, r2 = reach * reach;
  SpatialGrid g;
  systems::allocate_grid(g, 2100, reach);
  for (const std::uint32_t stride : {3u, 7u}) {
    std::vector<std::uint32_t> subset;
    for (std::uint32_t i = stride / 2; i < points.size(); i += stride) subset.push_back(i);
    systems::build_grid_of(g, points, subset);
    CHECK(g.mask + 1 >= 2 * subset.size());
    CHECK(g.start[g.mask + 1] == subset.size());  // every entry is in some bucket
    std::size_t found = 0, wrong = 0;
    for (std::uint32_t i = 0; i < points.size(); i += 5) {
      std::vector<std::uint32_t> grid_hits, brute;
      systems::for_each_within(g, points[i], r2, [&](std::uint32_t q) {
        grid_hits.push_back(g.sorted[q]);
        wrong += (g.sorted_position[q].array() != points[g.sorted[q]].array()).any();
      });
      for (const std::uint32_t j : subset)
        if ((points[j] - points[i]).squaredNorm() < r2) brute.push_back(j);
      std::sort(grid_hits.begin(), grid_hits.end());
      CHECK(grid_hits == brute);
      found += brute.size();
    }
    CHECK(wrong == 0);
    CHECK(found > 1000);  // the queries find many points
  }
}
