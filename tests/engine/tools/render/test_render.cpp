// perifx render: PNG encoder (decoded back with libpng's reader), the built-in
// rasterizer, camera framing, the run-directory readers and `perifx render` end to end (built-in
// backend, so it runs without povray; the POV-Ray case skips when povray is not installed).
#include <doctest/doctest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <png.h>

#include "cli_support.hpp"
#include "io/atomic.hpp"
#include "io/obj.hpp"
#include "io/ply.hpp"
#include "io/vtk.hpp"
#include "tools/render/png.hpp"
#include "tools/render/render.hpp"
#include "tools/render/render_run.hpp"
#include "io/run_dir.hpp"
#include "file_support.hpp"

namespace fs = std::filesystem;
using namespace perifx;
using namespace perifx::render;

namespace {

using perifx::test::slurp;

// Exit code of `perifx ARGS`; the output goes to *output when given.
int run_cli(const std::string& args, std::string* output = nullptr) {
  auto r = perifx::test::run_cli(args);
  if (output) *output = r.output;
  return r.code;
}

std::uint32_t be32(const std::string& s, std::size_t at) {
  return std::uint32_t(std::uint8_t(s[at])) << 24 | std::uint32_t(std::uint8_t(s[at + 1])) << 16 |
         std::uint32_t(std::uint8_t(s[at + 2])) << 8 | std::uint32_t(std::uint8_t(s[at + 3]));
}

struct Decoded {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
};

// Decodes with libpng (independent of how the file was encoded) and checks it is 8-bit RGB.
Decoded decode_png(const std::string& png) {
  REQUIRE(png.size() > 8);
  REQUIRE(png.compare(0, 8, std::string("\x89PNG\r\n\x1a\n", 8)) == 0);
  CHECK(png[25] == 2);  // IHDR colour type: truecolour RGB
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  REQUIRE(png_image_begin_read_from_memory(&image, png.data(), png.size()));
  image.format = PNG_FORMAT_RGB;
  Decoded d;
  d.width = int(image.width);
  d.height = int(image.height);
  d.rgb.resize(PNG_IMAGE_SIZE(image));
  REQUIRE(png_image_finish_read(&image, nullptr, d.rgb.data(), 0, nullptr));
  return d;
}


fs::path temp_dir(const std::string& name) { return perifx::test::temp_dir("render", name); }


// A ball of particles of radius 0.5 at the origin, on a jittered lattice.
RenderScene particle_ball() {
  RenderScene s;
  const double h = 0.1;
  for (int i = -5; i <= 5; ++i)
    for (int j = -5; j <= 5; ++j)
      for (int k = -5; k <= 5; ++k) {
        const Vec3 p(i * h, j * h, k * h);
        if (p.norm() <= 0.5) s.spheres.push_back({p, 0.6 * h, damage_color(p.norm())});
      }
  return s;
}

std::array<std::uint8_t, 3> pixel(const Image& img, int x, int y) {
  const std::size_t i = (std::size_t(y) * std::size_t(img.width) + std::size_t(x)) * 3;
  return {img.rgb[i], img.rgb[i + 1], img.rgb[i + 2]};
}

}  // namespace

TEST_CASE("render: PNG encoder output decodes back to the same pixels") {
  const int w = 37, h = 23;
  std::vector<std::uint8_t> rgb(std::size_t(w) * h * 3);
  std::uint32_t state = 12345;
  for (std::size_t i = 0; i < rgb.size(); ++i) {
    state = state * 1664525u + 1013904223u;
    // Half noise, half smooth and repetitive, so literals, matches and every filter all occur.
    rgb[i] = (i / 3) % w < std::size_t(w / 2) ? std::uint8_t(state >> 24) : std::uint8_t((i / 3) % w * 5 + (i % 3) * 40);
  }
  const std::string png = encode_png(w, h, rgb);
  const Decoded d = decode_png(png);
  CHECK(d.width == w);
  CHECK(d.height == h);
  CHECK(d.rgb == rgb);

  // Flat images compress well.
  std::vector<std::uint8_t> flat(std::size_t(400) * 300 * 3, 200);
  const std::string flat_png = encode_png(400, 300, flat);
  CHECK(flat_png.size() < flat.size() / 50);
  CHECK(decode_png(flat_png).rgb == flat);
}

