// Tests for engine/geometry: structured meshers, TetGen input, mesh measures and Morton order.
#include <doctest/doctest.h>
#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "geometry/geometry.hpp"
#include "engine/geometry/geometry_test_support.hpp"

namespace fs = std::filesystem;
using namespace perifx;
using namespace perifx::geometry;

namespace {

using perifx::test::TempDir;
fs::path data_dir() { return perifx::test::geometry_data_dir(); }


void write_file(const fs::path& p, const std::string& text) {
  std::ofstream out(p);
  out << text;
}

double total_volume(const TetMesh& m) {
  double v = 0.0;
  for (std::size_t t = 0; t < m.tets.size(); ++t) v += tet_volume(m, t);
  return v;
}

double min_volume(const TetMesh& m) {
  double v = kInfinity;
  for (std::size_t t = 0; t < m.tets.size(); ++t) v = std::min(v, tet_volume(m, t));
  return v;
}

// Number of face-connected components of the tets.
std::size_t face_components(const TetMesh& m) {
  const auto nb = face_neighbors(m);
  std::vector<char> seen(m.tets.size(), 0);
  std::size_t components = 0;
  std::vector<std::size_t> stack;
  for (std::size_t s = 0; s < m.tets.size(); ++s) {
    if (seen[s]) continue;
    ++components;
    seen[s] = 1;
    stack.assign(1, s);
    while (!stack.empty()) {
      const std::size_t t = stack.back();
      stack.pop_back();
      for (std::int32_t n : nb[t]) {
        if (n >= 0 && !seen[static_cast<std::size_t>(n)]) {
          seen[static_cast<std::size_t>(n)] = 1;
          stack.push_back(static_cast<std::size_t>(n));
        }
      }
    }
  }
  return components;
}

std::array<std::uint32_t, 3> face_of(const TetMesh& m, std::size_t t, int k) {
  std::array<std::uint32_t, 3> f{};
  int n = 0;
  for (int i = 0; i < 4; ++i) {
    if (i != k) f[static_cast<std::size_t>(n++)] = m.tets[t][static_cast<std::size_t>(i)];
  }
  std::sort(f.begin(), f.end());
  return f;
}

// Vertices on boundary faces.
std::set<std::uint32_t> boundary_vertices(const TetMesh& m) {
  const auto nb = face_neighbors(m);
  std::set<std::uint32_t> boundary;
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    for (int k = 0; k < 4; ++k) {
      if (nb[t][static_cast<std::size_t>(k)] >= 0) continue;
      for (auto v : face_of(m, t, k)) boundary.insert(v);
    }
  }
  return boundary;
}

// face_neighbors is symmetric and neighbors really share the face; returns the boundary face count.
std::size_t check_neighbors_consistent(const TetMesh& m) {
  const auto nb = face_neighbors(m);
  REQUIRE(nb.size() == m.tets.size());
  std::size_t boundary = 0;
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    for (int k = 0; k < 4; ++k) {
      const std::int32_t n = nb[t][static_cast<std::size_t>(k)];
      if (n < 0) {
        ++boundary;
        continue;
      }
      const auto u = static_cast<std::size_t>(n);
      REQUIRE(u != t);
      const auto f = face_of(m, t, k);
      int matches = 0;
      for (int j = 0; j < 4; ++j) {
        if (face_of(m, u, j) == f) {
          ++matches;
          CHECK(nb[u][static_cast<std::size_t>(j)] == static_cast<std::int32_t>(t));
        }
      }
      CHECK(matches == 1);
    }
  }
  return boundary;
}

// Interleaves bits one at a time: the reference the fast Morton code is checked against.
std::uint64_t naive_morton(std::uint64_t x, std::uint64_t y, std::uint64_t z) {
  std::uint64_t code = 0;
  for (int b = 0; b < 21; ++b) {
    code |= ((x >> b) & 1u) << (3 * b);
    code |= ((y >> b) & 1u) << (3 * b + 1);
    code |= ((z >> b) & 1u) << (3 * b + 2);
  }
  return code;
}

