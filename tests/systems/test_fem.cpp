// FEM reference solver (components/fem.hpp): static cantilever against Euler–Bernoulli, and the
// ghost forces of linear FEM under rigid rotation that corotated FEM (and peridynamics) avoid.
#include <doctest/doctest.h>

#include <Eigen/Geometry>
#include <chrono>

#include "support.hpp"

using namespace perifx;

namespace {

// Tip deflection of a clamped beam (length L along x, square h×h) sagging under gravity, by dynamic
// relaxation (mass-proportional damping 2ω₁, critical for the first bending mode) from the
// Euler–Bernoulli shape, relative to qL⁴/(8EI). ν = 0 (κ = 2μ/3) so the beam theory applies without
// Poisson terms; L/h = 8 keeps Timoshenko's shear term at ~1%. Linear tets are stiff in bending
// (4 cells through the depth give 0.83 of the beam value), so the depth gets 8 cells.
double cantilever_ratio(scene::Solver solver, double cell) {
  const double L = 0.8, h = 0.1, E = 1.0e9, rho = 1000.0, g = 9.81;
  auto sc = test::box_scene(Vec3(L, h, h), cell, E / 3.0, E / 2.0, rho);
  sc.solver = solver;
  sc.gravity = Vec3(0, -g, 0);
  const double omega1 = 3.516 * std::sqrt(E * h * h / 12.0 / rho) / (L * L);
  sc.materials[0].damping = 2.0 * omega1;
  scene::BoundaryCondition clamp;
  clamp.region.kind = scene::Region::Kind::box;
  clamp.region.min = Vec3(-1, -1, -1);
  clamp.region.max = Vec3(-0.5 * L + 1e-9, 1, 1);
  sc.boundary_conditions.push_back(clamp);
  World probe(sc);
  sc.time.dt = 0.9 * probe.stable_time_step();
  World world(sc);
  const double q = rho * g * h * h, EI = E * h * h * h * h / 12.0;
  const double expected = q * L * L * L * L / (8.0 * EI);
  // Start from the beam-theory deflection w(s) = q s²(6L² − 4Ls + s²)/(24 EI), s from the clamp.
  auto& y = world.state_mutable().particles.position;
  const auto x = world.reference_positions();
  for (std::size_t i = 0; i < y.size(); ++i) {
    const double s = x[i].x() + 0.5 * L;
    y[i].y() -= q * s * s * (6 * L * L - 4 * L * s + s * s) / (24.0 * EI);
  }
  while (world.time() < 5.0 / omega1) world.step();
  double tip = 0.0;
  int count = 0;
  for (std::size_t i = 0; i < y.size(); ++i)
    if (x[i].x() > 0.5 * L - 1e-9) tip += x[i].y() - y[i].y(), ++count;
  return tip / count / expected;
}

// Largest internal force for positions y, relative to `reference`.
double max_force(const World& world, const std::vector<Vec3>& y) {
  std::vector<Vec3> scratch, force;
  systems::compute_fem_force(world.state(), y, scratch, force);
  double m = 0.0;
  for (const auto& f : force) m = std::max(m, f.norm());
  return m;
}

}  // namespace

TEST_CASE("fem: static cantilever tip deflection within 5% of Euler-Bernoulli qL^4/(8EI)") {
  // Linear FEM only: the corotated model reduces to it for small displacements (next test).
  const auto t0 = std::chrono::steady_clock::now();
  const double ratio = cantilever_ratio(scene::Solver::fem_linear, 0.0125);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  MESSAGE("linear FEM: tip / EB = " << ratio << " (" << secs << " s)");
  CHECK(std::abs(ratio - 1.0) < 0.05);
}

TEST_CASE("fem: corotated forces equal linear forces for a small displacement") {
  auto sc = test::box_scene(Vec3(0.2, 0.1, 0.1), 0.025, 1e6, 5e5);
  sc.solver = scene::Solver::fem_linear;
  World linear(sc);
  sc.solver = scene::Solver::fem_corotated;
  World corotated(sc);
  const auto x = linear.reference_positions();
  std::vector<Vec3> y(x.begin(), x.end());
  for (std::size_t i = 0; i < y.size(); ++i)  // a smooth bend-and-shear field of amplitude 1e-7 m
    y[i] += 1e-7 * Vec3(std::sin(7 * x[i].y()), std::cos(5 * x[i].x()), x[i].x() * x[i].z() * 30);
  std::vector<Vec3> scratch, fl, fc;
  systems::compute_fem_force(linear.state(), y, scratch, fl);
  systems::compute_fem_force(corotated.state(), y, scratch, fc);
  double diff = 0.0, size = 0.0;
  for (std::size_t i = 0; i < y.size(); ++i) diff = std::max(diff, (fl[i] - fc[i]).norm()), size = std::max(size, fl[i].norm());
  CHECK(size > 0.0);
  CHECK(diff < 1e-4 * size);
}

TEST_CASE("fem: lumped vertex masses add up to the body mass, vertices are the particles") {
  auto sc = test::box_scene(Vec3(0.2, 0.1, 0.1), 0.025, 1e6, 5e5, 1200.0);
  sc.solver = scene::Solver::fem_corotated;
  World world(sc);
  const auto& w = world.state();
  CHECK(world.particle_count() == w.mesh.vertices.size());
  double mass = 0.0;
  for (double m : w.particles.mass) mass += m;
  CHECK(mass == doctest::Approx(1200.0 * 0.2 * 0.1 * 0.1).epsilon(1e-12));
  CHECK(world.bond_count() == 0);
  CHECK(world.stable_time_step() > 0.0);
  CHECK(std::isfinite(world.stable_time_step()));
}