TEST_CASE("render: built-in rasterizer draws a particle ball over the background") {
  RenderScene s = particle_ball();
  s.camera = frame_box(Vec3::Constant(-0.55), Vec3::Constant(0.55), 4.0 / 3.0);
  s.lights = default_lights(s.camera, Vec3::Constant(-0.55), Vec3::Constant(0.55));
  RenderScene empty = s;
  empty.spheres.clear();
  const Image img = rasterize(s, 64, 48), bg = rasterize(empty, 64, 48);
  REQUIRE(img.width == 64);
  REQUIRE(img.height == 48);
  REQUIRE(img.rgb.size() == 64u * 48u * 3u);
  CHECK(pixel(img, 32, 24) != pixel(bg, 32, 24));
  CHECK(pixel(img, 0, 0) == pixel(bg, 0, 0));
  CHECK(pixel(img, 63, 47) == pixel(bg, 63, 47));
  // Lit, not black: the ball's center pixel has real brightness.
  const auto c = pixel(img, 32, 24);
  CHECK(int(c[0]) + c[1] + c[2] > 120);

  const fs::path dir = temp_dir("png");
  write_png(dir / "ball.png", img.width, img.height, img.rgb);
  const Decoded d = decode_png(slurp(dir / "ball.png"));
  CHECK(d.width == 64);
  CHECK(d.height == 48);
  CHECK(d.rgb == img.rgb);
  fs::remove_all(dir);
}

TEST_CASE("render: default camera framing keeps every point of the box in the image") {
  for (const Vec3& size : {Vec3(1, 1, 1), Vec3(4, 0.2, 0.3), Vec3(0.1, 3, 0.1), Vec3(2, 1, 0.05)}) {
    const Vec3 lo = Vec3(0.3, -1.0, 2.0), hi = lo + size;
    for (const double aspect : {16.0 / 9.0, 1.0, 0.6}) {
      const int w = int(std::lround(400 * aspect)), h = 400;
      const Camera cam = frame_box(lo, hi, double(w) / h);
      double min_x = 1e9, max_x = -1e9, min_y = 1e9, max_y = -1e9;
      for (int k = 0; k < 8; ++k) {
        const Vec3 corner((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(), (k & 4) ? hi.z() : lo.z());
        const Vec3 p = project(cam, w, h, corner);
        CHECK(p.z() > 0);
        min_x = std::min(min_x, p.x()), max_x = std::max(max_x, p.x());
        min_y = std::min(min_y, p.y()), max_y = std::max(max_y, p.y());
      }
      CHECK(min_x >= 0);
      CHECK(max_x <= w);
      CHECK(min_y >= 0);
      CHECK(max_y <= h);
      // Tight: the box fills most of one image dimension.
      CHECK(std::max((max_x - min_x) / w, (max_y - min_y) / h) > 0.7);
      // Elevated 3/4 view with Y up.
      CHECK(cam.position.y() > 0.5 * (lo.y() + hi.y()));
    }
  }
}

TEST_CASE("render: readers round-trip VTU particles and PLY/OBJ surfaces with crack flags") {
  const fs::path dir = temp_dir("readers");
  const std::vector<Vec3> pts = {Vec3(0, 1, 2), Vec3(-1, 0.5, 3), Vec3(4, 5, -6)};
  const std::vector<double> volume = {1e-3, 2e-3, 3e-3}, damage = {0.0, 0.5, 1.0};
  const std::vector<std::uint32_t> material = {0, 1, 2};
  const std::vector<Vec3> velocity(3, Vec3(1, 2, 3));
  auto field = [](const char* name, FieldType t, int comps, const void* data) {
    FieldView f;
    f.name = name;
    f.type = t;
    f.components = comps;
    f.data = data;
    f.count = 3;
    return f;
  };
  const std::vector<FieldView> fields = {field("velocity", FieldType::f64, 3, velocity.data()),
                                         field("volume", FieldType::f64, 1, volume.data()),
                                         field("damage", FieldType::f64, 1, damage.data()),
                                         field("material_id", FieldType::u32, 1, material.data())};
  io::write_vtu_points(dir / "particles.0000.vtu", pts, fields);
  io::write_ply_points(dir / "particles.0001.ply", pts, fields);
  for (const auto& file : {dir / "particles.0000.vtu", dir / "particles.0001.ply"}) {
    CAPTURE(file);
    const ParticleFrame f = io::read_particle_frame(file);
    REQUIRE(f.position.size() == 3);
    CHECK((f.position[2] - pts[2]).norm() < 1e-6);
    REQUIRE(f.volume.size() == 3);
    CHECK(f.volume[1] == doctest::Approx(2e-3));
    CHECK(f.damage.at(2) == doctest::Approx(1.0));
    CHECK(f.material.at(2) == 2u);
  }

  std::ofstream(dir / "surface.0002.obj") << "mtllib surface.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
                                             "g surface\nusemtl surface\nf 1 2 3\ng crack\nusemtl crack\nf 2 4 3\n";
  const SurfaceFrame obj = io::read_surface_frame(dir / "surface.0002.obj");
  REQUIRE(obj.triangle.size() == 2);
  REQUIRE(obj.crack.size() == 2);
  CHECK(obj.crack[0] == 0);
  CHECK(obj.crack[1] == 1);

  {  // binary PLY surface as engine/io writes it: list uchar int vertex_indices, uchar crack, uint fragment
    std::ofstream ply(dir / "surface.0003.ply", std::ios::binary);
    ply << "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
           "property float z\nelement face 2\nproperty list uchar int vertex_indices\nproperty uchar crack\n"
           "property uint fragment\nend_header\n";
    for (const float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f, 1.f, 1.f, 0.f}) ply.write(reinterpret_cast<const char*>(&v), 4);
    for (int face = 0; face < 2; ++face) {
      const std::uint8_t n = 3, crack = std::uint8_t(face);
      const std::int32_t idx[2][3] = {{0, 1, 2}, {1, 3, 2}};
      const std::uint32_t fragment = 7;
      ply.write(reinterpret_cast<const char*>(&n), 1);
      ply.write(reinterpret_cast<const char*>(idx[face]), 12);
      ply.write(reinterpret_cast<const char*>(&crack), 1);
      ply.write(reinterpret_cast<const char*>(&fragment), 4);
    }
  }
  const SurfaceFrame ply = io::read_surface_frame(dir / "surface.0003.ply");
  REQUIRE(ply.triangle.size() == 2);
  CHECK(ply.triangle[1] == std::array<std::uint32_t, 3>{1, 3, 2});
  REQUIRE(ply.crack.size() == 2);
  CHECK(ply.crack[1] == 1);
  const RenderScene scene = frame_scene(nullptr, &ply, {}, FrameStyle{});
  REQUIRE(scene.triangles.size() == 2);
  CHECK(scene.triangles[0].color != scene.triangles[1].color);  // crack faces in their own colour

  const RunDirectory run = io::scan_run_directory(dir);
  REQUIRE(run.frames.size() == 4);
  CHECK(run.frames[2].surface.filename() == "surface.0002.obj");
  CHECK(run.frames[1].particles.filename() == "particles.0001.ply");
  fs::remove_all(dir);
}

