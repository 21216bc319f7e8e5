// The export writers (engine/io/pc2.*, gltf.*, pieces_csv.*, animation_history.*, obj.cpp's cache
// surface) on small inputs, and `perifx run` writing them: byte-identical on 1 and 2 threads.
#include <doctest/doctest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include <nlohmann/json.hpp>

#include "cli_support.hpp"
#include "io/animation_history.hpp"
#include "io/gltf.hpp"
#include "io/obj.hpp"
#include "io/pc2.hpp"
#include "io/pieces_csv.hpp"
#include "file_support.hpp"

namespace fs = std::filesystem;
using namespace perifx;

namespace {

using perifx::test::slurp;

fs::path scratch(const std::string& name) { return perifx::test::temp_dir("export", name); }

template <class T>
T at(const std::string& s, std::size_t offset) {
  T v;
  std::memcpy(&v, s.data() + offset, sizeof v);
  return v;
}

// Two pieces: a tetrahedron (piece 3: three outside faces, one crack face) and a triangle pair (piece 9).
SurfaceMesh two_pieces() {
  SurfaceMesh s;
  s.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1), Vec3(2, 0, 0), Vec3(3, 0, 0), Vec3(2, 1, 0)};
  s.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}, {4, 5, 6}, {4, 6, 5}};
  s.crack = {0, 0, 0, 1, 0, 1};
  s.fragment = {3, 3, 3, 3, 9, 9};
  s.tet = {0, 0, 0, 0, 1, 1};
  s.reference = s.vertices;
  s.velocity.assign(s.vertices.size(), Vec3::Zero());
  for (std::uint32_t v = 0; v < s.vertices.size(); ++v) s.source.push_back(v);
  return s;
}

}  // namespace

TEST_CASE("PC2: signature, header and float samples as Blender's Mesh Cache reads them") {
  const fs::path dir = scratch("pc2");
  perifx::io::write_pc2(dir / "a.pc2", {{1, 2, 3, 4, 5, 6}, {7, 8, 9, 10, 11, 12}});
  const std::string b = slurp(dir / "a.pc2");
  REQUIRE(b.size() == 32 + 2 * 6 * 4);
  CHECK(std::memcmp(b.data(), "POINTCACHE2\0", 12) == 0);
  CHECK(at<std::int32_t>(b, 12) == 1);
  CHECK(at<std::int32_t>(b, 16) == 2);  // vertices
  CHECK(at<float>(b, 20) == 0.0f);      // start frame
  CHECK(at<float>(b, 24) == 1.0f);      // sample rate
  CHECK(at<std::int32_t>(b, 28) == 2);  // samples
  CHECK(at<float>(b, 32 + 6 * 4) == 7.0f);
  CHECK_THROWS_WITH_AS(perifx::io::write_pc2(dir / "b.pc2", {{1, 2, 3}, {1, 2}}),
                       doctest::Contains("frame 1 has 2 coordinates, expected 3"), perifx::io::IoError);
  CHECK_FALSE(fs::exists(dir / "b.pc2"));
}

TEST_CASE("the surface and animation writers refuse non-finite values and leave no file") {
  // A NaN vertex, velocity, cached position or pose is a bug upstream (a degenerate fit or rotation);
  // the writers name it and write nothing rather than a file the importers reject.
  const fs::path dir = scratch("finite");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  SurfaceMesh s = two_pieces();
  s.vertices[5].y() = nan;
  CHECK_THROWS_WITH_AS(perifx::io::write_obj_surface(dir / "a.obj", s, "a.mtl"),
                       doctest::Contains("surface vertex 5 has a non-finite position or velocity"), perifx::io::IoError);
  CHECK_FALSE(fs::exists(dir / "a.obj"));
  s = two_pieces();
  s.velocity[2].x() = std::numeric_limits<double>::infinity();
  CHECK_THROWS_WITH_AS(perifx::io::write_obj_surface(dir / "b.obj", s, "b.mtl"),
                       doctest::Contains("surface vertex 2 has a non-finite"), perifx::io::IoError);
  CHECK_FALSE(fs::exists(dir / "b.obj"));
  CHECK_THROWS_WITH_AS(perifx::io::write_pc2(dir / "a.pc2", {{1, 2, 3, 4, 5, 6}, {7, 8, 9, 10, float(nan), 12}}),
                       doctest::Contains("frame 1: vertex 1 is not finite"), perifx::io::IoError);
  CHECK_FALSE(fs::exists(dir / "a.pc2"));
  s = two_pieces();
  std::vector<std::array<std::array<double, 2>, 3>> uv(s.triangles.size());
  std::vector<perifx::io::RigidPieceTrack> tracks(2);
  tracks[0].id = 3, tracks[1].id = 9;
  for (auto& t : tracks)
    for (int k = 0; k < 2; ++k) t.translation.push_back(Vec3(k, 0, 0)), t.rotation.push_back(Eigen::Vector4d(0, 0, 0, 1));
  tracks[1].rotation[1].x() = nan;
  CHECK_THROWS_WITH_AS(perifx::io::write_glb(dir / "a.glb", s, uv, {0.0, 1.0}, tracks, "perifx test"),
                       doctest::Contains("piece 9's pose at key 1 is not finite"), perifx::io::IoError);
  CHECK_FALSE(fs::exists(dir / "a.glb"));
}

