// Quasi-static stretch of a beam: lateral strain = −ν·axial strain for any Poisson ratio (paper Fig. 9;
// κ and μ are independent in the state-based model, unlike bond-based peridynamics' fixed ν = 1/4).
#include <doctest/doctest.h>

#include "support.hpp"

using namespace perifx;

namespace {

// Slope of u_a against x_b over the particles in `ids` (least squares).
double slope(const World& w, const std::vector<std::size_t>& ids, int a, int b) {
  double mx = 0, mu = 0;
  for (auto i : ids) mx += w.reference_positions()[i][b], mu += w.positions()[i][a] - w.reference_positions()[i][a];
  mx /= double(ids.size()), mu /= double(ids.size());
  double sxy = 0, sxx = 0;
  for (auto i : ids) {
    const double dx = w.reference_positions()[i][b] - mx;
    sxy += dx * (w.positions()[i][a] - w.reference_positions()[i][a] - mu);
    sxx += dx * dx;
  }
  return sxy / sxx;
}

double measured_poisson(double nu, scene::Normalization normalization) {
  const double E = 1.0e6;
  const double L = 0.3, W = 0.06;
  auto sc = test::box_scene(Vec3(L, W, W), 0.01, perifx::bulk_modulus(E, nu), perifx::shear_modulus(E, nu));
  sc.normalization = normalization;
  sc.materials[0].damping = 1500.0;  // dynamic relaxation towards the static state
  const double eps = 1e-3, clamp = 0.025;
  for (int side : {-1, 1}) {
    scene::BoundaryCondition bc;
    bc.kind = scene::BoundaryCondition::Kind::displacement;
    bc.region.kind = scene::Region::Kind::box;
    bc.region.min = Vec3(side < 0 ? -1.0 : 0.5 * L - clamp, -1, -1);
    bc.region.max = Vec3(side < 0 ? -0.5 * L + clamp : 1.0, 1, 1);
    bc.displacement = Vec3(side * eps * 0.5 * L, 0, 0);
    sc.boundary_conditions.push_back(bc);
  }
  World probe(sc);
  sc.time.dt = 0.5 * probe.stable_time_step();
  World world(sc);
  // Start from the uniform axial stretch so only the lateral contraction has to develop.
  auto& y = world.state_mutable().particles.position;
  for (std::size_t i = 0; i < y.size(); ++i) y[i].x() *= 1.0 + eps;
  while (world.time() < 0.03) world.step();
  std::vector<std::size_t> middle;
  for (std::size_t i = 0; i < world.particle_count(); ++i)
    if (std::abs(world.reference_positions()[i].x()) < L / 6) middle.push_back(i);
  const double axial = slope(world, middle, 0, 0);
  const double lateral = 0.5 * (slope(world, middle, 1, 1) + slope(world, middle, 2, 2));
  return -lateral / axial;
}

}  // namespace

TEST_CASE("beam stretch: lateral strain is -nu times axial strain within 10%") {
  for (double nu : {0.1, 0.25, 0.4}) {
    const double discrete = measured_poisson(nu, scene::Normalization::discrete);
    const double paper = measured_poisson(nu, scene::Normalization::paper);
    MESSAGE("nu = " << nu << ": measured " << discrete << " (discrete normalization), " << paper << " (paper normalization)");
    CHECK(std::abs(discrete / nu - 1.0) < 0.10);
  }
}
