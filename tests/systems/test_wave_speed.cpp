// A longitudinal pulse in a slender bar travels at the bar velocity √(E/ρ). The bar is 6 cells
// (≈ 3 horizons) across: with 4 cells the discrete-normalized surface layer makes it ~6% too fast.
#include <doctest/doctest.h>

#include "support.hpp"

using namespace perifx;

namespace {

// Time at which the mean axial velocity of the slab around x = station peaks.
struct Probe {
  double station, best_value = -1.0, best_time = 0.0;
};

double measured_speed(scene::Normalization normalization) {
  const double kappa = 2.0e6, mu = 1.2e6, rho = 1000.0;
  auto sc = test::box_scene(Vec3(1.2, 0.075, 0.075), 0.0125, kappa, mu, rho);
  sc.normalization = normalization;
  World probe_world(sc);
  sc.time.dt = 0.5 * probe_world.stable_time_step();
  World world(sc);
  auto v = world.velocities_mutable();
  const auto x = world.reference_positions();
  const double x0 = -0.35, width = 0.06;
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = Vec3(1e-3 * std::exp(-std::pow((x[i].x() - x0) / width, 2)), 0, 0);
  Probe a{-0.1}, b{0.3};
  const double c = std::sqrt(perifx::youngs_modulus(kappa, mu) / rho);
  const double t_end = (b.station - x0) / c * 1.4;
  while (world.time() < t_end) {
    world.step();
    for (Probe* p : {&a, &b}) {
      double sum = 0.0;
      int count = 0;
      for (std::size_t i = 0; i < v.size(); ++i)
        if (std::abs(x[i].x() - p->station) < 0.02) sum += world.velocities()[i].x(), ++count;
      if (sum / count > p->best_value) p->best_value = sum / count, p->best_time = world.time();
    }
  }
  return (b.station - a.station) / (b.best_time - a.best_time);
}

}  // namespace

TEST_CASE("longitudinal pulse travels at sqrt(E/rho) within 5%") {
  const double c = std::sqrt(perifx::youngs_modulus(2.0e6, 1.2e6) / 1000.0);
  const double discrete = measured_speed(scene::Normalization::discrete);
  const double paper = measured_speed(scene::Normalization::paper);
  MESSAGE("bar velocity sqrt(E/rho) = " << c << " m/s; measured: discrete normalization " << discrete
                                        << " m/s (" << discrete / c << "), paper normalization " << paper << " m/s ("
                                        << paper / c << ")");
  CHECK(std::abs(discrete / c - 1.0) < 0.05);
}