template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const GeometryError& e) {
    return e.what();
  }
  return "<no GeometryError thrown>";
}

}  // namespace

TEST_CASE("mesh_box: counts, volume, orientation, conformity") {
  struct Case {
    Vec3 size;
    double cell;
    std::size_t nx, ny, nz;
  };
  const Case cases[] = {{Vec3(3, 4, 5), 1.0, 3, 4, 5},
                        {Vec3(2.0, 3.0, 1.5), 0.7, 3, 4, 2},
                        {Vec3(0.3, 0.1, 0.2), 1.0, 1, 1, 1},
                        {Vec3(1.0, 1.0, 1.0), 0.1, 10, 10, 10}};
  for (const Case& c : cases) {
    CAPTURE(c.size.transpose());
    CAPTURE(c.cell);
    const TetMesh m = mesh_box(c.size, c.cell);
    CHECK(m.tets.size() == 6 * c.nx * c.ny * c.nz);
    CHECK(m.vertices.size() == (c.nx + 1) * (c.ny + 1) * (c.nz + 1));

    const double expected = c.size.prod();
    CHECK(std::abs(total_volume(m) - expected) <= 1e-12 * expected);
    // Congruent tets: each is exactly 1/6 of a cell.
    const double cell_volume = expected / static_cast<double>(c.nx * c.ny * c.nz);
    CHECK(min_volume(m) == doctest::Approx(cell_volume / 6.0).epsilon(1e-12));

    // Centered at the origin, spanning exactly the requested size.
    Vec3 lo = m.vertices[0], hi = m.vertices[0];
    for (const Vec3& p : m.vertices) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    CHECK((hi - lo - c.size).norm() <= 1e-12 * c.size.norm());
    CHECK((hi + lo).norm() <= 1e-12 * c.size.norm());

    const std::size_t boundary = check_neighbors_consistent(m);
    CHECK(boundary == 4 * (c.nx * c.ny + c.ny * c.nz + c.nx * c.nz));
    CHECK(face_components(m) == 1);
  }
}

TEST_CASE("mesh_box: mean edge length matches the count of unique grid edges") {
  auto expected_mean = [](std::size_t nx, std::size_t ny, std::size_t nz, double hx, double hy, double hz) {
    const auto X = static_cast<double>(nx), Y = static_cast<double>(ny), Z = static_cast<double>(nz);
    // Axis edges of the vertex grid.
    const double ex = X * (Y + 1) * (Z + 1), ey = (X + 1) * Y * (Z + 1), ez = (X + 1) * (Y + 1) * Z;
    // One diagonal per grid square (the Freudenthal split cuts every square along its (+,+) diagonal).
    const double fxy = X * Y * (Z + 1), fyz = (X + 1) * Y * Z, fxz = X * (Y + 1) * Z;
    // One body diagonal per cube.
    const double body = X * Y * Z;
    const double sum = ex * hx + ey * hy + ez * hz + fxy * std::hypot(hx, hy) + fyz * std::hypot(hy, hz) +
                       fxz * std::hypot(hx, hz) + body * std::sqrt(hx * hx + hy * hy + hz * hz);
    return sum / (ex + ey + ez + fxy + fyz + fxz + body);
  };

  SUBCASE("unit cells") {
    const TetMesh m = mesh_box(Vec3(3, 4, 5), 1.0);
    CHECK(mean_edge_length(m) == doctest::Approx(expected_mean(3, 4, 5, 1, 1, 1)).epsilon(1e-12));
  }
  SUBCASE("single unit cube: 12 edges of 1, 6 of sqrt2, 1 of sqrt3") {
    const TetMesh m = mesh_box(Vec3(1, 1, 1), 1.0);
    CHECK(mean_edge_length(m) == doctest::Approx((12 + 6 * std::sqrt(2.0) + std::sqrt(3.0)) / 19).epsilon(1e-14));
  }
  SUBCASE("non-cubic cells") {
    const TetMesh m = mesh_box(Vec3(2.0, 3.0, 1.5), 0.7);
    CHECK(mean_edge_length(m) ==
          doctest::Approx(expected_mean(3, 4, 2, 2.0 / 3, 0.75, 0.75)).epsilon(1e-12));
  }
}