TEST_CASE("GLB: chunks, one node per piece, POSITION and key-time bounds, unit quaternions") {
  const fs::path dir = scratch("glb");
  const SurfaceMesh s = two_pieces();
  std::vector<std::array<std::array<double, 2>, 3>> uv(s.triangles.size());
  const std::vector<double> times = {0.0, 0.5, 1.0};
  std::vector<perifx::io::RigidPieceTrack> tracks(2);
  tracks[0].id = 3, tracks[1].id = 9;
  for (auto& t : tracks)
    for (int k = 0; k < 3; ++k) t.translation.push_back(Vec3(k, 0, 0)), t.rotation.push_back(Eigen::Vector4d(0, std::sin(0.1 * k), 0, std::cos(0.1 * k)));
  perifx::io::write_glb(dir / "a.glb", s, uv, times, tracks, "perifx test");
  const std::string b = slurp(dir / "a.glb");
  REQUIRE(b.size() > 28);
  CHECK(std::memcmp(b.data(), "glTF", 4) == 0);
  CHECK(at<std::uint32_t>(b, 4) == 2);
  CHECK(at<std::uint32_t>(b, 8) == b.size());
  const auto json_length = at<std::uint32_t>(b, 12);
  CHECK(json_length % 4 == 0);
  CHECK(std::memcmp(b.data() + 16, "JSON", 4) == 0);
  const auto bin_at = 20 + json_length;
  const auto bin_length = at<std::uint32_t>(b, bin_at);
  CHECK(bin_length % 4 == 0);
  CHECK(std::memcmp(b.data() + bin_at + 4, "BIN\0", 4) == 0);
  CHECK(bin_at + 8 + bin_length == b.size());
  const auto doc = nlohmann::json::parse(b.substr(20, json_length));
  CHECK(doc["asset"]["version"] == "2.0");
  REQUIRE(doc["nodes"].size() == 2);
  CHECK(doc["nodes"][0]["name"] == "piece_3");
  CHECK(doc["nodes"][1]["extras"]["piece"] == 9);
  CHECK(doc["meshes"][0]["primitives"].size() == 2);  // outside and crack
  CHECK(doc["meshes"][0]["primitives"][1]["material"] == 1);
  CHECK(doc["meshes"][0]["primitives"][1]["attributes"].contains("TEXCOORD_0"));
  for (const auto& mesh : doc["meshes"])
    for (const auto& prim : mesh["primitives"]) {
      const auto& pos = doc["accessors"][prim["attributes"]["POSITION"].get<int>()];
      CHECK(pos.contains("min"));
      CHECK(pos.contains("max"));
    }
  REQUIRE(doc["animations"].size() == 1);
  const auto& anim = doc["animations"][0];
  CHECK(anim["channels"].size() == 4);
  const auto& input = doc["accessors"][anim["samplers"][0]["input"].get<int>()];
  CHECK(input["min"][0] == 0.0);
  CHECK(input["max"][0] == 1.0);
  CHECK(doc["buffers"][0]["byteLength"] == bin_length);
  // Rotations stored as unit float quaternions.
  const auto& rot = doc["accessors"][anim["samplers"][1]["output"].get<int>()];
  const auto& view = doc["bufferViews"][rot["bufferView"].get<int>()];
  for (int k = 0; k < 3; ++k) {
    double n2 = 0;
    for (int d = 0; d < 4; ++d) {
      const float q = at<float>(b, bin_at + 8 + view["byteOffset"].get<std::size_t>() + 16 * k + 4 * d);
      n2 += double(q) * q;
    }
    CHECK(n2 == doctest::Approx(1.0).epsilon(1e-6));
  }
}

