// perifx compare (engine/compare.cpp): identical runs give exactly zero, a peridynamic run maps onto
// an FEM run of the same scene through the tet barycenters, mismatched runs are refused.
#include <doctest/doctest.h>
#include <unistd.h>

#include <filesystem>

#include "compare.hpp"
#include "runner.hpp"
#include "support.hpp"

using namespace perifx;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("perifx_test_compare_" + std::to_string(::getpid())) / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

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

TEST_CASE("compare: runs of different meshes are refused with a clear message") {
  const auto a = run(tiny(scene::Solver::peridynamics), "coarse");
  const auto b = run(tiny(scene::Solver::fem_linear, 0.0125), "fine");
  CHECK_THROWS_AS(compare_runs(a, b), CompareError);
  try {
    compare_runs(a, b);
  } catch (const CompareError& e) {
    CHECK(std::string(e.what()).find("not of the same tet mesh") != std::string::npos);
  }
  CHECK_THROWS_AS(compare_runs(a, temp_dir("empty")), CompareError);
}