TEST_CASE("mesh_box: rejects bad input") {
  CHECK_THROWS_AS(mesh_box(Vec3(1, 1, 1), 0.0), GeometryError);
  CHECK_THROWS_AS(mesh_box(Vec3(1, -1, 1), 0.1), GeometryError);
  CHECK_THROWS_AS(mesh_box(Vec3(1, 1, 1), std::nan("")), GeometryError);
  CHECK_THROWS_AS(mesh_box(Vec3(1, 1, 1), 1e-9), GeometryError);  // 6e27 tets
}

namespace {

// The mean ratio 12 (3V)^(2/3) / Σ edge² of tet t: 1 for a regular tet, 0 for a flat one.
double mean_ratio(const TetMesh& m, std::size_t t) {
  double edges = 0.0;
  for (int a = 0; a < 4; ++a)
    for (int b = a + 1; b < 4; ++b) edges += (m.vertices[m.tets[t][a]] - m.vertices[m.tets[t][b]]).squaredNorm();
  return 12.0 * std::pow(3.0 * tet_volume(m, t), 2.0 / 3.0) / edges;
}

double worst_mean_ratio(const TetMesh& m) {
  double worst = 1.0;
  for (std::size_t t = 0; t < m.tets.size(); ++t) worst = std::min(worst, mean_ratio(m, t));
  return worst;
}

}  // namespace

TEST_CASE("mesh_sphere: volume, validity, one component, every boundary vertex on the sphere") {
  // The grid cut at the sphere: no pits. Carve-and-snap held back 60 of 512 boundary vertices at 12
  // cells across (138 of 1,460 at 20, 618 of 5,870 at 40), which a render shows as missing cubes.
  for (double radius : {1.0, 0.37}) {
    for (double cells : {3.0, 6.0, 12.0, 20.0, 40.0}) {
      CAPTURE(radius);
      CAPTURE(cells);
      const double cell = 2.0 * radius / cells;
      const TetMesh m = mesh_sphere(radius, cell);
      const double analytic = 4.0 / 3.0 * kPi * radius * radius * radius;
      // The inscribed polyhedron loses the caps between the surface vertices: 18 % at 3 cells across,
      // 5 % at 6, 1.3 % at 12, 0.12 % at 40 (measured).
      CHECK(total_volume(m) <= analytic);
      CHECK(total_volume(m) >= (1.0 - (cells < 4.0 ? 0.2 : 0.4 / (cells * cells) * 12.0)) * analytic);
      // No cut leaves less than 0.4 of an edge, so no sliver: measured worst mean ratio 0.31–0.50,
      // smallest tet 9–23 % of a grid tet.
      CHECK(worst_mean_ratio(m) >= 0.25);
      CHECK(min_volume(m) >= 0.05 * cell * cell * cell / 6.0);
      CHECK(face_components(m) == 1);
      std::vector<char> used(m.vertices.size(), 0);
      for (const auto& t : m.tets)
        for (auto v : t) used[v] = 1;
      CHECK(std::count(used.begin(), used.end(), 0) == 0);
      std::size_t off = 0;
      const auto boundary = boundary_vertices(m);
      for (auto v : boundary) off += std::abs(m.vertices[v].norm() - radius) > 1e-12 * radius ? 1 : 0;
      CAPTURE(boundary.size());
      CHECK(off == 0);
    }
  }
}

