// perifx check-surface (engine/tools/surface_check.cpp): a short fracture run's surfaces pass with
// every count 0; a corrupted surface is caught; output.min_piece_tets drops small pieces.
#include <doctest/doctest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "io/obj.hpp"
#include "io/ply.hpp"
#include "io/run_dir.hpp"
#include "runner.hpp"
#include "support.hpp"
#include "tools/surface_check.hpp"
#include "file_support.hpp"

using namespace perifx;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir(const std::string& name) { return perifx::test::temp_dir("surface_check", name); }

// A brittle slab torn apart by its two halves' velocities: pieces fly off within a few frames.
scene::Scene torn_slab() {
  auto sc = test::box_scene(Vec3(0.06, 0.03, 0.012), 0.004, 5e5, 3e5);
  sc.materials[0].critical_stretch = 0.01;
  sc.time.dt = 2e-5;
  sc.time.frame_rate = 500;
  sc.output.vtu = true;
  sc.output.ply = false;
  sc.output.surface_ply = true;
  sc.output.obj = true;
  for (int side : {-1, 1}) {
    scene::BoundaryCondition bc;
    bc.kind = scene::BoundaryCondition::Kind::velocity;
    bc.region.kind = scene::Region::Kind::box;
    bc.region.min = Vec3(-1, side < 0 ? -1.0 : 0.01, -1);
    bc.region.max = Vec3(1, side < 0 ? -0.01 : 1.0, 1);
    bc.velocity = Vec3(0, side * 2.0, 0);
    sc.boundary_conditions.push_back(bc);
  }
  return sc;
}

// A surface file read back as the SurfaceMesh the writers take (velocities, which the checker does
// not read, zero), for the subcases that corrupt a frame and write it again.
SurfaceMesh surface_mesh_of(const io::SurfaceFrame& s) {
  SurfaceMesh m;
  m.vertices = s.vertex;
  m.triangles = s.triangle;
  m.crack = s.crack;
  m.fragment = s.fragment;
  m.tet = s.tet;
  m.reference = s.reference;
  m.source = s.source;
  m.velocity.assign(s.vertex.size(), Vec3::Zero());
  return m;
}

}  // namespace

