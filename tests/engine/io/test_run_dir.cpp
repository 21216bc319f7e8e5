// Run directories (engine/io/run_dir.cpp): the frame times a reader finds without particles.pvd.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>

#include "io/run_dir.hpp"
#include "runner.hpp"
#include "support.hpp"
#include "file_support.hpp"

using namespace perifx;
namespace fs = std::filesystem;

TEST_CASE("scan_run_directory: a run without particles.pvd has the frame times the .pvd would give") {
  // A frame interval that is not a whole number of steps (1/300 s over 7e-5 s steps = 47.6 steps), so
  // the frames sit at the rounded steps, not at k/300; and not at the 30 fps of the old fallback.
  auto sc = test::box_scene(Vec3(0.02, 0.02, 0.02), 0.005, 5e5, 3e5);
  sc.time.dt = 7e-5;
  sc.time.frame_rate = 300;
  sc.output.surface_ply = false;
  sc.output.obj = false;
  auto run = [&](bool vtu, const std::string& name) {
    auto s = sc;
    s.output.vtu = vtu;
    s.output.ply = !vtu;
    const fs::path dir = test::temp_dir("run_dir", name);
    World world(s);
    RunOptions opt;
    opt.output_directory = dir;
    opt.frames = 5;
    run_world(world, opt);
    return io::scan_run_directory(dir);
  };
  const io::RunDirectory with_pvd = run(true, "vtu"), without = run(false, "ply");
  REQUIRE(with_pvd.frames.size() == 6);
  REQUIRE(without.frames.size() == 6);
  for (std::size_t k = 0; k < 6; ++k) {
    INFO("frame " << k);
    // The .pvd holds the world's clock (a sum of steps); the reader rounds k/frame_rate to a step.
    CHECK(without.frames[k].time == doctest::Approx(with_pvd.frames[k].time).epsilon(1e-12));
    CHECK(without.frames[k].time == doctest::Approx(std::llround(k / 300.0 / 7e-5) * 7e-5).epsilon(1e-12));
  }
  CHECK(without.frames[1].time != doctest::Approx(1.0 / 300.0).epsilon(1e-6));  // 48 steps, not 47.6
}