TEST_CASE("mesh_sphere: mirror symmetric when asked") {
  // Every tet has its mirror image in the mesh: the cut's diagonals follow a folded order, and a
  // vertex on the mirror plane between two mirrored crossings goes to its nearest surface point.
  const TetMesh m = mesh_sphere(0.05, 0.1 / 12.0, {true, false, true});
  std::vector<std::array<double, 3>> centres;
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    const Vec3 c = tet_barycenter(m, t);
    centres.push_back({c.x(), c.y(), c.z()});
  }
  std::sort(centres.begin(), centres.end());
  for (const int axis : {0, 2}) {
    std::size_t missing = 0;
    for (const auto& c : centres) {
      std::array<double, 3> image = c;
      image[static_cast<std::size_t>(axis)] = -image[static_cast<std::size_t>(axis)];
      auto it = std::lower_bound(centres.begin(), centres.end(), std::array<double, 3>{image[0] - 1e-12, -kInfinity, -kInfinity});
      bool found = false;
      for (; it != centres.end() && (*it)[0] <= image[0] + 1e-12; ++it)
        found = found || (std::abs((*it)[1] - image[1]) <= 1e-12 && std::abs((*it)[2] - image[2]) <= 1e-12);
      missing += found ? 0 : 1;
    }
    CAPTURE(axis);
    CHECK(missing == 0);
  }
}

TEST_CASE("mesh_sphere: coarse and fine resolutions stay valid") {
  for (double cells_per_diameter : {2.0, 3.0, 6.0, 40.0}) {
    CAPTURE(cells_per_diameter);
    const TetMesh m = mesh_sphere(1.0, 2.0 / cells_per_diameter);
    CHECK(min_volume(m) > 0.0);
    CHECK(face_components(m) == 1);
  }
  const TetMesh fine = mesh_sphere(1.0, 0.05);
  CHECK(std::abs(total_volume(fine) - 4.0 / 3.0 * kPi) <= 0.01 * 4.0 / 3.0 * kPi);
}

TEST_CASE("mesh_cylinder: volume, validity, one component, exact caps") {
  const double radius = 1.0, height = 3.0, cell = 0.1;
  for (int axis = 0; axis < 3; ++axis) {
    CAPTURE(axis);
    const TetMesh m = mesh_cylinder(radius, height, axis, cell);
    const double analytic = kPi * radius * radius * height;
    CHECK(std::abs(total_volume(m) - analytic) <= 0.02 * analytic);
    CHECK(min_volume(m) >= 0.05 * cell * cell * cell / 6.0);
    CHECK(worst_mean_ratio(m) >= 0.25);
    CHECK(face_components(m) == 1);

    double w_lo = kInfinity, w_hi = -kInfinity, max_rho = 0.0;
    for (const Vec3& p : m.vertices) {
      w_lo = std::min(w_lo, p[axis]);
      w_hi = std::max(w_hi, p[axis]);
      Vec3 r = p;
      r[axis] = 0;
      max_rho = std::max(max_rho, r.norm());
    }
    CHECK(w_lo == -0.5 * height);
    CHECK(w_hi == 0.5 * height);
    CHECK(max_rho >= radius * (1 - 1e-12));
    CHECK(max_rho <= radius * (1 + 1e-12));

    // Every boundary vertex is in a cap plane or exactly on the cylinder (no pits in the side).
    std::size_t stray = 0, on_side = 0;
    for (auto v : boundary_vertices(m)) {
      const Vec3& p = m.vertices[v];
      Vec3 r = p;
      r[axis] = 0;
      const bool on_cap = p[axis] == w_lo || p[axis] == w_hi;
      const bool on_rim = std::abs(r.norm() - radius) <= 1e-12 * radius;
      on_side += on_rim ? 1 : 0;
      stray += on_cap || on_rim ? 0 : 1;
    }
    CAPTURE(on_side);
    CHECK(stray == 0);
    CHECK(on_side > 0);
  }
  CHECK_THROWS_AS(mesh_cylinder(1.0, 1.0, 3, 0.1), GeometryError);
}