TEST_CASE("check-surface: a short fracture run has no far, inverted, open or stretched surface elements") {
  const fs::path dir = temp_dir("torn");
  {
    World world(torn_slab());
    RunOptions opt;
    opt.output_directory = dir;
    opt.frames = 6;
    run_world(world, opt);
    CHECK(world.fragment_count() > 1);
  }
  const auto report = check_run_surfaces(dir);
  std::ostringstream table;
  print_surface_check(table, report);
  MESSAGE(table.str());
  REQUIRE(report.frames.size() == 7);
  CHECK(report.horizon > 0.0);
  CHECK(report.frames.back().pieces > 1);
  for (const auto& f : report.frames) {
    CHECK(f.far_vertices == 0);
    CHECK(f.inverted_shells == 0);
    CHECK(f.open_edges == 0);
    CHECK(f.nonmanifold_edges == 0);
    CHECK(f.stretched_triangles == 0);
  }
  CHECK(report.issues() == 0);

  // The checker does see problems: push one vertex of the last surface far away (and unweld nothing).
  SUBCASE("a displaced vertex is reported") {
    const io::FrameFiles last = io::scan_run_directory(dir).frames.back();
    io::SurfaceFrame s = io::read_surface_frame(last.surface);
    CHECK(s.source.size() == s.vertex.size());
    CHECK(s.reference.size() == s.vertex.size());
    CHECK(s.tet.size() == s.triangle.size());
    // Rewrite it as a plain OBJ with one vertex moved by 1 m (no reference data: stretch n/a).
    SurfaceMesh m = surface_mesh_of(s);
    m.vertices[m.triangles[0][0]] += Vec3(1.0, 0, 0);
    fs::remove(last.surface);
    io::write_obj_surface(last.surface.parent_path() / last.surface.filename().replace_extension(".obj"), m);
    const auto bad = check_run_surfaces(dir);
    CHECK(bad.frames.back().far_vertices >= 1);
    CHECK(bad.issues() > 0);
  }
  // A vertex that lies beyond δ of its piece's particles at rest is not a spike while it keeps that
  // distance: with δ given as a fifth of the cell, most vertices of the unmoved frame 0 are beyond it
  // (the δ test alone counted them), and none is farther than at rest. The PLY keeps the reference
  // positions, so a vertex moved 1 m is still far.
  SUBCASE("a vertex is far only beyond δ and beyond its distance at rest") {
    SurfaceCheckOptions small;
    small.horizon = 0.2 * 0.004;
    small.frames = 1;
    small.details = true;
    const auto rest = check_run_surfaces(dir, small);
    REQUIRE(rest.frames.size() == 1);
    CHECK(rest.frames[0].far_vertices == 0);
    const io::FrameFiles last = io::scan_run_directory(dir).frames.back();
    SurfaceMesh m = surface_mesh_of(io::read_surface_frame(last.surface));
    REQUIRE(m.reference.size() == m.vertices.size());
    const std::uint32_t moved = m.triangles[0][0];
    for (std::uint32_t v = 0; v < m.vertices.size(); ++v)  // every copy of the vertex (same source)
      if (m.source[v] == m.source[moved]) m.vertices[v] += Vec3(1.0, 0, 0);
    io::write_ply_surface(last.surface, m);
    const auto bad = check_run_surfaces(dir);
    CHECK(bad.frames.back().far_vertices == 1);
  }
  // A triangle edge stretched past 3× while the particles are not is counted, and --details gives the
  // edge's length at rest and now: vertex a of the first triangle moved to b + 3.5 (a − b).
  SUBCASE("a stretched triangle is reported with its edge's lengths") {
    const io::FrameFiles last = io::scan_run_directory(dir).frames.back();
    const io::SurfaceFrame s = io::read_surface_frame(last.surface);
    REQUIRE(s.reference.size() == s.vertex.size());
    SurfaceMesh m = surface_mesh_of(s);
    const std::uint32_t a = m.triangles[0][0], b = m.triangles[0][1];
    m.vertices[a] = m.vertices[b] + 3.5 * (m.vertices[a] - m.vertices[b]);
    io::write_ply_surface(last.surface, m);
    // The most stretched edge of that triangle as the file now holds it (PLY stores floats).
    const io::SurfaceFrame written = io::read_surface_frame(last.surface);
    double ratio = 0.0, rest = 0.0, now = 0.0;
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t p = written.triangle[0][e], q = written.triangle[0][(e + 1) % 3];
      const double r = (written.reference[p] - written.reference[q]).norm(), n = (written.vertex[p] - written.vertex[q]).norm();
      if (r > 0.0 && n / r > ratio) ratio = n / r, rest = r, now = n;
    }
    REQUIRE(ratio > 3.0);
    SurfaceCheckOptions options;
    options.details = true;
    const auto bad = check_run_surfaces(dir, options);
    CHECK(bad.frames.back().stretched_triangles >= 1);
    char expected[96];
    std::snprintf(expected, sizeof expected, "(%.3g m at rest, %.3g m = ", rest, now);
    const auto& details = bad.frames.back().details;
    const bool found = std::any_of(details.begin(), details.end(), [&](const std::string& line) {
      return line.find("stretched triangle of tet") != std::string::npos && line.find(expected) != std::string::npos;
    });
    INFO("expected a stretched-triangle line with " << expected);
    CHECK(found);
  }
}

