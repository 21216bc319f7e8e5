// The perifx command line as a user meets it: exit codes, messages, and byte-identical output for
// any thread count.
#include <doctest/doctest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <algorithm>
#include <nlohmann/json.hpp>

#include "cli_support.hpp"
#include "file_support.hpp"
#include "systems/yield_law.hpp"

namespace fs = std::filesystem;

namespace {

using perifx::test::slurp;

using perifx::test::run_cli;

fs::path temp_dir(const std::string& name) { return perifx::test::temp_dir("cli", name); }

fs::path write(const fs::path& dir, const std::string& name, const std::string& text) {
  std::ofstream(dir / name) << text;
  return dir / name;
}

const char* kScene = R"({
  "time": { "dt": 1e-4, "duration": 0.02, "frame_rate": 200 },
  "materials": { "gel": { "density": 1000, "youngs_modulus": 1e6, "poisson_ratio": 0.3 } },
  "bodies": [ { "material": "gel", "geometry": { "type": "box", "size": [0.3, 0.1, 0.1], "edge_length": 0.025 },
                "transform": { "translate": [0, 0.2, 0] }, "velocity": [0.5, -1, 0.2] } ],
  "boundary_conditions": [ { "type": "velocity", "velocity": [0, 0.5, 0], "end": 0.01,
                             "region": { "type": "box", "min": [0.1, 0, -1], "max": [1, 1, 1] } } ],
  "colliders": [ { "type": "plane", "point": [0, 0.16, 0], "normal": [0, 1, 0], "friction": 0.3 } ]
})";

}  // namespace

TEST_CASE("cli: a scene run with 1 and with 2 threads writes byte-identical frames") {
  const fs::path dir = temp_dir("determinism");
  const fs::path scene = write(dir, "scene.json", kScene);
  const auto one = run_cli("run " + scene.string() + " --quiet --threads 1 --out " + (dir / "t1").string());
  const auto two = run_cli("run " + scene.string() + " --quiet --threads 2 --out " + (dir / "t2").string());
  REQUIRE(one.code == 0);
  REQUIRE(two.code == 0);
  int compared = 0;
  for (const auto& entry : fs::directory_iterator(dir / "t1")) {
    const auto name = entry.path().filename();
    if (name == "summary.json") continue;  // holds wall-clock timings
    CHECK_MESSAGE(slurp(entry.path()) == slurp(dir / "t2" / name), name.string());
    ++compared;
  }
  // Frames 0..4 as particle VTU and PLY and surface OBJ and PLY (surfaces by default), plus the .pvd,
  // mesh.json (compare), surface.mtl and checkpoint.bin (the checkpoint is thread-count independent too),
  // and the point cache written by default: pieces.csv, animation.obj, animation.pc2, animation.bin.
  CHECK(compared == 4 * 5 + 4 + 4);
  // No temporary files are left behind.
  for (const auto& entry : fs::directory_iterator(dir / "t1"))
    CHECK(entry.path().filename().string().find(".tmp-") == std::string::npos);
  // A run that writes no mesh format never evaluates the embedded mesh's deformation arrays; they are
  // in the checkpoint all the same, and were left uninitialized: this torn sheet (two steps, particles
  // only) wrote checkpoints differing in 32 bytes between two runs of the same binary.
  const fs::path sheet = write(dir, "sheet.json", R"({
    "gravity": [0, 0, 0], "time": { "dt": 5e-5, "duration": 1e-4, "frame_rate": 2e4 },
    "materials": { "sheet": { "density": 1000, "bulk_modulus": 5e6, "shear_modulus": 3e6, "critical_stretch": 0.1 } },
    "bodies": [ { "material": "sheet", "geometry": { "type": "box", "size": [0.4, 0.4, 0.01], "edge_length": 0.01 } } ],
    "boundary_conditions": [ { "type": "velocity", "velocity": [-0.3, 0, 0.4], "region": { "type": "box", "min": [-1, -1, -1], "max": [-0.185, 1, 1] } } ],
    "cracks": [ { "polygon": [[-0.08, 0.003, -0.01], [0.08, 0.003, -0.01], [0.08, 0.003, 0.01], [-0.08, 0.003, 0.01]] } ],
    "output": { "formats": ["vtu"] } })");
  REQUIRE(run_cli("run " + sheet.string() + " --quiet --threads 1 --out " + (dir / "s1").string()).code == 0);
  REQUIRE(run_cli("run " + sheet.string() + " --quiet --threads 2 --out " + (dir / "s2").string()).code == 0);
  CHECK(slurp(dir / "s1" / "checkpoint.bin") == slurp(dir / "s2" / "checkpoint.bin"));
  fs::remove_all(dir);
}