TEST_CASE("mesh_cylinder: same mesh up to rotation for every axis") {
  // The grid is a permutation of axes, so volumes must agree closely (not bit-exactly: the
  // Freudenthal diagonal breaks the symmetry a little).
  const double v0 = total_volume(mesh_cylinder(0.5, 2.0, 0, 0.1));
  const double v2 = total_volume(mesh_cylinder(0.5, 2.0, 2, 0.1));
  CHECK(v0 == doctest::Approx(v2).epsilon(0.01));
}

TEST_CASE("read_tetgen: 1-based fixture with comments, blank lines, markers and attributes") {
  const TetMesh m = read_tetgen(data_dir() / "cube5.node");
  CHECK(m.vertices.size() == 8);
  CHECK(m.tets.size() == 5);
  CHECK(m.vertices[6].isApprox(Vec3(2, 3, 1)));
  CHECK(total_volume(m) == doctest::Approx(6.0).epsilon(1e-14));
  CHECK(tet_volume(m, 4) == doctest::Approx(2.0).epsilon(1e-14));  // the central tet is 1/3 of the box
  CHECK(min_volume(m) > 0.0);
  CHECK(check_neighbors_consistent(m) == 12);  // 6 box faces, 2 triangles each
  CHECK(tet_barycenter(m, 4).isApprox(Vec3(1.0, 1.5, 0.5)));
}

TEST_CASE("read_tetgen: 0-based fixture gives the same mesh") {
  const TetMesh a = read_tetgen(data_dir() / "cube5.node");
  const TetMesh b = read_tetgen(data_dir() / "cube5_0based.node");
  REQUIRE(a.vertices.size() == b.vertices.size());
  REQUIRE(a.tets.size() == b.tets.size());
  for (std::size_t i = 0; i < a.vertices.size(); ++i) CHECK(a.vertices[i] == b.vertices[i]);
  for (std::size_t t = 0; t < a.tets.size(); ++t) CHECK(a.tets[t] == b.tets[t]);
}

TEST_CASE("read_tetgen: inverted tets are flipped") {
  const TetMesh m = read_tetgen(data_dir() / "cube5_inverted.node");
  REQUIRE(m.tets.size() == 5);
  CHECK(min_volume(m) > 0.0);
  CHECK(total_volume(m) == doctest::Approx(6.0).epsilon(1e-14));
  // Same vertex sets as the properly oriented file.
  const TetMesh ref = read_tetgen(data_dir() / "cube5.node");
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    auto a = m.tets[t], b = ref.tets[t];
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    CHECK(a == b);
  }
}

TEST_CASE("read_tetgen: 10-node tets use their corners") {
  TempDir dir;
  write_file(dir.path / "quad.node",
             "10 3 0 0\n"
             "1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n"
             "5 0.5 0 0\n6 0.5 0.5 0\n7 0 0.5 0\n8 0 0 0.5\n9 0.5 0 0.5\n10 0 0.5 0.5\n");
  write_file(dir.path / "quad.ele", "1 10 0\n1 1 2 3 4 5 6 7 8 9 10\n");
  const TetMesh m = read_tetgen(dir.path / "quad.node");
  REQUIRE(m.tets.size() == 1);
  CHECK(m.tets[0] == std::array<std::uint32_t, 4>{0, 1, 2, 3});
  CHECK(tet_volume(m, 0) == doctest::Approx(1.0 / 6.0));
}