TEST_CASE("render: perifx render turns a two-frame run into PNGs with the built-in backend") {
  const fs::path dir = temp_dir("cli");
  std::ofstream(dir / "scene.json") << R"({
    "time": { "dt": 1e-4, "duration": 0.02, "frame_rate": 200 },
    "materials": { "gel": { "density": 1000, "youngs_modulus": 1e6, "poisson_ratio": 0.3 } },
    "bodies": [ { "material": "gel", "geometry": { "type": "box", "size": [0.2, 0.1, 0.1], "edge_length": 0.025 },
                  "transform": { "translate": [0, 0.2, 0] }, "velocity": [0, -1, 0] } ],
    "projectiles": [ { "type": "sphere", "center": [0, 0.4, 0], "radius": 0.05, "density": 1000, "velocity": [0, -1, 0] } ]
  })";
  std::string out;
  REQUIRE(run_cli("run " + (dir / "scene.json").string() + " --out " + (dir / "run").string() + " --frames 2 --quiet", &out) == 0);
  const int rc = run_cli("render " + (dir / "run").string() + " --backend builtin --width 96 --height 64 --mp4", &out);
  CAPTURE(out);
  REQUIRE(rc == 0);
  for (const char* name : {"frame.0000.png", "frame.0001.png", "frame.0002.png"}) {
    CAPTURE(name);
    const Decoded d = decode_png(slurp(dir / "run" / "render" / name));
    CHECK(d.width == 96);
    CHECK(d.height == 64);
  }
  CHECK(out.find("frame 3/3") != std::string::npos);
  if (!find_program("ffmpeg").empty()) CHECK(fs::file_size(dir / "run" / "render" / "movie.mp4") > 0);

  // A frame range and an output directory; bad options are usage errors; a missing run is exit 2.
  REQUIRE(run_cli("render " + (dir / "run").string() + " --backend builtin --width 32 --height 32 --frames 1:1 --quiet --out " +
                  (dir / "only1").string()) == 0);
  CHECK(fs::exists(dir / "only1" / "frame.0001.png"));
  CHECK_FALSE(fs::exists(dir / "only1" / "frame.0000.png"));
  CHECK(run_cli("render " + (dir / "run").string() + " --color-by rainbow") == 1);
  CHECK(run_cli("render " + (dir / "nothing").string() + " --backend builtin") == 2);
  CHECK(run_cli("render " + (dir / "run").string() + " --frames 7:9 --backend builtin") == 2);
  fs::remove_all(dir);
}

