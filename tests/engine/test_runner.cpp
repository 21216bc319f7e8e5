// engine/runner.cpp: run_world's profile (`perifx run --profile`).
#include <doctest/doctest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "runner.hpp"
#include "support.hpp"
#include "file_support.hpp"

using namespace perifx;
namespace fs = std::filesystem;

namespace {

fs::path fresh_dir(const std::string& name) { return perifx::test::temp_dir("runner", name); }

// A falling bar that breaks on a collider: every fracture and mesh system is in the graph.
scene::Scene breaking_bar() {
  auto sc = test::box_scene(Vec3(0.2, 0.04, 0.04), 0.01, 5e5, 3e5);
  sc.gravity = Vec3(0, -9.81, 0);
  sc.materials[0].critical_stretch = 0.01;
  sc.time.dt = 2e-4;
  sc.time.frame_rate = 100;
  sc.output.ply = false;
  return sc;
}

}  // namespace

TEST_CASE("run --profile: every system of the graph is timed once per step, and the frames do not change") {
  const auto sc = breaking_bar();
  World plain(sc), profiled(sc);
  RunOptions opt;
  opt.frames = 3;
  const fs::path plain_dir = fresh_dir("plain");
  opt.output_directory = plain_dir;
  const RunSummary a = run_world(plain, opt);
  CHECK(a.system_times.empty());
  opt.output_directory = fresh_dir("profiled");
  opt.profile = true;
  const RunSummary b = run_world(profiled, opt);

  // One row per system of the schedule, in its order, each run exactly once per step.
  const auto& systems = b.system_times;
  REQUIRE(systems.size() == profiled.system_times().size());
  std::string schedule = profiled.schedule();
  std::size_t line = 0;
  for (const auto& t : systems) {
    CAPTURE(t.name);
    CHECK(t.runs == b.steps);
    CHECK(t.seconds >= 0.0);
    CHECK(t.seconds <= b.wall_seconds);  // a node cannot run longer than the steps it is part of
    CHECK(schedule.find(std::to_string(line++) + " " + t.name + " ") != std::string::npos);
  }
  CHECK(b.steps == 150);  // 3 frames of 10 ms at dt 0.2 ms

  // summary.json carries the same table; the frame files are byte-identical to the unprofiled run.
  const auto js = nlohmann::json::parse(test::slurp(*opt.output_directory / "summary.json"));
  REQUIRE(js.contains("profile"));
  REQUIRE(js["profile"].size() == systems.size());
  CHECK(js["profile"][0]["system"] == systems[0].name);
  CHECK(js["profile"][0]["steps"] == b.steps);
  CHECK_FALSE(nlohmann::json::parse(test::slurp(plain_dir / "summary.json")).contains("profile"));
  // The peak resident memory: at least the arrays the world holds (all written at set-up), and the same
  // number in summary.json.
  CHECK(b.peak_memory_bytes >= profiled.memory().total_bytes);
  CHECK(js["peak_memory_bytes"].get<std::uint64_t>() == b.peak_memory_bytes);
  for (int k = 0; k <= 3; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "particles.%04d.vtu", k);
    CHECK(test::slurp(plain_dir / name) == test::slurp(*opt.output_directory / name));
  }

  // The text table: a row per system plus the totals.
  const std::string table = profile_table(b);
  for (const auto& t : systems) CHECK(table.find(t.name) != std::string::npos);
  CHECK(table.find("stepping total") != std::string::npos);
  CHECK(table.find("file output") != std::string::npos);
}
