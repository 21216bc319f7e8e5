// Long test (PERIFX_LONG_TESTS=1): every shipped fracture preview, run for all its frames with surface
// PLY output, passes `perifx check-surface` with every count 0 (far, inverted, open, non-manifold,
// stretched; issue 11 item 2). Slow: the previews take minutes each on 2 shared cores
// (assets/report/surfaces.md lists the times). PERIFX_SURFACE_PREVIEW=<name> runs one preview only.
#include <doctest/doctest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>

#include "perifx/scene.hpp"
#include "runner.hpp"
#include "tools/surface_check.hpp"

using namespace perifx;
namespace fs = std::filesystem;

namespace {

bool long_tests() {
  const char* v = std::getenv("PERIFX_LONG_TESTS");
  return v && std::string(v) == "1";
}

const fs::path kScenes = fs::path(PERIFX_SOURCE_DIR) / "assets" / "scenes";

// The shipped scenes that break (fracture previews) and the fracture showcase.
const char* const kFracture[] = {
    "paper/fig01_brittle_walls.preview.json", "paper/fig01_ductile_walls.preview.json",
    "paper/fig05_ductile_fracture.preview.json", "paper/fig06_crack_patterns.preview.json",
    "paper/fig07_glass_alpha.preview.json", "paper/fig14_creature_tear.preview.json",
    "paper/fig15_glass_ball_press.preview.json", "paper/fig16_bunny_drop.preview.json",
    "paper/fig17_thin_sheet.preview.json", "showcase.json",
};

}  // namespace

TEST_CASE("check-surface: every fracture preview, every frame, all counts 0 (PERIFX_LONG_TESTS=1)" *
          doctest::skip(!long_tests())) {
  const char* only = std::getenv("PERIFX_SURFACE_PREVIEW");
  for (const char* rel : kFracture) {
    const fs::path file = kScenes / rel;
    if (only && file.filename().string().find(only) == std::string::npos) continue;
    INFO("scene " << std::string(rel));
    scene::Scene sc = scene::load_scene_file(file);
    sc.output.vtu = false;
    sc.output.ply = true;  // the checker reads the particles' fragment_id
    sc.output.obj = false;
    sc.output.surface_ply = true;
    sc.output.surface_vtp = sc.output.tets_vtu = sc.output.cache = sc.output.gltf = false;
    sc.output.checkpoint_every = 0;
    const fs::path dir = fs::temp_directory_path() / ("perifx_surface_previews_" + std::to_string(::getpid())) /
                         file.stem().string();
    fs::remove_all(dir);
    {
      World world(sc);
      RunOptions opt;
      opt.output_directory = dir;
      run_world(world, opt);
    }
    const auto report = check_run_surfaces(dir);
    std::ostringstream table;
    print_surface_check(table, report);
    MESSAGE(rel << "\n" << table.str());
    for (const auto& f : report.frames) {
      INFO("frame " << f.frame);
      CHECK(f.far_vertices == 0);
      CHECK(f.inverted_shells == 0);
      CHECK(f.open_edges == 0);
      CHECK(f.nonmanifold_edges == 0);
      CHECK(f.stretched_triangles == 0);
    }
    fs::remove_all(dir);
  }
}