TEST_CASE("read_tetgen: errors name the file and line") {
  SUBCASE("degenerate tet") {
    const std::string msg = error_of([] { read_tetgen(data_dir() / "degenerate.node"); });
    CAPTURE(msg);
    CHECK(msg.find("degenerate.ele:5:") != std::string::npos);
    CHECK(msg.find("tet 3") != std::string::npos);
  }
  SUBCASE("missing .ele") {
    const std::string msg = error_of([] { read_tetgen(data_dir() / "orphan.node"); });
    CAPTURE(msg);
    CHECK(msg.find("orphan.ele") != std::string::npos);
  }
  SUBCASE("missing .node") {
    const std::string msg = error_of([] { read_tetgen(data_dir() / "no_such_mesh.node"); });
    CAPTURE(msg);
    CHECK(msg.find("no_such_mesh.node") != std::string::npos);
  }
  SUBCASE("bad token") {
    const std::string msg = error_of([] { read_tetgen(data_dir() / "bad_token.node"); });
    CAPTURE(msg);
    CHECK(msg.find("bad_token.node:5:") != std::string::npos);
    CHECK(msg.find("'1.0x5'") != std::string::npos);
  }
  SUBCASE("truncated") {
    const std::string msg = error_of([] { read_tetgen(data_dir() / "truncated.node"); });
    CAPTURE(msg);
    CHECK(msg.find("truncated.ele:") != std::string::npos);
    CHECK(msg.find("truncated") != std::string::npos);
  }
  SUBCASE("node index out of range") {
    const std::string msg = error_of([] { read_tetgen(data_dir() / "out_of_range.node"); });
    CAPTURE(msg);
    CHECK(msg.find("out_of_range.ele:3:") != std::string::npos);
    CHECK(msg.find("point index 5") != std::string::npos);
  }
  SUBCASE("truncated .node and bad header") {
    TempDir dir;
    write_file(dir.path / "short.node", "3 3 0 0\n1 0 0 0\n2 1 0 0\n");
    write_file(dir.path / "short.ele", "0 4 0\n");
    std::string msg = error_of([&] { read_tetgen(dir.path / "short.node"); });
    CHECK(msg.find("short.node:1:") != std::string::npos);
    write_file(dir.path / "flat.node", "3 2 0 0\n1 0 0\n2 1 0\n3 0 1\n");
    write_file(dir.path / "flat.ele", "0 4 0\n");
    msg = error_of([&] { read_tetgen(dir.path / "flat.node"); });
    CHECK(msg.find("flat.node:1:") != std::string::npos);
  }
}

TEST_CASE("read_tetgen: round trip through the tetgen program") {
  if (std::system("command -v tetgen > /dev/null 2>&1") != 0) {
    MESSAGE("tetgen is not installed; skipping");
    return;
  }
  TempDir dir;
  // A 2 x 1 x 1.5 box as a TetGen surface mesh (.smesh: points, then facets as polygons).
  write_file(dir.path / "box.smesh",
             "8 3 0 0\n"
             "1 0 0 0\n2 2 0 0\n3 2 1 0\n4 0 1 0\n"
             "5 0 0 1.5\n6 2 0 1.5\n7 2 1 1.5\n8 0 1 1.5\n"
             "6 0\n"
             "4 1 4 3 2\n4 5 6 7 8\n4 1 2 6 5\n4 2 3 7 6\n4 3 4 8 7\n4 4 1 5 8\n"
             "0\n0\n");
  const std::string cmd = "cd '" + dir.path.string() + "' && tetgen -pq1.4a0.01Q box.smesh > tetgen.log 2>&1";
  REQUIRE(std::system(cmd.c_str()) == 0);
  const TetMesh m = read_tetgen(dir.path / "box.1.node");
  CHECK(m.tets.size() > 100);
  CHECK(std::abs(total_volume(m) - 3.0) <= 1e-9 * 3.0);
  CHECK(min_volume(m) > 0.0);
  CHECK(face_components(m) == 1);
  check_neighbors_consistent(m);
}

TEST_CASE("face_neighbors: non-manifold meshes are rejected") {
  TetMesh m;
  m.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1), Vec3(0, 0, -1), Vec3(1, 1, 1)};
  m.tets = {{0, 1, 2, 3}, {0, 2, 1, 4}};
  auto nb = face_neighbors(m);
  CHECK(nb[0][3] == 1);  // face (0,1,2) is opposite local vertex 3 of tet 0
  CHECK(nb[1][3] == 0);
  CHECK(nb[0][0] == -1);
  m.tets.push_back({0, 1, 2, 5});  // a third tet on the same triangle
  CHECK_THROWS_AS(face_neighbors(m), GeometryError);
  m.tets = {{0, 1, 2, 9}};
  CHECK_THROWS_AS(face_neighbors(m), GeometryError);  // vertex index out of range
}