TEST_CASE("cli: errors exit non-zero with a message naming the file, pointer, value and expectation") {
  const fs::path dir = temp_dir("errors");
  struct Case {
    std::string file, text, needle;
  };
  const std::string ok_body = R"("bodies": [ { "material": "gel", "geometry": { "type": "box", "size": [0.1, 0.1, 0.1] } } ])";
  const Case cases[] = {
      {"malformed.json", "{ \"time\": { \"dt\": 1e-4, }\n}", "line 1"},
      {"wrong_type.json",
       R"({ "time": { "dt": "fast" }, "materials": { "gel": { "bulk_modulus": 1e6, "shear_modulus": 1e6 } }, )" + ok_body + "}",
       "/time/dt"},
      {"range.json",
       R"({ "time": { "dt": 1e-4 }, "materials": { "gel": { "density": -5, "bulk_modulus": 1e6, "shear_modulus": 1e6 } }, )" + ok_body + "}",
       "/materials/gel/density"},
      {"unknown.json",
       R"({ "time": { "dt": 1e-4 }, "materials": { "gel": { "densty": 5, "bulk_modulus": 1e6, "shear_modulus": 1e6 } }, )" + ok_body + "}",
       "did you mean 'density'"},
      {"missing_mesh.json",
       R"({ "time": { "dt": 1e-4 }, "materials": { "gel": { "bulk_modulus": 1e6, "shear_modulus": 1e6 } },
            "bodies": [ { "material": "gel", "geometry": { "type": "tetgen", "path": "nowhere/bunny.node" } } ] })",
       "bunny.node"},
  };
  for (const auto& c : cases) {
    const fs::path file = write(dir, c.file, c.text);
    const auto r = run_cli("check " + file.string());
    CHECK_MESSAGE(r.code == 2, c.file);
    CHECK_MESSAGE(r.output.find(c.file) != std::string::npos, r.output);
    CHECK_MESSAGE(r.output.find(c.needle) != std::string::npos, r.output);
  }
  const auto missing = run_cli("check " + (dir / "absent.json").string());
  CHECK(missing.code == 2);
  CHECK(missing.output.find("absent.json") != std::string::npos);
  const auto usage = run_cli("run");
  CHECK(usage.code == 1);
  const auto bad_flag = run_cli("run x.json --threads zero");
  CHECK(bad_flag.code == 1);
  CHECK(bad_flag.output.find("--threads") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("cli: a scene without dt, or --dt auto, runs at the step picked at set-up; info says so; resume continues it") {
  const fs::path dir = temp_dir("auto_dt");
  std::string text = kScene;
  const std::string step = "\"dt\": 1e-4, ";
  text.erase(text.find(step), step.size());  // the step left out: "auto"
  const fs::path scene = write(dir, "scene.json", text);
  const auto info = run_cli("info " + scene.string());
  REQUIRE(info.code == 0);
  CHECK(info.output.find("(auto: ") != std::string::npos);  // "time step 0.000128 s (auto: 77% of the stable limit …"
  const auto whole = run_cli("run " + scene.string() + " --quiet --threads 2 --out " + (dir / "whole").string());
  REQUIRE(whole.code == 0);
  const auto summary = nlohmann::json::parse(slurp(dir / "whole" / "summary.json"));
  const double dt = summary["dt"].get<double>();
  CHECK(dt > 1e-4);  // the scene's hand-picked step was well inside the limit
  const double per_frame = 1.0 / (200.0 * dt);
  CHECK(per_frame == doctest::Approx(std::round(per_frame)).epsilon(1e-12));
  // The option overrides a scene's number, and a resumed run picks the same step (the checkpoint holds it).
  const fs::path given = write(dir, "given.json", kScene);
  REQUIRE(run_cli("run " + given.string() + " --dt auto --quiet --threads 1 --frames 2 --out " + (dir / "part").string()).code == 0);
  REQUIRE(run_cli("run " + given.string() + " --dt auto --quiet --threads 1 --resume --out " + (dir / "part").string()).code == 0);
  CHECK(nlohmann::json::parse(slurp(dir / "part" / "summary.json"))["dt"].get<double>() == dt);
  int compared = 0;
  for (const auto& entry : fs::directory_iterator(dir / "whole")) {
    const auto name = entry.path().filename().string();
    if (name == "summary.json" || name == "checkpoint.bin") continue;
    CHECK_MESSAGE(slurp(entry.path()) == slurp(dir / "part" / name), name);
    ++compared;
  }
  CHECK(compared >= 20);  // frames 0..4 in four formats, and the series files
  const auto bad = run_cli("run " + given.string() + " --dt soon --quiet --out " + (dir / "bad").string());
  CHECK(bad.code == 1);
  CHECK(bad.output.find("--dt") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("cli: info prints the contact time scale, and warns when the step is longer") {
  const fs::path dir = temp_dir("contact_time_scale");
  std::string text = kScene;
  text.replace(text.rfind("\n}"), 2, ",\n  \"contact\": { \"enabled\": true }\n}");
  const auto automatic = run_cli("info " + write(dir, "auto.json", text).string());
  REQUIRE(automatic.code == 0);
  CHECK(automatic.output.find("contact          time scale ") != std::string::npos);
  CHECK(automatic.output.find("(auto; ") != std::string::npos);
  CHECK(automatic.output.find("longer than the contact time scale") == std::string::npos);  // 1e-4 s is within it
  text.replace(text.find("\"enabled\": true"), 15, "\"enabled\": true, \"time_scale\": 2e-5");
  const auto given = run_cli("info " + write(dir, "given.json", text).string());
  REQUIRE(given.code == 0);  // a warning, not an error: the step is stable
  CHECK(given.output.find("time scale 2e-05 s (given; ") != std::string::npos);
  CHECK(given.output.find("warning: time/dt 0.0001 s is longer than the contact time scale 2e-05 s") != std::string::npos);
  // The same from the command line, over the scene's "auto"; a bad value is a usage error.
  const fs::path automatic_scene = dir / "auto.json";
  const auto option = run_cli("info " + automatic_scene.string() + " --contact-time-scale 2e-5");
  REQUIRE(option.code == 0);
  CHECK(option.output.find("time scale 2e-05 s (given; ") != std::string::npos);
  const auto bad = run_cli("info " + automatic_scene.string() + " --contact-time-scale soon");
  CHECK(bad.code == 1);
  CHECK(bad.output.find("--contact-time-scale expects a positive number of seconds or auto, got 'soon'") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("cli: a time step above the stable limit is refused with the limit in the message") {
  const fs::path dir = temp_dir("unstable");
  std::string text = kScene;
  text.replace(text.find("1e-4"), 4, "5e-2");
  text.replace(text.find("0.02,"), 5, "1.0, ");
  text.replace(text.find("\"frame_rate\": 200"), 18, "\"frame_rate\": 10");  // frames at least dt apart
  const fs::path scene = write(dir, "scene.json", text);
  const auto r = run_cli("run " + scene.string() + " --quiet --out " + (dir / "out").string());
  CHECK(r.code == 4);
  CHECK(r.output.find("above the stable explicit limit") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("cli: every shipped scene passes check") {
  int count = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(PERIFX_SOURCE_DIR) / "assets" / "scenes")) {
    if (entry.path().extension() != ".json") continue;
    const auto r = run_cli("check " + entry.path().string());
    CHECK_MESSAGE(r.code == 0, r.output);
    ++count;
  }
  CHECK(count >= 3);
}

TEST_CASE("cli: every command has --help (exit 0) and perifx --version prints the project version") {
  for (const char* command : {"run", "check", "info", "spec", "compare", "render"}) {
    const auto r = run_cli(std::string(command) + " --help");
    CHECK_MESSAGE(r.code == 0, command);
    CHECK_MESSAGE(r.output.find("Usage:") != std::string::npos, r.output);
  }
  CHECK(run_cli("--help").code == 0);
  const auto version = run_cli("--version");
  CHECK(version.code == 0);
  CHECK(version.output == std::string("perifx ") + PERIFX_VERSION + "\n");
}

TEST_CASE("cli: usage errors are one line on stderr with exit code 1") {
  for (const char* args : {"", "bogus", "run", "run x.json --frames 0", "run x.json --solver magic", "run x.json --nope",
                           "compare only_one", "render"}) {
    const auto r = run_cli(args);
    CHECK_MESSAGE(r.code == 1, args);
    CHECK_MESSAGE(std::count(r.output.begin(), r.output.end(), '\n') == 1, r.output);
    CHECK_MESSAGE(r.output.rfind("perifx: ", 0) == 0, r.output);
  }
}

TEST_CASE("cli: summary.json is valid JSON for a scene name with quotes and backslashes") {
  const fs::path dir = temp_dir("summary");
  std::string text = kScene;
  text.insert(text.find('{') + 1, R"( "name": "a \"quoted\" \\ name",)");
  const fs::path scene = write(dir, "scene.json", text);
  const auto r = run_cli("run " + scene.string() + " --quiet --frames 1 --out " + (dir / "out").string());
  REQUIRE_MESSAGE(r.code == 0, r.output);
  const auto summary = nlohmann::json::parse(slurp(dir / "out" / "summary.json"));
  CHECK(summary.at("scene").get<std::string>() == "a \"quoted\" \\ name");
  CHECK(summary.at("frames").get<int>() == 1);
  fs::remove_all(dir);
}

TEST_CASE("cli: info prints each material in physical units, and what its yield stress means") {
  const fs::path dir = temp_dir("info_materials");
  // σ_y/E = 0.4 %: the per-bond law's 0.2 % offset yield is 0.933 of the flow stress (systems/yield_law.hpp).
  const fs::path scene = write(dir, "scene.json", R"({
    "time": { "dt": 1e-5, "duration": 0.01, "frame_rate": 100 },
    "materials": { "metal": { "density": 2700, "youngs_modulus": 5e6, "poisson_ratio": 0.25, "yield_stress": 2e4,
                              "fracture_energy": 30 } },
    "bodies": [ { "material": "metal", "geometry": { "type": "box", "size": [0.1, 0.05, 0.05], "edge_length": 0.025 } } ]
  })");
  const auto r = run_cli("info " + scene.string());
  REQUIRE_MESSAGE(r.code == 0, r.output);
  // κ = E/(3(1 − 2ν)), μ = E/(2(1 + ν)); the ratio printed to 4 digits (0.9328 at ν = 0.25).
  std::ostringstream ratio;
  ratio.precision(4);
  ratio << perifx::systems::offset_yield_ratio(5e6 / 1.5, 5e6 / 2.5, 2e4);
  CHECK(ratio.str() == "0.9328");
  CHECK_MESSAGE(r.output.find("material         metal: density 2700 kg/m^3, E 5e+06 Pa, nu 0.25, fracture_energy 30 "
                              "J/m^2, yield_stress 2e+04 Pa (the flow stress; 0.2 % offset yield " + ratio.str() + " of it)") !=
                    std::string::npos,
                r.output);
  // Given as a 0.2 % offset yield stress instead, info names the flow stress set-up derives from it.
  const fs::path offset = write(dir, "offset.json", R"({
    "time": { "dt": 1e-5, "duration": 0.01, "frame_rate": 100 },
    "materials": { "metal": { "density": 2700, "youngs_modulus": 5e6, "poisson_ratio": 0.25, "offset_yield_stress": 2e4 } },
    "bodies": [ { "material": "metal", "geometry": { "type": "box", "size": [0.1, 0.05, 0.05], "edge_length": 0.025 } } ]
  })");
  const auto o = run_cli("info " + offset.string());
  REQUIRE_MESSAGE(o.code == 0, o.output);
  std::ostringstream flow;
  flow.precision(4);
  flow << perifx::systems::flow_stress_for_offset_yield(5e6 / 1.5, 5e6 / 2.5, 2e4);
  CHECK(flow.str() == "2.155e+04");  // 1.078 × the offset stress at σ/E = 0.4 %
  CHECK_MESSAGE(o.output.find("offset_yield_stress 2e+04 Pa (0.2 % offset; the flow stress it sets is " + flow.str() + " Pa)") !=
                    std::string::npos,
                o.output);
  fs::remove_all(dir);
}

TEST_CASE("cli: run says when a large world is being set up, and how long set-up took") {
  // 118,098 particles (27 cells of 1.11 cm across a 30 cm cube asked for at 1.1 cm, 6 tets each), one step.
  const auto dir = temp_dir("setup_lines");
  const auto scene = write(dir, "big.json", R"({
    "time": { "dt": 1e-5, "duration": 1e-5, "frame_rate": 1e5 },
    "materials": { "gel": { "density": 1000, "youngs_modulus": 1e6, "poisson_ratio": 0.3 } },
    "bodies": [ { "material": "gel", "geometry": { "type": "box", "size": [0.3, 0.3, 0.3], "edge_length": 0.011 } } ],
    "output": { "formats": ["vtu"] } })");
  const auto big = run_cli("run " + scene.string() + " --threads 2 --out " + (dir / "out").string());
  REQUIRE(big.code == 0);
  CHECK(big.output.find(": setting up 118098 particles (estimated peak ") != std::string::npos);
  CHECK(big.output.find(": 118098 particles, ") != std::string::npos);
  CHECK(big.output.find(" threads, set up in ") != std::string::npos);
  CHECK(big.output.find("setting up") < big.output.find("set up in"));
  // A small world gets only the line after set-up; --quiet gets neither.
  const auto small = run_cli("run " + write(dir, "small.json", kScene).string() + " --threads 1 --frames 1 --out " +
                             (dir / "small").string());
  REQUIRE(small.code == 0);
  CHECK(small.output.find("setting up") == std::string::npos);
  CHECK(small.output.find("set up in ") != std::string::npos);
  const auto quiet = run_cli("run " + scene.string() + " --quiet --overwrite --out " + (dir / "out").string());
  REQUIRE(quiet.code == 0);
  CHECK(quiet.output.find("set") == std::string::npos);
}

TEST_CASE("cli: perifx restarts itself with malloc asking for huge pages, unless told not to") {
  // setup/preflight.hpp (restart_with_huge_page_malloc). `perifx info` prints the process's resident
  // memory and the part in 2 MiB pages. The fig07 preview's set-up allocates ~20 MiB through malloc
  // besides the arrays that advise huge pages themselves (none of its arrays is large enough for that,
  // kHugePageMinBytes), so with the restart some of it is in huge pages, and without none is.
  std::string mode;
  std::getline(std::ifstream("/sys/kernel/mm/transparent_hugepage/enabled"), mode);
  if (mode.find("[madvise]") == std::string::npos) {
    MESSAGE("skipped: transparent huge pages are not in madvise mode here (" << mode << "); the restart does nothing");
    return;
  }
  auto huge_bytes = [](const std::string& output) {
    const auto at = output.find("in huge pages ");
    REQUIRE(at != std::string::npos);
    std::istringstream in(output.substr(at + 14));
    double value = 0.0;
    std::string unit;
    in >> value >> unit;
    const double scale = unit == "KiB" ? 1024.0 : unit == "MiB" ? 1048576.0 : unit == "GiB" ? 1073741824.0 : 1.0;
    return value * scale;
  };
  const char* saved = std::getenv("GLIBC_TUNABLES");
  const std::string saved_value = saved ? saved : "";
  const std::string info = "info " + (fs::path(PERIFX_SOURCE_DIR) / "assets/scenes/paper/fig07_glass_alpha.preview.json").string();
  ::unsetenv("GLIBC_TUNABLES");
  const auto restarted = run_cli(info);
  ::setenv("PERIFX_HUGE_PAGE_MALLOC", "0", 1);
  const auto opted_out = run_cli(info);
  ::unsetenv("PERIFX_HUGE_PAGE_MALLOC");
  ::setenv("GLIBC_TUNABLES", "glibc.malloc.hugetlb=0", 1);  // the user's own setting stands
  const auto users_choice = run_cli(info);
  if (saved) ::setenv("GLIBC_TUNABLES", saved_value.c_str(), 1);
  else ::unsetenv("GLIBC_TUNABLES");
  REQUIRE(restarted.code == 0);
  REQUIRE(opted_out.code == 0);
  REQUIRE(users_choice.code == 0);
  CHECK(huge_bytes(restarted.output) >= 4.0 * 1048576.0);  // at least two 2 MiB pages (14 MiB measured)
  CHECK(huge_bytes(opted_out.output) == 0.0);
  CHECK(huge_bytes(users_choice.output) == 0.0);
}

TEST_CASE("cli: info --ranks N prints one row per rank covering every particle; a bad N is a usage error") {
  const fs::path dir = temp_dir("info_ranks");
  const fs::path scene = write(dir, "scene.json", kScene);
  const auto r = run_cli("info " + scene.string() + " --ranks 3");
  REQUIRE(r.code == 0);
  std::istringstream lines(r.output);
  std::size_t rows = 0, owned = 0, particles = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("particles        ", 0) == 0) particles = std::stoul(line.substr(17));
    unsigned rank = 0, first = 0, count = 0;
    if (std::sscanf(line.c_str(), "%u %u %u", &rank, &first, &count) == 3) {  // a rank row (the schedule's rows are "N name")
      CHECK(rank == rows);
      CHECK(first == owned);  // contiguous ranges in rank order
      owned += count;
      ++rows;
    }
  }
  CHECK(rows == 3);
  CHECK(owned == particles);
  CHECK(r.output.find("x the mean bonds") != std::string::npos);
  // The FEM solver splits by tet corners and says so.
  const auto fem = run_cli("info " + scene.string() + " --ranks 3 --solver fem_linear");
  REQUIRE(fem.code == 0);
  CHECK(fem.output.find("x the mean tet corners") != std::string::npos);
  CHECK(fem.output.find("rank  first_particle  particles  tet_corners  ghosts  tet_ghosts") != std::string::npos);
  const auto bad = run_cli("info " + scene.string() + " --ranks 0");
  CHECK(bad.code == 1);
  CHECK(bad.output.find("--ranks expects an integer >= 1") != std::string::npos);
  const auto many = run_cli("info " + scene.string() + " --ranks 100000000");
  CHECK(many.code == 1);
  CHECK(many.output.find("--ranks expects 1 to the particle count") != std::string::npos);
}

