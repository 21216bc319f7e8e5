// Conservation laws of the paired force and the velocity-Verlet integrator (systems/README.md §2.1 and §7).
#include <doctest/doctest.h>

#include "support.hpp"

using namespace perifx;

namespace {

// A free box set vibrating by a smooth, non-rigid initial velocity field plus a rigid spin.
World vibrating_box(double dt_fraction) {
  auto sc = test::box_scene(Vec3(0.2, 0.12, 0.1), 0.02, 3.3e6, 2.0e6);
  World probe(sc);
  sc.time.dt = dt_fraction * probe.stable_time_step();
  World world(sc);
  auto v = world.velocities_mutable();
  const auto x = world.reference_positions();
  for (std::size_t i = 0; i < v.size(); ++i) {
    const Vec3& p = x[i];
    v[i] = Vec3(0.3 * std::sin(15.0 * p.x()) + 0.1, 0.2 * std::cos(20.0 * p.y()) * p.x(), 0.25 * p.y() * p.z() * 40.0) +
           Vec3(0.0, 0.0, 2.0).cross(p);
  }
  return world;
}

}  // namespace

TEST_CASE("linear and angular momentum are conserved over 1000 steps of a free deforming body") {
  World world = vibrating_box(0.5);
  const auto d0 = world.diagnostics();
  double scale_p = 0.0, scale_l = 0.0;  // Σ m|v| and Σ m|x×v|: what "relative" is measured against
  for (std::size_t i = 0; i < world.particle_count(); ++i) {
    const double m = world.state().particles.mass[i];
    scale_p += m * world.velocities()[i].norm();
    scale_l += m * world.positions()[i].cross(world.velocities()[i]).norm();
  }
  world.step(1000);
  const auto d1 = world.diagnostics();
  CHECK(d1.kinetic_energy > 0.0);
  const double dp = (d1.linear_momentum - d0.linear_momentum).norm() / scale_p;
  const double dl = (d1.angular_momentum - d0.angular_momentum).norm() / scale_l;
  MESSAGE("relative momentum change: linear " << dp << ", angular " << dl);
  CHECK(dp < 1e-10);
  CHECK(dl < 1e-10);
}

TEST_CASE("total energy drifts less than 1% over 1000 undamped steps") {
  World world = vibrating_box(0.5);
  // The initial velocity field is not an equilibrium state, so energy moves between kinetic and elastic.
  const double e0 = world.diagnostics().kinetic_energy + world.diagnostics().elastic_energy;
  double worst = 0.0, max_elastic = 0.0;
  for (int k = 0; k < 20; ++k) {
    world.step(50);
    const auto d = world.diagnostics();
    max_elastic = std::max(max_elastic, d.elastic_energy);
    worst = std::max(worst, std::abs(d.kinetic_energy + d.elastic_energy - e0) / e0);
  }
  MESSAGE("max relative energy deviation " << worst << ", peak elastic share " << max_elastic / e0);
  CHECK(max_elastic > 0.01 * e0);  // the body really deforms
  CHECK(worst < 0.01);
}