TEST_CASE("morton_order: matches a bit-by-bit interleave") {
  // Coordinates spanning exactly 0..2^21-1 quantize to themselves, so the order must equal sorting by
  // the naively interleaved code (ties by index).
  const double q_max = static_cast<double>((1u << 21) - 1u);
  std::mt19937_64 rng(12345);
  std::uniform_int_distribution<std::uint32_t> coord(0, (1u << 21) - 1u);
  std::vector<Vec3> pts = {Vec3(0, 0, 0), Vec3(q_max, q_max, q_max)};
  for (int i = 0; i < 2000; ++i) pts.emplace_back(coord(rng), coord(rng), coord(rng));
  pts.push_back(pts[5]);  // a duplicate point: tie broken by index
  std::vector<std::pair<std::uint64_t, std::uint32_t>> ref;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    ref.emplace_back(naive_morton(static_cast<std::uint64_t>(pts[i].x()), static_cast<std::uint64_t>(pts[i].y()),
                                  static_cast<std::uint64_t>(pts[i].z())),
                     static_cast<std::uint32_t>(i));
  }
  std::sort(ref.begin(), ref.end());
  const auto order = morton_order(pts);
  REQUIRE(order.size() == pts.size());
  for (std::size_t k = 0; k < order.size(); ++k) CHECK(order[k] == ref[k].second);

  // The 2x2x2 cube: x is the fastest bit, then y, then z.
  std::vector<Vec3> cube;
  for (int i = 7; i >= 0; --i) cube.emplace_back(i & 1, (i >> 1) & 1, (i >> 2) & 1);
  const auto co = morton_order(cube);
  for (int k = 0; k < 8; ++k) CHECK(co[static_cast<std::size_t>(k)] == static_cast<std::uint32_t>(7 - k));
}

TEST_CASE("morton_order: a permutation that groups nearby points") {
  const int n = 16;
  std::vector<Vec3> pts;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) pts.emplace_back(0.1 * i, 0.1 * j, 0.1 * k);
  std::mt19937 rng(7);
  std::shuffle(pts.begin(), pts.end(), rng);

  const auto order = morton_order(pts);
  REQUIRE(order.size() == pts.size());
  std::vector<std::uint32_t> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 0; i < sorted.size(); ++i) REQUIRE(sorted[i] == i);

  auto mean_step = [&](auto index) {
    double s = 0.0;
    for (std::size_t k = 1; k < pts.size(); ++k) s += (pts[index(k)] - pts[index(k - 1)]).norm();
    return s / static_cast<double>(pts.size() - 1);
  };
  const double morton = mean_step([&](std::size_t k) { return order[k]; });
  const double random = mean_step([](std::size_t k) { return k; });  // pts is shuffled
  CAPTURE(morton);
  CAPTURE(random);
  CHECK(morton < 0.25 * random);
  CHECK(morton < 2.0 * 0.1);  // on average within two grid spacings

  CHECK(morton_order({}).empty());
  CHECK(morton_order({Vec3(1, 2, 3)}) == std::vector<std::uint32_t>{0});
  CHECK(morton_order({Vec3(1, 1, 1), Vec3(1, 1, 1)}) == std::vector<std::uint32_t>{0, 1});
  CHECK_THROWS_AS(morton_order({Vec3(0, 0, 0), Vec3(std::nan(""), 0, 0)}), GeometryError);
}

