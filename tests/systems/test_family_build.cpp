// Family build (systems/family_build.cpp): the bonds equal a plain reference construction of the
// rule, member for member, on a jittered body large enough that the Morton curve puts some members
// more than the fast sorter's window (±8192 indices) from their particle; and bonds never jump the gap
// between two bodies closer than the horizon.
#include <doctest/doctest.h>

#include <algorithm>
#include <queue>
#include <set>

#include "geometry/geometry.hpp"
#include "support.hpp"

using namespace perifx;

namespace {

// The mesh rule written the obvious way: a breadth-first search with a std::set, then the union of
// each list with its transpose, as sorted vectors. `one_sided` (when given) counts the pairs only one
// of the two searches found, the bonds the build merges into rows after their lists.
std::vector<std::vector<std::uint32_t>> reference_families(const WorldState& w, std::size_t* one_sided = nullptr) {
  const auto adjacency = geometry::face_neighbors(w.mesh);
  const auto& x = w.particles.reference_position;
  const std::size_t n = x.size();
  std::vector<std::set<std::uint32_t>> family(n), found(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double reach = w.model.horizon[i] * (1.0 + 1e-9);
    std::set<std::uint32_t> seen = {static_cast<std::uint32_t>(i)};
    std::queue<std::uint32_t> queue;
    queue.push(static_cast<std::uint32_t>(i));
    while (!queue.empty()) {
      const std::uint32_t q = queue.front();
      queue.pop();
      for (std::int32_t t : adjacency[q]) {
        if (t < 0 || !seen.insert(static_cast<std::uint32_t>(t)).second) continue;
        if ((x[t] - x[i]).norm() <= reach) {
          queue.push(static_cast<std::uint32_t>(t));
          family[i].insert(static_cast<std::uint32_t>(t));
          family[t].insert(static_cast<std::uint32_t>(i));
          found[i].insert(static_cast<std::uint32_t>(t));
        }
      }
    }
  }
  if (one_sided) {
    *one_sided = 0;
    for (std::size_t i = 0; i < n; ++i)
      for (std::uint32_t j : found[i]) *one_sided += found[j].count(static_cast<std::uint32_t>(i)) == 0;
  }
  std::vector<std::vector<std::uint32_t>> out(n);
  for (std::size_t i = 0; i < n; ++i) out[i].assign(family[i].begin(), family[i].end());
  return out;
}

std::vector<std::uint32_t> bonds_of(const WorldState& w, std::size_t i) {
  return {w.bonds.neighbor.begin() + w.bonds.offsets[i], w.bonds.neighbor.begin() + w.bonds.offsets[i + 1]};
}

}  // namespace

TEST_CASE("family build: the mesh rule's bonds equal a reference search, far members included") {
  // 0.48 × 0.24 × 0.08 m at 0.01 m cells: 55,296 particles, so a family can straddle the Morton
  // curve's large jumps (the test checks that it does).
  auto sc = test::box_scene(Vec3(0.48, 0.24, 0.08), 0.01, 1e6, 1e6);
  sc.bodies[0].geometry.jitter = 0.3;
  const World world(sc);
  const WorldState& w = world.state();
  std::size_t one_sided = 0;
  const auto reference = reference_families(w, &one_sided);
  std::size_t mismatched = 0, far = 0, bonds = 0;
  for (std::size_t i = 0; i < reference.size(); ++i) {
    const auto got = bonds_of(w, i);
    mismatched += got != reference[i];
    for (std::uint32_t j : got) far += (j > i ? j - i : i - j) > 8192, ++bonds;
  }
  INFO(bonds << " bonds, " << far << " with |j - i| > 8192, " << one_sided << " found by one side only");
  CHECK(mismatched == 0);
  CHECK(far > 0);                                  // the far path of the sorter was exercised
  CHECK(one_sided > 0);  // the in-place merge of the one-sided finds was exercised
  CHECK(w.bonds.initial_count[0] == reference[0].size());
}

TEST_CASE("family build: no bond crosses the gap between two bodies closer than the horizon") {
  // Two boxes 0.5 cell apart (horizon ≈ 1.45 cells): the mesh rule bonds within each box only.
  auto sc = test::box_scene(Vec3(0.1, 0.1, 0.1), 0.02, 1e6, 1e6);
  sc.bodies.push_back(sc.bodies[0]);
  sc.bodies[0].transform.translation = Vec3(-0.0525, 0, 0);
  sc.bodies[1].transform.translation = Vec3(0.0525, 0, 0);
  sc.bodies[1].name = "box2";
  const World world(sc);
  const WorldState& w = world.state();
  std::size_t crossing = 0, bonds = 0;
  for (std::size_t i = 0; i < w.particles.count(); ++i)
    for (std::uint32_t j : bonds_of(w, i)) crossing += w.particles.body_id[j] != w.particles.body_id[i], ++bonds;
  CHECK(bonds > 0);
  CHECK(crossing == 0);
  CHECK(reference_families(w) == [&] {
    std::vector<std::vector<std::uint32_t>> got(w.particles.count());
    for (std::size_t i = 0; i < got.size(); ++i) got[i] = bonds_of(w, i);
    return got;
  }());
}
