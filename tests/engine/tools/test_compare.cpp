// perifx compare (engine/tools/compare.cpp): identical runs give exactly zero, a peridynamic run maps onto
// an FEM run of the same scene through the tet barycenters, an FEM run of a different (finer) mesh
// is interpolated at the other run's points, two PD runs of different resolutions are compared by a
// local affine fit of the finer, and frames are paired by time.
#include <doctest/doctest.h>
#include <unistd.h>

#include <filesystem>

#include "tools/compare.hpp"
#include "runner.hpp"
#include "support.hpp"
#include "file_support.hpp"

using namespace perifx;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir(const std::string& name) { return perifx::test::temp_dir("compare", name); }

// A small clamped bar sagging under gravity, 4 frames.
scene::Scene tiny(scene::Solver solver, double cell = 0.025) {
  auto sc = test::box_scene(Vec3(0.3, 0.05, 0.05), cell, 5e5, 3e5);
  sc.solver = solver;
  sc.gravity = Vec3(0, -9.81, 0);
  sc.time.dt = 2e-4;
  sc.time.frame_rate = 100;
  sc.output.ply = false;
  scene::BoundaryCondition clamp;
  clamp.region.kind = scene::Region::Kind::box;
  clamp.region.min = Vec3(-1, -1, -1);
  clamp.region.max = Vec3(-0.13, 1, 1);
  sc.boundary_conditions.push_back(clamp);
  return sc;
}

fs::path run(const scene::Scene& sc, const std::string& name) {
  World world(sc);
  RunOptions opt;
  opt.output_directory = temp_dir(name);
  opt.frames = 4;
  run_world(world, opt);
  return *opt.output_directory;
}

}  // namespace

TEST_CASE("compare: identical runs give exactly zero, PD vs FEM a small finite deviation") {
  const auto pd = run(tiny(scene::Solver::peridynamics), "pd");
  const auto pd2 = run(tiny(scene::Solver::peridynamics), "pd2");
  const auto fem = run(tiny(scene::Solver::fem_corotated), "fem");
  const auto fem2 = run(tiny(scene::Solver::fem_corotated), "fem2");

  const auto same = compare_runs(pd, pd2);
  CHECK(same.frames.size() == 5);
  CHECK(same.max_error == 0.0);
  CHECK(same.mean_error == 0.0);
  CHECK(compare_runs(fem, fem2).max_error == 0.0);

  const auto cross = compare_runs(pd, fem);
  MESSAGE("PD vs corotated FEM: max " << cross.max_error << ", mean " << cross.mean_error);
  CHECK(cross.points == World(tiny(scene::Solver::peridynamics)).particle_count());
  CHECK(cross.frames[0].max_error < 1e-12);  // same mesh: the FEM barycenters are the PD particles
  CHECK(cross.max_error > 0.0);
  CHECK(cross.max_error < 0.05);
  CHECK(std::isfinite(cross.mean_error));
  // The FEM run as reference maps the other way round to the same points.
  const auto reverse = compare_runs(fem, pd);
  CHECK(reverse.points == cross.points);
  CHECK(reverse.max_error == doctest::Approx(cross.max_error).epsilon(0.05));

  write_compare_csv(cross, pd / "compare.csv");
  CHECK(fs::exists(pd / "compare.csv"));
}

TEST_CASE("compare: two peridynamic runs of different resolutions: the finer is fitted at the coarser's particles") {
  const auto coarse = run(tiny(scene::Solver::peridynamics), "coarse");
  const auto fine = run(tiny(scene::Solver::peridynamics, 0.0125), "fine_pd");
  const std::size_t coarse_particles = World(tiny(scene::Solver::peridynamics)).particle_count();
  for (const auto& r : {compare_runs(coarse, fine), compare_runs(fine, coarse)}) {  // either order
    CHECK(r.mapping.find("fitted") != std::string::npos);
    CHECK(r.points == coarse_particles);
    CHECK(r.frames.size() == 5);
    CHECK(r.frames[0].max_error < 1e-12);  // the fit reproduces the points themselves at frame 0
    // The sag of a 2-cell-deep and a 4-cell-deep bar differ (the coarse bar is softer or stiffer)
    // but by a small fraction of the diagonal.
    CHECK(r.max_error > 1e-6);
    CHECK(r.max_error < 0.05);
  }
  CHECK_THROWS_AS(compare_runs(coarse, temp_dir("empty")), CompareError);
}

TEST_CASE("compare: the fit between resolutions is exact for a rigid rotation, unlike nearest neighbours") {
  // No clamp, no gravity, spinning at 0.5 rad/s about z for 40 ms (0.02 rad). A rotation is linear
  // in x, so the affine fit reproduces it exactly; what is left is how the two resolutions stretch
  // under the centrifugal load, ρω²L²/E ~ 1e-5 strain, about 1e-6 of the diagonal (measured: 1.6e-5
  // at 2 rad/s, and it scales as ω²). Taking each coarse particle's nearest fine particle instead
  // would be off by its distance (~5 mm) × 0.02 rad, ~3e-4 of the diagonal.
  auto spinning = [](double cell) {
    auto sc = tiny(scene::Solver::peridynamics, cell);
    sc.boundary_conditions.clear();
    sc.gravity = Vec3::Zero();
    sc.bodies[0].angular_velocity = Vec3(0, 0, 0.5);
    return sc;
  };
  const auto coarse = run(spinning(0.025), "spin_coarse");
  const auto fine = run(spinning(0.0125), "spin_fine");
  const auto r = compare_runs(coarse, fine);
  MESSAGE("rigid rotation, preview vs 2x finer: max deviation " << r.max_error << " of the diagonal");
  CHECK(r.frames.back().time_a == doctest::Approx(0.04));
  CHECK(r.max_error < 1e-5);
}