TEST_CASE("fem: corotated has no ghost force under a rigid rotation, linear does") {
  auto sc = test::box_scene(Vec3(0.2, 0.1, 0.1), 0.025, 1e6, 5e5);
  const Mat3 rot = Eigen::AngleAxisd(kPi / 6.0, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  for (auto solver : {scene::Solver::fem_corotated, scene::Solver::fem_linear}) {
    sc.solver = solver;
    World world(sc);
    const auto x = world.reference_positions();
    std::vector<Vec3> stretched(x.begin(), x.end()), rotated(x.begin(), x.end());
    for (auto& p : stretched) p.x() *= 1.0 + 1e-3;
    for (auto& p : rotated) p = rot * p + Vec3(0.3, -0.2, 0.1);
    const double reference = max_force(world, stretched);
    REQUIRE(reference > 0.0);
    const double ghost = max_force(world, rotated) / reference;
    if (solver == scene::Solver::fem_corotated) {
      MESSAGE("corotated: rotation force / stretch force = " << ghost);
      CHECK(ghost < 1e-10);
    } else {
      MESSAGE("linear: rotation force / stretch force = " << ghost);
      CHECK(ghost > 1e-3);
    }
  }
}

TEST_CASE("fem: polar rotation of a stretched, rotated matrix") {
  const Mat3 r = Eigen::AngleAxisd(1.0, Vec3(0.3, -1, 0.2).normalized()).toRotationMatrix();
  Mat3 s;
  s << 1.3, 0.1, 0.0, 0.1, 0.8, 0.05, 0.0, 0.05, 1.1;
  const Mat3 found = systems::polar_rotation(r * s);
  CHECK((found - r).norm() < 1e-12);
  // An inverted element still gets a proper rotation (det +1).
  Mat3 flip = Mat3::Identity();
  flip(2, 2) = -0.5;
  CHECK(systems::polar_rotation(r * flip).determinant() == doctest::Approx(1.0));
}

TEST_CASE("fem: polar rotation of a rank-deficient matrix is a finite proper rotation") {
  // Sums of one or two outer products (the cross-covariance of a piece of two or three particles):
  // round-off leaves det F ~1e-30, of either sign. Before the scale-aware test, about 6 % of them
  // iterated to NaN (the glTF validator found NaN rotations in the fig07 preview's animation).
  std::uint64_t state = 12345;
  auto uniform = [&] {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(state >> 11) * 0x1.0p-53 - 0.5;
  };
  int not_rotations = 0;
  for (int k = 0; k < 3000; ++k) {
    Mat3 F = Mat3::Zero();
    for (int r = 0; r < 1 + k % 2; ++r) {
      const Vec3 a(uniform(), uniform(), uniform()), b(uniform(), uniform(), uniform());
      F += 1e-4 * a * b.transpose();
    }
    const Mat3 R = systems::polar_rotation(F);
    not_rotations += !R.allFinite() || (R.transpose() * R - Mat3::Identity()).norm() > 1e-12 ||
                     std::abs(R.determinant() - 1.0) > 1e-12;
  }
  CHECK(not_rotations == 0);
  CHECK(systems::polar_rotation(Mat3::Zero()).allFinite());
}

TEST_CASE("fem: a block dropped on a ground collider comes to rest on the plane") {
  // FEM worlds step the colliders on their vertices (the particles). A 12 × 6 × 12 cm corotated block,
  // 2 mm above the ground, falls and settles under mass damping: its lowest vertices must end on the
  // plane (the push-out puts them there; its weight compresses it by ρgH/E ≈ 6e-5 m, which moves the
  // top, not the bottom) and at rest. Until 2026-12-05 an FEM world with a collider crashed in its
  // first step (the per-particle collider record was allocated on the peridynamic path only).
  for (const scene::Solver solver : {scene::Solver::fem_corotated, scene::Solver::fem_linear}) {
    CAPTURE(static_cast<int>(solver));
    auto sc = test::box_scene(Vec3(0.12, 0.06, 0.12), 0.03, 8e6, 4.8e6);
    sc.solver = solver;
    sc.bodies[0].transform.translation = Vec3(0.0, 0.032, 0.0);
    sc.gravity = Vec3(0.0, -9.81, 0.0);
    sc.materials[0].damping = 60.0;
    sc.colliders.push_back(scene::Collider{});  // the default: the plane y = 0
    {
      World probe(sc);
      sc.time.dt = 0.5 * probe.stable_time_step();
    }
    World world(sc);
    double lowest_ever = kInfinity;
    while (world.time() < 0.3) {
      world.step();
      for (const Vec3& y : world.positions()) lowest_ever = std::min(lowest_ever, y.y());
    }
    double lowest = kInfinity, fastest = 0.0;
    for (const Vec3& y : world.positions()) lowest = std::min(lowest, y.y());
    for (const Vec3& v : world.velocities()) fastest = std::max(fastest, v.norm());
    CHECK(lowest_ever > -1e-9);        // never into the ground
    CHECK(std::abs(lowest) < 1e-6);    // resting on it (a micrometre against a 2 mm drop)
    CHECK(fastest < 1e-3);             // at rest (m/s)
  }
}