TEST_CASE("reorder_tets: permutes tets, keeps vertices") {
  TetMesh m = mesh_box(Vec3(1, 1, 1), 0.5);
  const TetMesh before = m;
  std::vector<Vec3> centers;
  for (std::size_t t = 0; t < m.tets.size(); ++t) centers.push_back(tet_barycenter(m, t));
  const auto order = morton_order(centers);
  reorder_tets(m, order);
  REQUIRE(m.tets.size() == before.tets.size());
  for (std::size_t k = 0; k < order.size(); ++k) CHECK(m.tets[k] == before.tets[order[k]]);
  CHECK(m.vertices == before.vertices);
  CHECK(std::abs(total_volume(m) - 1.0) <= 1e-12);

  std::vector<std::uint32_t> bad(m.tets.size(), 0);
  CHECK_THROWS_AS(reorder_tets(m, bad), GeometryError);
  CHECK_THROWS_AS(reorder_tets(m, {0, 1}), GeometryError);
}

namespace {

// Area fraction of interior faces whose normal lies within `degrees` of a coordinate axis: the faces
// a crack can open along (systems/README.md §6.4), so this is the crack's pull toward the grid.
double axis_aligned_face_fraction(const TetMesh& mesh, double degrees) {
  const auto neighbors = face_neighbors(mesh);
  static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  const double cos_limit = std::cos(degrees * kPi / 180.0);
  double aligned = 0.0, total = 0.0;
  for (std::size_t t = 0; t < mesh.tets.size(); ++t)
    for (int k = 0; k < 4; ++k) {
      if (neighbors[t][k] < 0 || std::size_t(neighbors[t][k]) < t) continue;  // interior, once
      const auto& tet = mesh.tets[t];
      const Vec3 n = (mesh.vertices[tet[kFace[k][1]]] - mesh.vertices[tet[kFace[k][0]]])
                         .cross(mesh.vertices[tet[kFace[k][2]]] - mesh.vertices[tet[kFace[k][0]]]);
      const double area = 0.5 * n.norm();
      total += area;
      if (n.cwiseAbs().maxCoeff() / n.norm() >= cos_limit) aligned += area;
    }
  return aligned / total;
}

}  // namespace

TEST_CASE("jitter: seeded, keeps the box exact and every tet well shaped, removes the grid's directions") {
  const Vec3 size(0.6, 0.4, 0.2);
  const TetMesh grid = mesh_box(size, 0.04);
  TetMesh a = grid, b = grid, c = grid;
  const std::size_t moved = jitter_vertices(a, 0.3, 7);
  jitter_vertices(b, 0.3, 7);
  jitter_vertices(c, 0.3, 8);
  CHECK(moved > grid.vertices.size() / 2);
  // Same seed, same bits; another seed, another mesh.
  CHECK(std::memcmp(a.vertices.data(), b.vertices.data(), a.vertices.size() * sizeof(Vec3)) == 0);
  CHECK(std::memcmp(a.vertices.data(), c.vertices.data(), a.vertices.size() * sizeof(Vec3)) != 0);
  // The box keeps its shape: boundary vertices slide within their faces, so the volume is exact.
  double volume = 0.0, worst = kInfinity;
  for (std::size_t t = 0; t < a.tets.size(); ++t) {
    volume += tet_volume(a, t);
    worst = std::min(worst, tet_volume(a, t) / tet_volume(grid, t));
  }
  CHECK(volume == doctest::Approx(size.prod()).epsilon(1e-12));
  CHECK(worst >= 0.25);
  for (const Vec3& v : a.vertices) CHECK(((v.cwiseAbs() - 0.5 * size).array() <= 1e-12).all());
  // Grid alignment of the faces a crack can follow (normals within 10° of an axis): for randomly
  // oriented faces that is 3·(1 − cos 10°) = 4.6% of the (undirected) normals; the issue allows 5
  // points above that.
  const double before = axis_aligned_face_fraction(grid, 10.0), after = axis_aligned_face_fraction(a, 10.0);
  MESSAGE("interior face area with its normal within 10 deg of an axis: structured " << 100 * before
                                                                                       << "%, jittered " << 100 * after << "%");
  CHECK(before > 0.3);
  CHECK(after <= 3.0 * (1.0 - std::cos(10.0 * kPi / 180.0)) + 0.05);
}
