// Pieces (systems/fragments.cpp): stable piece ids. A piece that splits keeps its id on its largest
// part, the other parts get ids never used before; 1 and 2 threads give the same ids.
#include <doctest/doctest.h>

#include <algorithm>
#include <map>
#include <set>

#include "support.hpp"

using namespace perifx;

namespace {

constexpr double kKappa = 5.0e5, kMu = 3.0e5;

// Breaks every bond crossing the plane x = cut.
void cut_at(WorldState& w, double cut) {
  Bonds& b = w.bonds;
  const auto& x = w.particles.reference_position;
  for (std::uint32_t i = 0; i < b.particle_count(); ++i)
    for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k)
      if ((x[i].x() < cut) != (x[b.neighbor[k]].x() < cut)) b.alive[k] = 0;
}

std::vector<std::uint32_t> ids(const World& world) {
  const FieldView f = world.field("fragment_id");
  const auto* p = static_cast<const std::uint32_t*>(f.data);
  return {p, p + f.count};
}

// The id of the particles with x in (lo, hi); checks they all share it.
std::uint32_t id_between(const World& world, double lo, double hi) {
  const auto all = ids(world);
  const auto& x = world.state().particles.reference_position;
  std::set<std::uint32_t> seen;
  for (std::size_t i = 0; i < x.size(); ++i)
    if (x[i].x() > lo && x[i].x() < hi) seen.insert(all[i]);
  REQUIRE(seen.size() == 1);
  return *seen.begin();
}

}  // namespace

TEST_CASE("pieces: a bar cut in two keeps the larger part's id, a later split gets a fresh id") {
  World world(test::box_scene(Vec3(1.0, 0.1, 0.1), 0.05, kKappa, kMu));
  const std::uint32_t n = static_cast<std::uint32_t>(world.particle_count());
  CHECK(id_between(world, -1, 1) == 0);  // unbroken: one piece, id = its smallest particle index
  // Cut at x = 0.2: the part x < 0.2 (70% of the bar) is larger and keeps id 0 even if it does not
  // hold particle 0.
  cut_at(world.state_mutable(), 0.2);
  const std::uint32_t left = id_between(world, -1, 0.2), right = id_between(world, 0.2, 1);
  CHECK(left == 0);
  CHECK(right == n);  // the first id never used: the particle count
  CHECK(world.fragment_count() == 2);
  // Asking again (another frame, nothing broke) changes nothing.
  world.state_mutable();
  CHECK(id_between(world, -1, 0.2) == 0);
  CHECK(id_between(world, 0.2, 1) == n);
  // Cut the left part at x = −0.3: its larger part (−0.3, 0.2) keeps 0; (−0.5, −0.3) is new.
  cut_at(world.state_mutable(), -0.3);
  CHECK(id_between(world, -0.3, 0.2) == 0);
  CHECK(id_between(world, -1, -0.3) == n + 1);
  CHECK(id_between(world, 0.2, 1) == n);
  // Cut the right part in equal halves (x = 0.35; 3 cells each side): the tie goes to the half with
  // the smallest particle index, the other half gets n + 2.
  cut_at(world.state_mutable(), 0.35);
  const auto all = ids(world);
  const auto& x = world.state().particles.reference_position;
  std::uint32_t smallest_right = n;
  for (std::uint32_t i = 0; i < n; ++i)
    if (x[i].x() > 0.2) smallest_right = std::min(smallest_right, i);
  const bool low_keeps = x[smallest_right].x() < 0.35;
  CHECK(id_between(world, 0.2, 0.35) == (low_keeps ? n : n + 2));
  CHECK(id_between(world, 0.35, 1) == (low_keeps ? n + 2 : n));
  CHECK(world.state().derived.next_fragment_id == n + 3);
  // Surface triangles carry the piece ids of their tets.
  const SurfaceMesh s = world.surface();
  std::size_t mismatch = 0;
  for (std::size_t f = 0; f < s.triangles.size(); ++f) mismatch += s.fragment[f] != all[s.tet[f]];
  CHECK(mismatch == 0);
}

TEST_CASE("pieces: a bar pulled apart keeps its ids across frames; 1 and 2 threads agree bit for bit") {
  auto make = [](int threads) {
    auto sc = test::box_scene(Vec3(0.12, 0.03, 0.03), 0.006, kKappa, kMu);
    sc.threads = threads;
    sc.materials[0].critical_stretch = 0.01;
    sc.time.dt = 2e-5;
    // Both end slices pulled outward: the bar tears, possibly in several places and frames.
    for (int side : {-1, 1}) {
      scene::BoundaryCondition bc;
      bc.kind = scene::BoundaryCondition::Kind::velocity;
      bc.region.kind = scene::Region::Kind::box;
      bc.region.min = Vec3(side < 0 ? -1.0 : 0.05, -1, -1);
      bc.region.max = Vec3(side < 0 ? -0.05 : 1.0, 1, 1);
      bc.velocity = Vec3(side * 2.0, 0, 0);
      sc.boundary_conditions.push_back(bc);
    }
    return sc;
  };
  World one(make(1)), two(make(2));
  std::map<std::uint32_t, std::size_t> previous;  // id → particles, last frame
  std::set<std::uint32_t> ever;
  std::size_t splits = 0;
  for (int frame = 0; frame < 12; ++frame) {
    one.step(25);
    two.step(25);
    const auto a = ids(one), b = ids(two);
    REQUIRE(a == b);
    std::map<std::uint32_t, std::size_t> size;
    for (auto id : a) ++size[id];
    // Every id present before is still present (its largest part kept it) and no larger than before;
    // every new id was never seen.
    for (const auto& [id, count] : previous) {
      CHECK(size.count(id) == 1);
      if (size.count(id)) CHECK(size[id] <= count);
    }
    for (const auto& [id, count] : size)
      if (!previous.count(id)) {
        CHECK(ever.count(id) == 0);
        if (!previous.empty()) CHECK(id >= one.particle_count());
        ++splits;
      }
    for (const auto& [id, count] : size) ever.insert(id);
    previous = size;
  }
  MESSAGE("pieces after 300 steps: " << previous.size() << ", ids handed out " << ever.size());
  CHECK(previous.size() >= 2);
  CHECK(splits >= 2);  // the first frame's piece, and at least one split
}