TEST_CASE("cache OBJ: vertices as given, UVs only on crack faces, a group per piece") {
  const fs::path dir = scratch("obj");
  const SurfaceMesh s = two_pieces();
  std::vector<float> pos;
  for (const Vec3& v : s.vertices) pos.insert(pos.end(), {float(v.x()), float(v.y()), float(v.z())});
  std::vector<std::array<std::array<double, 2>, 3>> uv(s.triangles.size());
  uv[3] = {{{0, 0}, {1, 0}, {0, 1}}};
  perifx::io::write_obj_cache(dir / "a.obj", s, pos, uv);
  const std::string text = slurp(dir / "a.obj");
  CHECK(text.find("mtllib surface.mtl\n") != std::string::npos);
  CHECK(text.find("o piece_3\ng piece_3\nusemtl surface\nf 1 3 2\n") != std::string::npos);
  CHECK(text.find("usemtl crack\nf 2/1 3/2 4/3\n") != std::string::npos);
  CHECK(text.find("o piece_9\ng piece_9\nusemtl surface\nf 5 6 7\nusemtl crack\nf 5/4 7/5 6/6\n") != std::string::npos);
  std::size_t vt = 0;
  for (std::size_t p = text.find("\nvt "); p != std::string::npos; p = text.find("\nvt ", p + 1)) ++vt;
  CHECK(vt == 6);
}

TEST_CASE("animation.bin reads back what was written; pieces.csv has a row per piece and frame") {
  const fs::path dir = scratch("history");
  AnimationHistory h;
  h.record_vertices = true;
  h.min_piece_tets = 2;
  for (std::uint64_t k = 0; k < 3; ++k) {
    AnimationFrame f;
    f.frame = k;
    f.time = 0.1 * double(k);
    f.vertex_count = 2;
    f.positions = {1, 2, 3, 4, 5, float(k)};
    PieceSample p;
    p.id = 7;
    p.particles = 5;
    p.mass = 2.5;
    p.rotation = Eigen::AngleAxisd(0.3 * double(k), Vec3::UnitY()).toRotationMatrix();
    p.translation = Vec3(k, 1, 2);
    f.pieces.push_back(p);
    h.frames.push_back(f);
  }
  h.origins[7] = {0, kNoPiece};
  h.origins[12] = {2, 7};
  h.vertex_parent = {0, 0};
  h.vertex_birth = {0, 1};
  perifx::io::write_animation_history(dir / "animation.bin", h);
  const AnimationHistory back = perifx::io::read_animation_history(dir / "animation.bin");
  perifx::io::write_animation_history(dir / "again.bin", back);
  CHECK(slurp(dir / "animation.bin") == slurp(dir / "again.bin"));
  CHECK(back.origins.at(12).parent == 7);
  CHECK(back.frames[2].positions[5] == 2.0f);

  std::ofstream(dir / "bad.bin") << "PFXANIM1";
  CHECK_THROWS_WITH_AS(perifx::io::read_animation_history(dir / "bad.bin"), doctest::Contains("bad.bin': the file is truncated"),
                       perifx::io::IoError);

  perifx::io::write_pieces_csv(dir / "pieces.csv", h);
  std::ifstream in(dir / "pieces.csv");
  std::string line;
  std::getline(in, line);
  CHECK(line == "piece,frame,time,birth_frame,parent,particles,mass,cx,cy,cz,tx,ty,tz,qx,qy,qz,qw,vx,vy,vz,wx,wy,wz");
  int rows = 0;
  while (std::getline(in, line)) ++rows;
  CHECK(rows == 3);
}

TEST_CASE("perifx run writes pieces.csv, animation.obj/.pc2/.glb, the same bytes on 1 and 2 threads") {
  const fs::path dir = scratch("run");
  const std::string scene = std::string(PERIFX_SOURCE_DIR) + "/tests/engine/data/export_pane.json";
  for (const char* threads : {"1", "2"}) {
    const auto r = perifx::test::run_cli("run " + scene + " --out " + (dir / threads).string() + " --threads " + threads + " --quiet");
    INFO(r.output);
    REQUIRE(r.code == 0);
  }
  for (const char* name : {"pieces.csv", "animation.obj", "animation.pc2", "animation.glb", "animation.bin", "surface.0008.ply"}) {
    INFO(name);
    REQUIRE(fs::exists(dir / "1" / name));
    CHECK(slurp(dir / "1" / name) == slurp(dir / "2" / name));
  }
  // The cache: 9 frames of every vertex of the OBJ.
  const std::string pc2 = slurp(dir / "1" / "animation.pc2");
  const std::string obj = slurp(dir / "1" / "animation.obj");
  std::size_t vertices = 0;
  for (std::size_t p = obj.find("\nv "); p != std::string::npos; p = obj.find("\nv ", p + 1)) ++vertices;
  CHECK(at<std::int32_t>(pc2, 16) == std::int32_t(vertices));
  CHECK(at<std::int32_t>(pc2, 28) == 9);
  CHECK(pc2.size() == 32 + 9 * 12 * vertices);
}
