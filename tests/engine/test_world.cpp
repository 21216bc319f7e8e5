// The embedding API: no globals, so worlds are independent of each other and of the thread count.
#include <doctest/doctest.h>

#include <malloc.h>
#ifdef PERIFX_SANITIZED
// libasan's allocator statistics (GCC ships no header for them; clang's sanitizer/allocator_interface.h).
extern "C" std::size_t __sanitizer_get_current_allocated_bytes();
#endif

#include <cstring>

#include "support.hpp"

using namespace perifx;

namespace {

scene::Scene swinging_bar(int threads) {
  auto sc = test::box_scene(Vec3(0.4, 0.08, 0.08), 0.02, 2e6, 1e6);
  sc.threads = threads;
  sc.time.dt = 1e-4;
  sc.gravity = Vec3(0, -9.81, 0);
  scene::BoundaryCondition anchor;
  anchor.region.kind = scene::Region::Kind::halfspace;
  anchor.region.point = Vec3(-0.15, 0, 0);
  anchor.region.normal = Vec3(-1, 0, 0);
  sc.boundary_conditions.push_back(anchor);
  scene::Collider ground;
  ground.point = Vec3(0, -0.08, 0);
  sc.colliders.push_back(ground);
  return sc;
}

bool same_bits(std::span<const Vec3> a, std::span<const Vec3> b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)) == 0;
}

}  // namespace

TEST_CASE("two worlds stepped side by side match two separate runs bit for bit") {
  World alone(swinging_bar(2));
  alone.step(200);
  World a(swinging_bar(2)), b(swinging_bar(1));
  for (int k = 0; k < 200; ++k) {
    a.step();
    b.step();
  }
  CHECK(same_bits(a.positions(), alone.positions()));
  CHECK(same_bits(b.positions(), alone.positions()));
  CHECK(same_bits(a.velocities(), alone.velocities()));
  // The bar really moved (so equality is not trivial).
  double moved = 0.0;
  for (std::size_t i = 0; i < a.particle_count(); ++i)
    moved = std::max(moved, (a.positions()[i] - a.reference_positions()[i]).norm());
  CHECK(moved > 1e-3);
}

TEST_CASE("the schedule runs independent systems side by side") {
  World w(swinging_bar(2));
  const std::string s = w.schedule();
  // external_loads touches nothing the peridynamic chain writes: it depends on no other system.
  CHECK(s.find("external_loads  reads -  writes external_force  after (start)") != std::string::npos);
  CHECK(s.find("kick_end") != std::string::npos);
}

TEST_CASE("fields are found by name and unknown names are reported with the list") {
  World w(swinging_bar(1));
  const FieldView v = w.field("velocity");
  CHECK(v.components == 3);
  CHECK(v.count == w.particle_count());
  CHECK_THROWS_WITH_AS(w.field("velocty"), doctest::Contains("fields: position, velocity"), std::out_of_range);
}

TEST_CASE("memory(): the bytes reported are the bytes the world's arrays hold on the heap, within 1%") {
  // Measured independently of the report: the heap in use (malloc arena + mmapped chunks) before and
  // after building the world. A warm-up world first, so oneTBB's one-time allocations are not counted.
  auto scene_for = [](double cell) {
    auto sc = test::box_scene(Vec3(0.3, 0.1, 0.1), cell, 2e6, 1e6);
    sc.materials[0].critical_stretch = 0.01;  // fracture: embedded mesh, contact pair list
    sc.materials[0].yield_energy = 1.0;       // plasticity: mirror plastic extension
    return sc;
  };
  { World warm_up(scene_for(0.05)); warm_up.step(); }
  auto heap = [] {
#ifdef PERIFX_SANITIZED
    // ASan replaces malloc, so glibc's mallinfo2 sees nothing; ASan's allocator counts for itself.
    return double(__sanitizer_get_current_allocated_bytes());
#else
    const struct mallinfo2 info = mallinfo2();
    return double(info.uordblks) + double(info.hblkhd);
#endif
  };
  const double before = heap();
  World world(scene_for(0.01));
  const double held = heap() - before;
  const MemoryUse m = world.memory();
  MESSAGE("heap held by the world " << held / 1e6 << " MB; reported " << double(m.total_bytes) / 1e6 << " MB ("
                                    << m.bytes_per_bond << " B per bond, " << m.bytes_per_particle << " B per particle)");
  REQUIRE(held > 1e7);  // large enough that allocator overhead is far below 1%
  CHECK(double(m.total_bytes) == doctest::Approx(held).epsilon(0.01));
  CHECK(m.total_bytes == m.particle_bytes + m.bond_bytes + m.mesh_bytes + m.contact_bytes + m.other_bytes);
}