TEST_CASE("cli: --solver fem_* runs a peridynamic scene again, leaving out the mesh-only formats and saying so") {
  // The README's comparison run: the same scene (here with a ground collider, a velocity condition and
  // the formats an artist lists) through the FEM reference solver. The formats only the embedded mesh
  // writes are left out with a note; a scene that itself chooses FEM and lists them is still refused.
  const fs::path dir = temp_dir("fem_override");
  std::string text = kScene;
  text.insert(text.rfind('}'), R"(, "output": { "formats": ["vtu", "obj", "surface_ply", "gltf"] })");
  const fs::path scene = write(dir, "scene.json", text);
  const auto fem = run_cli("run " + scene.string() + " --quiet --frames 2 --solver fem_corotated --out " + (dir / "fem").string());
  CHECK(fem.code == 0);
  CHECK(fem.output.find("--solver fem_corotated: output formats obj, surface_ply, gltf left out") != std::string::npos);
  CHECK(fs::exists(dir / "fem" / "particles.0002.vtu"));
  CHECK_FALSE(fs::exists(dir / "fem" / "surface.0002.obj"));
  CHECK_FALSE(fs::exists(dir / "fem" / "animation.glb"));
  std::string own = text;
  own.insert(own.rfind('}'), R"(, "model": { "solver": "fem_linear" })");
  const fs::path own_scene = write(dir, "own.json", own);
  const auto refused = run_cli("run " + own_scene.string() + " --quiet --frames 2 --out " + (dir / "own").string());
  CHECK(refused.code == 2);
  CHECK(refused.output.find("/output/formats") != std::string::npos);
  // A scene the FEM solver cannot run (breakable materials; it lists mesh formats) is refused with no note before the error.
  const auto breakable = run_cli("run " + fs::path(PERIFX_SOURCE_DIR).append("tests/engine/distributed/mpi_impact.json").string() +
                                 " --frames 1 --solver fem_linear --out " + (dir / "tear").string());
  CHECK(breakable.code == 2);
  CHECK(breakable.output.find("/model/solver: the FEM reference solver is elastic only") != std::string::npos);
  CHECK(breakable.output.find("left out") == std::string::npos);
  fs::remove_all(dir);
}
