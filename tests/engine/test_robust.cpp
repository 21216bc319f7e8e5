// Issue 14: blow-ups are caught (each cause), degenerate geometry is refused before the first step,
// and `check` refuses what `run` would (stable limit, memory).
#include <doctest/doctest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

#include <nlohmann/json.hpp>

#include "cli_support.hpp"
#include "io/run_dir.hpp"
#include "support.hpp"
#include "file_support.hpp"

namespace fs = std::filesystem;
using namespace perifx;

namespace {

fs::path temp_dir(const std::string& name) { return perifx::test::temp_dir("robust", name); }

nlohmann::json ball_drop() {
  std::ifstream in(fs::path(PERIFX_SOURCE_DIR) / "assets" / "scenes" / "ball_drop.json");
  return nlohmann::json::parse(in);
}

}  // namespace

// The stable limit is the reference configuration's; a ball thrown at the ground at 5 m/s is squashed
// hard enough to stiffen past it at 99 % of it, which the preflight (against the limit) cannot see.
// (Dropped from rest it blew up too until kick_end's support constraint, systems/integration.cpp, stopped
// the ground feeding its bottom layer a velocity each step; dropped, it now lands and settles.)
TEST_CASE("instability: a ball thrown at the ground at 99% of the stable step stops with exit 7 and only finite frames") {
  const fs::path dir = temp_dir("ball99");
  const fs::path scene_file = dir / "ball.json";
  {
    auto j = ball_drop();
    std::ofstream(scene_file) << j.dump();
  }
  const double stable = World::from_file(scene_file).stable_time_step();
  auto j = ball_drop();
  j["time"]["dt"] = 0.99 * stable;
  j["time"]["duration"] = 0.6;
  j["bodies"][0]["velocity"] = {0.0, -5.0, 0.0};
  std::ofstream(scene_file) << j.dump();
  const auto r = test::run_cli("run " + scene_file.string() + " --quiet --out " + (dir / "out").string());
  CHECK(r.code == 7);
  CHECK(r.output.find("unstable simulation: body 'ball' particle ") != std::string::npos);
  CHECK(r.output.find("the last valid frame is") != std::string::npos);
  CHECK(r.output.find("hint: time/dt") != std::string::npos);
  CHECK(std::count(r.output.begin(), r.output.end(), '\n') == 1);
  int frames = 0;
  for (const auto& f : io::particle_series(dir / "out")) {
    ++frames;
    for (const auto& y : io::read_particle_frame(dir / "out" / f.file).position) REQUIRE(std::isfinite(y.norm()));
  }
  CHECK(frames >= 1);
  CHECK(!fs::exists(dir / "out" / "summary.json"));
  fs::remove_all(dir);
}

TEST_CASE("instability: a non-finite velocity is caught at the next step, naming the lowest bad particle") {
  auto sc = test::box_scene(Vec3(0.1, 0.1, 0.1), 0.025, 1e5, 5e4);
  sc.time.dt = 1e-5;
  World world(sc);
  world.step();
  world.velocities_mutable()[7] = Vec3(std::numeric_limits<double>::quiet_NaN(), 0, 0);
  try {
    world.step();
    FAIL("no InstabilityError");
  } catch (const InstabilityError& e) {
    // The NaN spreads to the bond neighbours within the step; the lowest bad index is reported.
    CHECK(e.particle() <= 7);
    CHECK(e.step() == 2);
    CHECK(std::string(e.what()).find("has a non-finite position or velocity at step 2") != std::string::npos);
  }
}

TEST_CASE("instability: a runaway speed is caught") {
  auto sc = test::box_scene(Vec3(0.1, 0.1, 0.1), 0.025, 1e5, 5e4);
  sc.time.dt = 1e-5;
  World world(sc);
  world.velocities_mutable()[3] = Vec3(0, 1e6, 0);  // far beyond 10 × the wave speed (~13 m/s)
  CHECK_THROWS_AS(world.step(), InstabilityError);
}

TEST_CASE("degenerate geometry the loader accepts is refused before the first step, with a pointer") {
  const fs::path dir = temp_dir("degenerate");
  struct Case {
    const char* pointer;
    nlohmann::json value;
  };
  for (const Case& c : {Case{"/bodies/0/geometry/radius", 1e-300}, Case{"/bodies/0/transform/scale", 1e300},
                        Case{"/bodies/0/transform/scale", 1e-300}}) {
    auto j = ball_drop();
    j[nlohmann::json::json_pointer(c.pointer)] = c.value;
    std::ofstream(dir / "s.json") << j.dump();
    const auto r = test::run_cli("check " + (dir / "s.json").string());
    CAPTURE(c.pointer);
    CAPTURE(r.output);
    CHECK(r.code == 2);
    CHECK(r.output.find(": /bodies/0/geometry: ") != std::string::npos);
  }
  fs::remove_all(dir);
}

TEST_CASE("check refuses a time step above the stable limit and a scene too big for memory") {
  const fs::path dir = temp_dir("check");
  auto j = ball_drop();
  j["time"]["dt"] = 0.01;  // stable limit ~1.1e-3 s
  std::ofstream(dir / "fast.json") << j.dump();
  auto r = test::run_cli("check " + (dir / "fast.json").string());
  CHECK(r.code == 4);
  CHECK(r.output.find("/time/dt: time step above the stable explicit limit") != std::string::npos);
  j = ball_drop();
  j["bodies"][0]["geometry"] = {{"type", "box"}, {"size", {1, 1, 1}}, {"resolution", 2000}};
  std::ofstream(dir / "big.json") << j.dump();
  r = test::run_cli("check " + (dir / "big.json").string());
  CHECK(r.code == 8);
  CHECK(r.output.find("not enough memory") != std::string::npos);
  r = test::run_cli("run " + (dir / "big.json").string() + " --quiet --out " + (dir / "out").string());
  CHECK(r.code == 8);
  CHECK(!fs::exists(dir / "out"));
  fs::remove_all(dir);
}
