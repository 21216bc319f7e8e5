// perifx crack-stats (engine/tools/crack_stats.cpp) on constructed crack surfaces with exact answers:
// axis-aligned area fraction, merged twin faces, mirror tilts, stair-step roughness.
#include <doctest/doctest.h>

#include <cmath>

#include "support.hpp"
#include "tools/crack_stats.hpp"

using namespace perifx;

namespace {


// Adds the rectangle p + s·u + t·w (s, t in [0, 1]) as a grid of m × k cells, two triangles each.
void add_rect(CrackSurface& c, const Vec3& p, const Vec3& u, const Vec3& w, int m, int k) {
  const auto base = static_cast<std::uint32_t>(c.vertex.size());
  for (int i = 0; i <= m; ++i)
    for (int j = 0; j <= k; ++j) c.vertex.push_back(p + (double(i) / m) * u + (double(j) / k) * w);
  auto id = [&](int i, int j) { return base + static_cast<std::uint32_t>(i * (k + 1) + j); };
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < k; ++j) {
      c.triangle.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      c.triangle.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
}

}  // namespace

TEST_CASE("crack-stats: axis-aligned area fraction of two flat cracks, twins counted once") {
  CrackSurface c;
  // 30° from the y axis: 30° from y, 60° from x, 90° from z: not within 10° of an axis. Area 2 × 1.
  const double t = 30.0 * kPi / 180.0;
  add_rect(c, Vec3(0, 0, 0), 2.0 * Vec3(std::cos(t), -std::sin(t), 0), Vec3(0, 0, 1), 4, 3);
  // Normal 5° from x: aligned. Area 1 × 1.
  const double s = 5.0 * kPi / 180.0;
  add_rect(c, Vec3(5, 0, 0), Vec3(-std::sin(s), std::cos(s), 0), Vec3(0, 0, 1), 3, 2);
  // The second side of the first crack: same positions, separate vertices, opposite winding.
  CrackSurface twin;
  add_rect(twin, Vec3(0, 0, 0), 2.0 * Vec3(std::cos(t), -std::sin(t), 0), Vec3(0, 0, 1), 4, 3);
  const auto offset = static_cast<std::uint32_t>(c.vertex.size());
  c.vertex.insert(c.vertex.end(), twin.vertex.begin(), twin.vertex.end());
  for (auto tri : twin.triangle) c.triangle.push_back({tri[0] + offset, tri[2] + offset, tri[1] + offset});

  CrackStatsOptions opt;
  const CrackStats st = crack_statistics(c, opt);
  CHECK(st.faces == 4 * 3 * 2 + 3 * 2 * 2);
  CHECK(st.area == doctest::Approx(3.0).epsilon(1e-12));
  CHECK(st.axis_aligned_fraction == doctest::Approx(1.0 / 3.0).epsilon(1e-12));
  // Flat pieces: no dihedral angle, area equal to its projection.
  CHECK(std::abs(st.mean_dihedral) < 1e-6);
  CHECK(st.area_ratio == doctest::Approx(1.0).epsilon(1e-12));
  // A tolerance of 4°: the 5° crack is not aligned any more.
  opt.axis_tolerance_deg = 4.0;
  CHECK(crack_statistics(c, opt).axis_aligned_fraction == 0.0);
}

TEST_CASE("crack-stats: mirror fit gives each side's tilt; mirror images have equal tilts") {
  // Right crack from (0.01, 0, 0) rising at θ, through a plate 0.02 thick (z).
  auto build = [](double right_deg, double left_deg) {
    CrackSurface c;
    const double r = right_deg * kPi / 180.0, l = left_deg * kPi / 180.0;
    add_rect(c, Vec3(0.01, 0, -0.01), 0.05 * Vec3(std::cos(r), std::sin(r), 0), Vec3(0, 0, 0.02), 6, 2);
    add_rect(c, Vec3(-0.01, 0, -0.01), 0.05 * Vec3(-std::cos(l), std::sin(l), 0), Vec3(0, 0, 0.02), 6, 2);
    return c;
  };
  CrackStatsOptions opt;
  opt.mirror_axis = 0;
  opt.load_axis = 1;
  {
    const CrackStats st = crack_statistics(build(20.0, 20.0), opt);
    REQUIRE(st.mirror);
    CHECK(st.left.faces == 24);
    CHECK(st.right.faces == 24);
    CHECK(st.right.tilt == doctest::Approx(20.0).epsilon(1e-9));
    CHECK(st.left.tilt == doctest::Approx(20.0).epsilon(1e-9));
    CHECK(st.right.angle_to_load == doctest::Approx(70.0).epsilon(1e-9));
    CHECK(st.left.angle_to_load == doctest::Approx(70.0).epsilon(1e-9));
    CHECK(std::abs(st.asymmetry) < 1e-9);
  }
  {
    // Both cracks on one straight line through the mirror plane (a 2-fold rotation, not a mirror):
    // tilts +15 and −15.
    const CrackStats st = crack_statistics(build(15.0, -15.0), opt);
    CHECK(st.right.tilt == doctest::Approx(15.0).epsilon(1e-9));
    CHECK(st.left.tilt == doctest::Approx(-15.0).epsilon(1e-9));
    CHECK(st.asymmetry == doctest::Approx(30.0).epsilon(1e-9));
  }
  {
    // Square to the load: 90° to the load axis, no tilt.
    const CrackStats st = crack_statistics(build(0.0, 0.0), opt);
    CHECK(st.right.angle_to_load == doctest::Approx(90.0).epsilon(1e-12));
    CHECK(std::abs(st.right.tilt) < 1e-9);
  }
}

TEST_CASE("crack-stats: a 45° stair-step has area ratio √2 and its exact mean dihedral angle") {
  // n steps of run a and rise a, depth d in z: a tread (normal y) then a riser (normal x), each a
  // single rectangle of two triangles. The best-fit plane of the whole staircase is the diagonal
  // (the staircase is mirror-symmetric about x + y = n·a), so area / projected area = 1/cos 45°.
  const int n = 4;
  const double a = 0.25, d = 0.5;  // binary fractions: shared corners have equal coordinates
  CrackSurface c;
  for (int k = 0; k < n; ++k) {
    add_rect(c, Vec3(k * a, k * a, 0), Vec3(a, 0, 0), Vec3(0, 0, d), 1, 1);        // tread
    add_rect(c, Vec3((k + 1) * a, k * a, 0), Vec3(0, a, 0), Vec3(0, 0, d), 1, 1);  // riser
  }
  CrackStatsOptions opt;
  opt.radius = 10.0;  // every face sees every other
  const CrackStats st = crack_statistics(c, opt);
  CHECK(st.faces == 4u * n);
  CHECK(st.axis_aligned_fraction == doctest::Approx(1.0).epsilon(1e-12));
  CHECK(st.area_ratio == doctest::Approx(std::sqrt(2.0)).epsilon(1e-9));
  // 2n rectangles: 2n diagonals (0°) and 2n − 1 corners (90°) shared by two faces.
  CHECK(st.dihedral_edges == 4u * n - 1);
  CHECK(st.mean_dihedral == doctest::Approx(90.0 * (2 * n - 1) / (4 * n - 1)).epsilon(1e-9));
}