TEST_CASE("output.min_piece_tets leaves small pieces out of the surface files") {
  auto sc = torn_slab();
  World all(sc);
  all.step(150);
  const FieldView f = all.field("fragment_id");
  const auto* id = static_cast<const std::uint32_t*>(f.data);
  std::map<std::uint32_t, std::uint32_t> tets;
  for (std::size_t i = 0; i < f.count; ++i) ++tets[id[i]];
  std::uint32_t largest = 0;
  for (const auto& [piece, n] : tets) largest = std::max(largest, n);
  // Keep only the pieces as large as the largest.
  sc.output.min_piece_tets = largest;
  World big(sc);
  big.step(150);
  const SurfaceMesh a = all.surface(), b = big.surface();
  std::size_t small = 0;
  for (const auto& [piece, n] : tets) small += n < largest;
  MESSAGE(tets.size() << " pieces, " << small << " below " << largest << " tets; triangles " << a.triangles.size()
                      << " -> " << b.triangles.size());
  REQUIRE(small > 0);
  CHECK(b.triangles.size() < a.triangles.size());
  std::set<std::uint32_t> kept(b.fragment.begin(), b.fragment.end());
  for (auto piece : kept) CHECK(tets[piece] >= largest);
  CHECK(kept.size() == tets.size() - small);
  CHECK(b.vertices.size() < a.vertices.size());
}

TEST_CASE("output.dust = points writes exactly the left-out pieces' particles as dust.NNNN.ply") {
  // The piece size that leaves some pieces out after 150 steps (as in the case above).
  auto sc = torn_slab();
  std::uint32_t largest = 0;
  {
    World probe(sc);
    probe.step(150);
    const FieldView f = probe.field("fragment_id");
    const auto* id = static_cast<const std::uint32_t*>(f.data);
    std::map<std::uint32_t, std::uint32_t> tets;
    for (std::size_t i = 0; i < f.count; ++i) ++tets[id[i]];
    for (const auto& [piece, n] : tets) largest = std::max(largest, n);
  }
  sc.output.ply = true;
  sc.output.min_piece_tets = largest;
  sc.output.dust_points = true;
  const fs::path dir = temp_dir("dust");
  {
    World world(sc);
    RunOptions opt;
    opt.output_directory = dir;
    opt.frames = 2;
    run_world(world, opt);
  }
  std::size_t dust_total = 0, surface_frames = 0;
  for (int k = 0; k <= 2; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "%04d.ply", k);
    const io::PlyContent particles = io::read_ply(dir / (std::string("particles.") + name));
    const io::PlyContent dust = io::read_ply(dir / (std::string("dust.") + name));
    const io::PlyContent surface = io::read_ply(dir / (std::string("surface.") + name));
    const auto& frag = particles.vertex_properties.at("fragment_id");
    const auto& volume = particles.vertex_properties.at("volume");
    std::map<double, std::size_t> tets;
    for (double id : frag) ++tets[id];
    std::vector<std::size_t> expected;  // particles of pieces below min_piece_tets, in order
    for (std::size_t p = 0; p < frag.size(); ++p)
      if (tets[frag[p]] < largest) expected.push_back(p);
    INFO("frame " << k);
    REQUIRE(dust.surface.vertices.size() == expected.size());
    CHECK(dust.surface.triangles.empty());
    const auto& piece = dust.vertex_properties.at("piece");
    const auto& radius = dust.vertex_properties.at("radius");
    std::set<double> dust_pieces;
    for (std::size_t i = 0; i < expected.size(); ++i) {
      const std::size_t p = expected[i];
      CHECK(piece[i] == frag[p]);
      CHECK(dust.surface.vertices[i] == particles.surface.vertices[p]);  // both written as float
      CHECK(radius[i] == std::cbrt(3.0 * volume[p] / (4.0 * 3.14159265358979323846)));
      CHECK(dust.vertex_properties.count("velocity_x") == 1);
      dust_pieces.insert(piece[i]);
    }
    // The surface has every other piece and none of the dust pieces.
    std::set<double> surface_pieces;
    for (double id : surface.face_properties.at("fragment")) surface_pieces.insert(id);
    for (double id : dust_pieces) CHECK(surface_pieces.count(id) == 0);
    CHECK(surface_pieces.size() + dust_pieces.size() == tets.size());
    dust_total += expected.size();
    surface_frames += !surface.surface.triangles.empty();
  }
  MESSAGE("dust points over frames 0-2: " << dust_total << " (min_piece_tets " << largest << ")");
  CHECK(dust_total > 0);
  CHECK(surface_frames > 0);
}