TEST_CASE("render: --draw chooses surface or particles, --view --zoom --fit-frames --cut shape the view, --threads") {
  const fs::path dir = temp_dir("draw");
  // A breakable bar with surface output: frames have both particles and surface files.
  std::ofstream(dir / "scene.json") << R"({
    "time": { "dt": 1e-4, "duration": 0.01, "frame_rate": 100 },
    "materials": { "gel": { "density": 1000, "youngs_modulus": 1e6, "poisson_ratio": 0.3, "critical_stretch": 0.5 } },
    "bodies": [ { "material": "gel", "geometry": { "type": "box", "size": [0.2, 0.1, 0.1], "edge_length": 0.025 },
                  "transform": { "translate": [0, 0.2, 0] } } ],
    "output": { "formats": ["vtu", "surface_ply"] }
  })";
  const std::string run = (dir / "run").string();
  REQUIRE(run_cli("run " + (dir / "scene.json").string() + " --out " + run + " --frames 1 --quiet") == 0);
  REQUIRE(fs::exists(dir / "run" / "surface.0001.ply"));
  const std::string common = "render " + run + " --backend builtin --width 48 --height 32 --frames 1 --threads 1 --out ";

  // The same frame drawn from the surface (default) and from the particles differs.
  std::string out;
  REQUIRE(run_cli(common + (dir / "auto").string() + " --quiet", &out) == 0);
  REQUIRE(run_cli(common + (dir / "particles").string() + " --draw particles --quiet") == 0);
  REQUIRE(run_cli(common + (dir / "surface").string() + " --draw surface --quiet") == 0);
  const auto auto_px = decode_png(slurp(dir / "auto" / "frame.0001.png")).rgb;
  CHECK(auto_px == decode_png(slurp(dir / "surface" / "frame.0001.png")).rgb);
  CHECK(auto_px != decode_png(slurp(dir / "particles" / "frame.0001.png")).rgb);

  // An explicit --color-by damage cannot colour the surface (no damage in it): particles, with a note.
  REQUIRE(run_cli(common + (dir / "damage").string() + " --color-by damage", &out) == 0);
  CHECK(out.find("drawing the particles") != std::string::npos);
  CHECK(decode_png(slurp(dir / "damage" / "frame.0001.png")).rgb != auto_px);
  // Nothing is damaged, so the automatic colouring is by material, not the all-blue damage map.
  REQUIRE(run_cli(common + (dir / "by_material").string() + " --draw particles --color-by material --quiet") == 0);
  const auto particles_px = decode_png(slurp(dir / "particles" / "frame.0001.png")).rgb;
  CHECK(particles_px == decode_png(slurp(dir / "by_material" / "frame.0001.png")).rgb);
  CHECK(particles_px != decode_png(slurp(dir / "damage" / "frame.0001.png")).rgb);

  // Another view direction gives another image; one thread gives the same pixels as the default.
  REQUIRE(run_cli(common + (dir / "top").string() + " --view 0,1,0.2 --quiet") == 0);
  CHECK(decode_png(slurp(dir / "top" / "frame.0001.png")).rgb != auto_px);
  REQUIRE(run_cli("render " + run + " --backend builtin --width 48 --height 32 --frames 1 --quiet --out " +
                  (dir / "all_threads").string()) == 0);
  CHECK(decode_png(slurp(dir / "all_threads" / "frame.0001.png")).rgb == auto_px);
  // Zoom moves the camera; framing on frame 0 (the same bar at rest) gives the same picture here.
  REQUIRE(run_cli(common + (dir / "zoom").string() + " --zoom 2 --quiet") == 0);
  CHECK(decode_png(slurp(dir / "zoom" / "frame.0001.png")).rgb != auto_px);
  REQUIRE(run_cli(common + (dir / "fit").string() + " --fit-frames 0 --quiet") == 0);
  CHECK(fs::exists(dir / "fit" / "frame.0001.png"));
  CHECK_FALSE(fs::exists(dir / "fit" / "frame.0000.png"));
  // A cut through the middle of the bar hides part of it; a cut beyond it hides nothing.
  REQUIRE(run_cli(common + (dir / "cut").string() + " --cut 0,0,2,0 --quiet") == 0);
  CHECK(decode_png(slurp(dir / "cut" / "frame.0001.png")).rgb != auto_px);
  REQUIRE(run_cli(common + (dir / "nocut").string() + " --cut 0,0,1,5 --quiet") == 0);
  CHECK(decode_png(slurp(dir / "nocut" / "frame.0001.png")).rgb == auto_px);

  // Bad values are usage errors; --draw surface on a run without surfaces is exit 2.
  CHECK(run_cli(common + (dir / "x").string() + " --draw mesh") == 1);
  CHECK(run_cli(common + (dir / "x").string() + " --view 0,0,0") == 1);
  CHECK(run_cli(common + (dir / "x").string() + " --view 1,2") == 1);
  CHECK(run_cli(common + (dir / "x").string() + " --threads 0") == 1);
  CHECK(run_cli(common + (dir / "x").string() + " --zoom 0") == 1);
  CHECK(run_cli(common + (dir / "x").string() + " --cut 0,0,0,1") == 1);
  CHECK(run_cli(common + (dir / "x").string() + " --cut 0,0,1") == 1);
  CHECK(run_cli(common + (dir / "x").string() + " --fit-frames 2:1") == 1);
  CHECK(run_cli(common + (dir / "x").string() + " --fit-frames 5:9") == 2);
  for (const auto& e : fs::directory_iterator(dir / "run"))
    if (e.path().filename().string().rfind("surface.", 0) == 0) fs::remove(e.path());
  CHECK(run_cli(common + (dir / "x").string() + " --draw surface") == 2);
  fs::remove_all(dir);
}

