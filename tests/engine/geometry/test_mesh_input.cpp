// Tests for mesh file input: Gmsh .msh (2.2, 4.1), closed surfaces (OBJ, PLY, STL, OFF) and their
// checks, and tetrahedralization of surfaces by the external `tetgen` program.
#include <doctest/doctest.h>
#include <stdlib.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "geometry/geometry.hpp"
#include "perifx/scene.hpp"
#include "engine/geometry/geometry_test_support.hpp"

namespace fs = std::filesystem;
using namespace perifx;
using namespace perifx::geometry;

namespace {

using Scratch = perifx::test::TempDir;
fs::path data() { return perifx::test::geometry_data_dir(); }


template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const GeometryError& e) {
    return e.what();
  }
  return "<no GeometryError thrown>";
}

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

double volume_of(const TetMesh& m) {
  double v = 0.0;
  for (std::size_t t = 0; t < m.tets.size(); ++t) v += tet_volume(m, t);
  return v;
}

double smallest_tet(const TetMesh& m) {
  double v = kInfinity;
  for (std::size_t t = 0; t < m.tets.size(); ++t) v = std::min(v, tet_volume(m, t));
  return v;
}

bool tetgen_installed() { return std::system("command -v tetgen > /dev/null 2>&1") == 0; }

// The 2 x 3 x 1 box of the fixtures as 12 triangles (outward).
SurfaceMesh box_surface() {
  SurfaceMesh s;
  s.vertices = {Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(2, 3, 0), Vec3(0, 3, 0),
                Vec3(0, 0, 1), Vec3(2, 0, 1), Vec3(2, 3, 1), Vec3(0, 3, 1)};
  const int quads[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
  for (const auto& q : quads) {
    s.triangles.push_back({std::uint32_t(q[0]), std::uint32_t(q[1]), std::uint32_t(q[2])});
    s.triangles.push_back({std::uint32_t(q[0]), std::uint32_t(q[2]), std::uint32_t(q[3])});
  }
  return s;
}

// An icosphere: an icosahedron with each triangle split `levels` times, projected on the sphere.
SurfaceMesh icosphere(double radius, int levels) {
  const double p = (1.0 + std::sqrt(5.0)) / 2.0;
  SurfaceMesh s;
  s.vertices = {Vec3(-1, p, 0), Vec3(1, p, 0), Vec3(-1, -p, 0), Vec3(1, -p, 0), Vec3(0, -1, p), Vec3(0, 1, p),
                Vec3(0, -1, -p), Vec3(0, 1, -p), Vec3(p, 0, -1), Vec3(p, 0, 1), Vec3(-p, 0, -1), Vec3(-p, 0, 1)};
  s.triangles = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                 {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
                 {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::vector<std::array<std::uint32_t, 3>> next;
    std::vector<std::pair<std::uint64_t, std::uint32_t>> mids;
    auto mid = [&](std::uint32_t a, std::uint32_t b) {
      const std::uint64_t key = (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
      for (const auto& [k, v] : mids)
        if (k == key) return v;
      s.vertices.push_back(0.5 * (s.vertices[a] + s.vertices[b]));
      mids.push_back({key, std::uint32_t(s.vertices.size() - 1)});
      return std::uint32_t(s.vertices.size() - 1);
    };
    for (const auto& t : s.triangles) {
      const std::uint32_t ab = mid(t[0], t[1]), bc = mid(t[1], t[2]), ca = mid(t[2], t[0]);
      next.push_back({t[0], ab, ca});
      next.push_back({t[1], bc, ab});
      next.push_back({t[2], ca, bc});
      next.push_back({ab, bc, ca});
    }
    s.triangles = next;
  }
  for (Vec3& v : s.vertices) v = radius * v.normalized();
  return s;
}

template <class T>
void put(std::ofstream& out, T value) {
  out.write(reinterpret_cast<const char*>(&value), sizeof(T));
}

void write_binary_stl(const SurfaceMesh& s, const fs::path& file) {
  std::ofstream out(file, std::ios::binary);
  // A header starting with "solid", as some exporters write: the size must decide.
  char header[80] = {};
  std::memcpy(header, "solid binary", 12);
  out.write(header, 80);
  put(out, std::uint32_t(s.triangles.size()));
  for (const auto& t : s.triangles) {
    for (int k = 0; k < 3; ++k) put(out, 0.0f);
    for (std::uint32_t v : t)
      for (int k = 0; k < 3; ++k) put(out, float(s.vertices[v][k]));
    put(out, std::uint16_t(0));
  }
}

void write_binary_ply(const SurfaceMesh& s, const fs::path& file) {
  std::ofstream out(file, std::ios::binary);
  out << "ply\nformat binary_little_endian 1.0\nelement vertex " << s.vertices.size()
      << "\nproperty double x\nproperty double y\nproperty double z\nproperty float nx\n"
      << "element face " << s.triangles.size() << "\nproperty list uchar int vertex_indices\n"
      << "element extra 1\nproperty short tag\nend_header\n";
  for (const Vec3& v : s.vertices) {
    put(out, v.x());
    put(out, v.y());
    put(out, v.z());
    put(out, 1.0f);
  }
  for (const auto& t : s.triangles) {
    put(out, std::uint8_t(3));
    for (std::uint32_t v : t) put(out, std::int32_t(v));
  }
  put(out, std::int16_t(7));
}

void write_obj(const SurfaceMesh& s, const fs::path& file) {
  std::ofstream out(file);
  out.precision(17);
  for (const Vec3& v : s.vertices) out << "v " << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
  for (const auto& t : s.triangles) out << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
}

void write_off(const SurfaceMesh& s, const fs::path& file) {
  std::ofstream out(file);
  out.precision(17);
  out << "OFF " << s.vertices.size() << ' ' << s.triangles.size() << " 0\n";
  for (const Vec3& v : s.vertices) out << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
  for (const auto& t : s.triangles) out << "3 " << t[0] << ' ' << t[1] << ' ' << t[2] << '\n';
}

}  // namespace

TEST_CASE("read_gmsh: 2.2 and 4.1 files give the 5-tet box") {
  for (const char* name : {"cube5_v22.msh", "cube5_v41.msh"}) {
    CAPTURE(name);
    const TetMesh m = read_gmsh(data() / name);
    CHECK(m.vertices.size() == 8);
    REQUIRE(m.tets.size() == 5);
    CHECK(volume_of(m) == doctest::Approx(6.0).epsilon(1e-12));
    CHECK(smallest_tet(m) > 0.0);  // the reversed tet of the 2.2 file is flipped
    CHECK(tet_volume(m, 4) == doctest::Approx(2.0));  // the central tet: a third of the box
    CHECK(face_neighbors(m).size() == 5);
    CHECK(m.vertices[0].isApprox(Vec3(0, 0, 0)));
    CHECK(m.vertices[6].isApprox(Vec3(2, 3, 1)));
  }
  // Same mesh as the TetGen fixture.
  const TetMesh a = read_gmsh(data() / "cube5_v22.msh"), b = read_tetgen(data() / "cube5.node");
  CHECK(mean_edge_length(a) == doctest::Approx(mean_edge_length(b)));
}

TEST_CASE("read_gmsh: errors name the file and line") {
  std::string msg = error_of([] { read_gmsh(data() / "bad_token.msh"); });
  CAPTURE(msg);
  CHECK(has(msg, "bad_token.msh:13:"));
  CHECK(has(msg, "'3x'"));
  msg = error_of([] { read_gmsh(data() / "degenerate.msh"); });
  CHECK(has(msg, "degenerate.msh:13:"));
  CHECK(has(msg, "tetrahedron 7 is degenerate"));
  msg = error_of([] { read_gmsh(data() / "two_pieces.msh"); });
  CHECK(has(msg, "2 disconnected pieces"));
  CHECK(has(msg, "split them into separate bodies"));
  msg = error_of([] { read_gmsh(data() / "no_such.msh"); });
  CHECK(has(msg, "no_such.msh"));
  CHECK(has(msg, "does not exist"));

  Scratch dir;
  std::ofstream(dir.path / "v40.msh") << "$MeshFormat\n4 0 8\n$EndMeshFormat\n";
  CHECK(has(error_of([&] { read_gmsh(dir.path / "v40.msh"); }), "v40.msh:2: Gmsh format version 4 is not supported"));
  std::ofstream(dir.path / "bin.msh") << "$MeshFormat\n4.1 1 8\n$EndMeshFormat\n";
  CHECK(has(error_of([&] { read_gmsh(dir.path / "bin.msh"); }), "binary"));
  std::ofstream(dir.path / "notets.msh") << "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n2 1 0 0\n"
                                            "3 0 1 0\n$EndNodes\n$Elements\n1\n1 2 0 1 2 3\n$EndElements\n";
  CHECK(has(error_of([&] { read_gmsh(dir.path / "notets.msh"); }), "no tetrahedra"));
  std::ofstream(dir.path / "missing_node.msh") << "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n2 1 0 0\n"
                                                  "3 0 1 0\n$EndNodes\n$Elements\n1\n9 4 0 1 2 3 4\n$EndElements\n";
  msg = error_of([&] { read_gmsh(dir.path / "missing_node.msh"); });
  CHECK(has(msg, "missing_node.msh:12:"));
  CHECK(has(msg, "node 4"));
  std::ofstream(dir.path / "cut.msh") << "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n";
  CHECK(has(error_of([&] { read_gmsh(dir.path / "cut.msh"); }), "truncated"));
}

TEST_CASE("read_tetgen: a .face file beside the mesh is ignored; disconnected tets are rejected") {
  Scratch dir;
  fs::copy_file(data() / "cube5.node", dir.path / "m.node");
  fs::copy_file(data() / "cube5.ele", dir.path / "m.ele");
  std::ofstream(dir.path / "m.face") << "this is not read\n";
  CHECK(read_tetgen(dir.path / "m.node").tets.size() == 5);
  std::ofstream(dir.path / "two.node") << "8 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 5 0 0\n6 6 0 0\n7 5 1 0\n8 5 0 1\n";
  std::ofstream(dir.path / "two.ele") << "2 4 0\n1 1 2 3 4\n2 5 6 7 8\n";
  CHECK(has(error_of([&] { read_tetgen(dir.path / "two.node"); }), "2 disconnected pieces"));
}

TEST_CASE("surface readers: the box in every format") {
  Scratch dir;
  write_binary_stl(box_surface(), dir.path / "box_binary.stl");
  write_binary_ply(box_surface(), dir.path / "box_binary.ply");
  const std::vector<fs::path> files = {data() / "box.obj", data() / "box.off", data() / "box.ply",
                                       data() / "box_ascii.stl", dir.path / "box_binary.stl",
                                       dir.path / "box_binary.ply"};
  for (const fs::path& f : files) {
    CAPTURE(f);
    SurfaceMesh s = read_surface(f);
    CHECK(s.vertices.size() == 8);  // the STL corners are welded
    CHECK(s.triangles.size() == 12);
    check_closed_surface(s, f.string());  // box.obj has a reversed face: fixed here
    CHECK(enclosed_volume(s) == doctest::Approx(6.0).epsilon(1e-9));
  }
}

TEST_CASE("check_closed_surface: orientation is made consistent and outward") {
  SurfaceMesh s = box_surface();
  for (auto& t : s.triangles) std::swap(t[1], t[2]);  // all inward
  std::swap(s.triangles[3][1], s.triangles[3][2]);     // and one outward
  CHECK(enclosed_volume(s) < 0.0);
  check_closed_surface(s, "box");
  CHECK(enclosed_volume(s) == doctest::Approx(6.0));
  SurfaceMesh ref = box_surface();
  for (std::size_t t = 0; t < s.triangles.size(); ++t) {
    // Same triangle, same cyclic order.
    const auto& a = s.triangles[t];
    const auto& b = ref.triangles[t];
    const bool same = (a[0] == b[0] && a[1] == b[1]) || (a[0] == b[1] && a[1] == b[2]) || (a[0] == b[2] && a[1] == b[0]);
    CHECK(same);
  }
}

TEST_CASE("surface input: each bad input gives its message") {
  auto problem = [](const char* name) {
    return error_of([&] {
      SurfaceMesh s = read_surface(data() / name);
      check_closed_surface(s, name);
    });
  };
  std::string msg = problem("open_box.obj");
  CAPTURE(msg);
  CHECK(has(msg, "surface is not closed: 4 boundary edges, e.g. between vertices"));
  msg = problem("fin_box.obj");
  CHECK(has(msg, "non-manifold edge between vertices 0"));
  CHECK(has(msg, "used by 4 triangles"));
  msg = problem("two_boxes.obj");
  CHECK(has(msg, "2 disconnected pieces; split them into separate bodies"));
  msg = problem("zero_area.obj");
  CHECK(has(msg, "triangle 0 (vertices 0, 1, 2, counted from 0) has zero area"));
  msg = problem("bad_token.obj");
  CHECK(has(msg, "bad_token.obj:3:"));
  CHECK(has(msg, "'1.5.2'"));
  msg = problem("no_such_surface.stl");
  CHECK(has(msg, "no_such_surface.stl' does not exist"));
  msg = error_of([] { read_surface(data() / "cube5.node"); });
  CHECK(has(msg, "unknown surface format '.node'"));

  Scratch dir;
  std::ofstream(dir.path / "far.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n";
  CHECK(has(error_of([&] { read_obj(dir.path / "far.obj"); }), "far.obj:4: vertex index 7 is out of range"));
  std::ofstream(dir.path / "neg.obj") << "v 0 0 0\nf -1 -2 -3\n";
  CHECK(has(error_of([&] { read_obj(dir.path / "neg.obj"); }), "neg.obj:2:"));
  std::ofstream(dir.path / "bad.off") << "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n";
  CHECK(has(error_of([&] { read_off(dir.path / "bad.off"); }), "bad.off:6: vertex index 3 is out of range"));
  std::ofstream(dir.path / "bad.ply") << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                         "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                         "end_header\n0 0 0\n1 0 zero\n0 1 0\n3 0 1 2\n";
  CHECK(has(error_of([&] { read_ply(dir.path / "bad.ply"); }), "bad.ply:11: bad"));
  std::ofstream(dir.path / "short.stl", std::ios::binary) << std::string(100, 'x');
  CHECK(has(error_of([&] { read_stl(dir.path / "short.stl"); }), "not an STL file"));
}

TEST_CASE("mesh_surface: the tetgen program fills closed surfaces") {
  if (!tetgen_installed()) {
    MESSAGE("tetgen is not installed; skipping");
    return;
  }
  Scratch dir;
  const SurfaceMesh ball = icosphere(0.5, 2);  // 320 triangles
  write_obj(ball, dir.path / "ball.obj");
  write_binary_stl(ball, dir.path / "ball.stl");
  write_binary_ply(ball, dir.path / "ball.ply");
  write_off(ball, dir.path / "ball.off");
  const double enclosed = enclosed_volume(ball);
  CHECK(enclosed == doctest::Approx(4.0 / 3.0 * M_PI * 0.125).epsilon(0.05));
  for (const char* name : {"ball.obj", "ball.stl", "ball.ply", "ball.off"}) {
    CAPTURE(name);
    SurfaceResolution res;
    res.edge_length = 0.1;
    const TetMesh m = load_surface(dir.path / name, res);
    CHECK(m.tets.size() > 100);
    CHECK(smallest_tet(m) > 0.0);
    CHECK(std::abs(volume_of(m) - enclosed) <= 0.01 * enclosed);  // float STL coordinates: not exact
    CHECK(mean_edge_length(m) == doctest::Approx(0.1).epsilon(0.3));
  }
  SUBCASE("target particle count") {
    SurfaceResolution res;
    res.particles = 2000;  // near the floor the surface sets
    const TetMesh m = mesh_surface(ball, res, "ball");
    CAPTURE(m.tets.size());
    CHECK(m.tets.size() >= 1700);
    CHECK(m.tets.size() <= 3000);  // 320 surface triangles: TetGen does not go much below ~2600
  }
  SUBCASE("the box keeps its exact volume") {
    SurfaceResolution res;
    res.resolution = 6;
    const TetMesh m = mesh_surface(box_surface(), res, "box");
    CHECK(volume_of(m) == doctest::Approx(6.0).epsilon(1e-9));
  }
  SUBCASE("tetgen failure is reported with its output") {
    // Two interpenetrating boxes as one closed, orientable, connected surface is hard to build by
    // hand; a self-touching surface (the box with one vertex pushed through the opposite face) is
    // enough to make tetgen give up.
    SurfaceMesh bad = box_surface();
    bad.vertices[6] = Vec3(-1, -1, -1);
    const std::string msg = error_of([&] { mesh_surface(bad, SurfaceResolution{}, "bad"); });
    CAPTURE(msg);
    CHECK(has(msg, "bad: tetgen -pq1.414a"));
    CHECK(has(msg, "failed ("));
  }
}

TEST_CASE("mesh_surface: a missing tetgen program is reported") {
  const char* old = std::getenv("PATH");
  const std::string saved = old ? old : "";
  setenv("PATH", "/nonexistent", 1);
  const std::string msg = error_of([] { mesh_surface(box_surface(), SurfaceResolution{}, "box"); });
  setenv("PATH", saved.c_str(), 1);
  CHECK(has(msg, "the surface mesh needs the 'tetgen' program: apt-get install tetgen"));
}

// ---------------------------------------------------------------------------------------------
// Scene geometry types "gmsh" and "surface"
// ---------------------------------------------------------------------------------------------

namespace {

std::string scene_with(const std::string& geometry) {
  return R"({"name": "t", "time": {"dt": 1e-4, "duration": 0.1},
    "materials": {"m": {"youngs_modulus": 1e6, "poisson_ratio": 0.3}},
    "bodies": [{"material": "m", "geometry": )" + geometry + "}]}";
}

std::string scene_error(const std::string& geometry) {
  try {
    scene::load_scene_text(scene_with(geometry), data() / "scene.json");
  } catch (const scene::SceneError& e) {
    return e.what();
  }
  return "<no SceneError thrown>";
}

}  // namespace

TEST_CASE("scene: gmsh and surface geometry") {
  using scene::Geometry;
  auto geometry_of = [](const std::string& g) {
    return scene::load_scene_text(scene_with(g), data() / "scene.json").bodies[0].geometry;
  };
  Geometry g = geometry_of(R"({"type": "gmsh", "path": "cube5_v41.msh"})");
  CHECK(g.kind == Geometry::Kind::gmsh);
  CHECK(g.path == data() / "cube5_v41.msh");
  g = geometry_of(R"({"type": "surface", "path": "box.obj", "particles": 500})");
  CHECK(g.kind == Geometry::Kind::surface);
  CHECK(g.particles == 500);
  CHECK(g.edge_length == 0.0);
  g = geometry_of(R"({"type": "surface", "path": "box.ply", "edge_length": 0.2})");
  CHECK(g.edge_length == 0.2);
  g = geometry_of(R"({"type": "surface", "path": "box.off"})");
  CHECK(g.resolution == 20);

  CHECK(has(scene_error(R"({"type": "gmsh", "path": "nope.msh"})"), "/bodies/0/geometry/path: mesh file not found"));
  CHECK(has(scene_error(R"({"type": "surface", "path": "cube5.node"})"), "unknown surface format '.node'"));
  CHECK(has(scene_error(R"({"type": "surface", "path": "box.obj", "particles": 9, "edge_length": 1})"),
            "cannot both be given"));
  CHECK(has(scene_error(R"({"type": "box", "size": [1, 1, 1], "particles": 9})"), "not used by geometry type 'box'"));
  CHECK(has(scene_error(R"({"type": "gmsh", "path": "cube5_v22.msh", "resolution": 4})"), "not used by"));
}