TEST_CASE("compare: runs of different frame rates compare at the times they share") {
  auto sc = tiny(scene::Solver::peridynamics);
  const auto a = run(sc, "rate100");
  sc.time.frame_rate = 200;  // twice as many frames: every other one is at one of a's times
  const auto b = run(sc, "rate200");
  const auto r = compare_runs(a, b);
  CHECK(r.frames.size() == 3);  // a: 0, 10, 20, 30, 40 ms; b: 0, 5, …, 20 ms
  CHECK(r.frames.back().time_b == doctest::Approx(0.02));
  CHECK(r.max_error == 0.0);    // the same scene and time step: the same trajectory
}

TEST_CASE("compare: a finer FEM reference is interpolated at the other run's points") {
  const auto coarse_fem = run(tiny(scene::Solver::fem_corotated), "coarse_fem");
  const auto coarse_pd = run(tiny(scene::Solver::peridynamics), "coarse_pd2");
  const auto fine_fem = run(tiny(scene::Solver::fem_corotated, 0.0125), "fine_fem");
  const std::size_t pd_particles = World(tiny(scene::Solver::peridynamics)).particle_count();

  // A coarse FEM run against its refinement: the coarse vertices are fine vertices at frame 0.
  const auto fem_fem = compare_runs(fine_fem, coarse_fem);
  CHECK(fem_fem.mapping.find("interpolated") != std::string::npos);
  CHECK(fem_fem.points == World(tiny(scene::Solver::fem_corotated)).particle_count());  // coarse vertices
  CHECK(fem_fem.frames[0].max_error < 1e-12);  // the coarse vertices lie in the fine mesh (box: same faces)
  CHECK(fem_fem.max_error > 0.0);
  CHECK(fem_fem.max_error < 0.05);

  // PD particles (tet barycenters of the coarse mesh) inside the fine FEM mesh, either order.
  const auto pd_ref = compare_runs(fine_fem, coarse_pd);
  CHECK(pd_ref.points == pd_particles);
  CHECK(pd_ref.frames[0].max_error < 1e-12);
  CHECK(pd_ref.max_error > 0.0);
  CHECK(pd_ref.max_error < 0.05);
  const auto pd_first = compare_runs(coarse_pd, fine_fem);
  CHECK(pd_first.points == pd_particles);
  CHECK(pd_first.max_error == doctest::Approx(pd_ref.max_error).epsilon(0.05));

  CHECK(compare_runs(fine_fem, fine_fem).max_error == 0.0);
}

TEST_CASE("compare: the interpolation is exact for a rigid translation") {
  // No clamp, no gravity, a uniform initial velocity: both runs translate rigidly, so a fine FEM run
  // interpolated at a coarse PD run's particles must match them to round-off in every frame.
  auto drifting = [](scene::Solver solver, double cell) {
    auto sc = tiny(solver, cell);
    sc.boundary_conditions.clear();
    sc.gravity = Vec3::Zero();
    sc.bodies[0].velocity = Vec3(1.0, 0.5, -0.25);
    return sc;
  };
  const auto fem = run(drifting(scene::Solver::fem_corotated, 0.0125), "drift_fem");
  const auto pd = run(drifting(scene::Solver::peridynamics, 0.025), "drift_pd");
  const auto r = compare_runs(fem, pd);
  CHECK(r.mapping.find("interpolated") != std::string::npos);
  CHECK(r.frames.size() == 5);
  CHECK(r.frames.back().time_a > 0.0);
  CHECK(r.max_error < 1e-12);
}

TEST_CASE("compare: points outside a finer curved mesh are compared by motion, not by their offset") {
  // A sphere meshed at two resolutions (1.5 and 1 cm cells): some coarse FEM vertices on the surface
  // lie outside the fine mesh (by up to ~2% of d). Both runs translate rigidly, so after subtracting
  // each point's frame-0 offset the deviation is round-off; without it, it would be that offset.
  auto ball = [](double cell) {
    auto sc = tiny(scene::Solver::fem_corotated, cell);
    sc.boundary_conditions.clear();
    sc.gravity = Vec3::Zero();
    sc.bodies[0].geometry.kind = scene::Geometry::Kind::sphere;
    sc.bodies[0].geometry.radius = 0.05;
    sc.bodies[0].velocity = Vec3(0.5, -0.2, 0.1);
    sc.time.dt = 2e-5;  // stable for the 1 cm cells
    return sc;
  };
  const auto fine = run(ball(0.01), "ball_fine");
  const auto coarse = run(ball(0.015), "ball_coarse");
  const auto r = compare_runs(fine, coarse);
  CHECK(r.mapping.find("by motion") != std::string::npos);
  CHECK(r.frames.size() == 5);
  CHECK(r.max_error < 1e-12);
}