TEST_CASE("render: a cut plane leaves out particles, triangles and projectiles beyond it") {
  ParticleFrame p;
  p.position = {Vec3(0, 0, 0), Vec3(0, 1, 0), Vec3(0, 2, 0)};
  SurfaceFrame surf;
  surf.vertex = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 0, 1), Vec3(0, 2, 0), Vec3(1, 2, 0), Vec3(0, 2, 1)};
  surf.triangle = {{0, 1, 2}, {3, 4, 5}};
  const std::vector<ProjectileState> balls = {{0, Vec3(0, 0.5, 0), 0.1}, {1, Vec3(0, 3, 0), 0.1}};
  FrameStyle style;
  style.cut = CutPlane{Vec3::UnitY(), 1.5};  // keep y <= 1.5
  const RenderScene a = frame_scene(&p, nullptr, balls, style);
  CHECK(a.spheres.size() == 2);
  REQUIRE(a.metal.size() == 1);
  CHECK(a.metal[0].center.y() == 0.5);
  const RenderScene b = frame_scene(nullptr, &surf, balls, style);
  REQUIRE(b.triangles.size() == 1);
  CHECK(b.triangles[0].a.y() == 0.0);
  style.cut.reset();
  CHECK(frame_scene(&p, nullptr, balls, style).spheres.size() == 3);
}

TEST_CASE("render: POV-Ray backend renders a frame (skipped without povray)") {
  RenderScene s = particle_ball();
  s.metal.push_back({Vec3(0.8, 0, 0), 0.2, Vec3::Ones()});
  s.triangles.push_back({Vec3(-1, -0.6, -1), Vec3(1, -0.6, -1), Vec3(0, -0.6, 1), Vec3(0.9, 0.4, 0.1)});
  s.ground_y = -0.6;
  s.camera = frame_box(Vec3::Constant(-1), Vec3::Constant(1), 1.5);
  s.lights = default_lights(s.camera, Vec3::Constant(-1), Vec3::Constant(1));
  const PovrayFiles files = povray_scene(s, 48, 32, "data.inc");
  CHECK(files.scene.find("camera") != std::string::npos);
  CHECK(files.scene.find("#include \"data.inc\"") != std::string::npos);
  CHECK(files.data.find("mesh2") != std::string::npos);
  CHECK(files.data.find("PFX_Metal") != std::string::npos);
  if (find_program("povray").empty()) {
    MESSAGE("povray not installed: skipping the POV-Ray render");
    return;
  }
  const fs::path dir = temp_dir("povray");
  std::ofstream(dir / "scene.pov") << files.scene;
  std::ofstream(dir / "data.inc") << files.data;
  const std::string cmd = "cd " + dir.string() + " && povray +Iscene.pov +Oout.png +W48 +H32 -D +FN -V -GA >/dev/null 2>&1";
  REQUIRE(std::system(cmd.c_str()) == 0);
  const std::string png = slurp(dir / "out.png");
  REQUIRE(png.size() > 24);
  CHECK(be32(png, 16) == 48);
  CHECK(be32(png, 20) == 32);
  fs::remove_all(dir);
}
