// Crack face smoothing (systems/crack_smoothing.cpp, systems/README.md §6.6): a box cut along a
// plane that is not a grid plane gets a stair-step crack of tet faces; smoothing must make it closer
// to the plane while every tet keeps ≥ 0.2 of its volume, every piece stays closed and the two sides
// of the crack keep coinciding in the reference configuration.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "systems/bond_rules.hpp"
#include "support.hpp"
#include "tools/crack_stats.hpp"

using namespace perifx;

namespace {

// A 0.6 × 0.6 × 0.3 box of 0.05 cells (jitter 0), every bond crossing the plane through `point`
// with normal (1, 2.5, 0) broken: two pieces.
WorldState& cut_box(World& world, const Vec3& normal, const Vec3& point) {
  WorldState& w = world.state_mutable();
  const auto& x = w.particles.reference_position;
  Bonds& b = w.bonds;
  for (std::uint32_t i = 0; i < b.particle_count(); ++i)
    for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k) {
      const std::uint32_t j = b.neighbor[k];
      if (b.alive[k] && ((x[i] - point).dot(normal) > 0) != ((x[j] - point).dot(normal) > 0))
        b.alive[k] = b.alive[systems::mirror_bond(b, i, k)] = 0;
    }
  systems::collect_crack_faces(w);
  systems::split_mesh_vertices(w);
  return w;
}

double tet_volume(const std::vector<Vec3>& X, const std::array<std::uint32_t, 4>& t) {
  return (X[t[1]] - X[t[0]]).dot((X[t[2]] - X[t[0]]).cross(X[t[3]] - X[t[0]])) / 6.0;
}

struct Measure {
  CrackStats stats;
  double rms_distance = 0.0;  // crack vertices' reference positions to the cut plane
  std::size_t open_edges = 0, unmatched_crack = 0, not_opposite = 0;
  double min_volume_fraction = 1e300;
};

Measure measure(WorldState& w, const Vec3& n, const Vec3& point) {
  Measure m;
  systems::update_mesh_vertices(w, 0.0);
  std::vector<std::uint32_t> id;
  systems::compute_fragments(w, id);
  SurfaceMesh s;
  systems::extract_surface(w, &id, s);
  CrackSurface c;
  c.vertex = s.reference;
  std::set<std::uint32_t> crack_vertices;
  std::map<std::array<double, 9>, std::vector<std::size_t>> twins;
  for (std::size_t f = 0; f < s.triangles.size(); ++f) {
    if (!s.crack[f]) continue;
    c.triangle.push_back(s.triangles[f]);
    std::array<std::array<double, 3>, 3> p;
    for (int k = 0; k < 3; ++k) {
      const Vec3& r = s.reference[s.triangles[f][static_cast<std::size_t>(k)]];
      crack_vertices.insert(s.triangles[f][static_cast<std::size_t>(k)]);
      p[static_cast<std::size_t>(k)] = {r.x(), r.y(), r.z()};
    }
    std::sort(p.begin(), p.end());
    std::array<double, 9> key{};
    for (int i = 0; i < 9; ++i) key[static_cast<std::size_t>(i)] = p[static_cast<std::size_t>(i / 3)][static_cast<std::size_t>(i % 3)];
    twins[key].push_back(f);
  }
  // Both sides: every crack triangle has one twin at the same reference positions, wound the other way.
  auto ref_normal = [&](std::size_t f) {
    const auto& t = s.triangles[f];
    return Vec3((s.reference[t[1]] - s.reference[t[0]]).cross(s.reference[t[2]] - s.reference[t[0]]));
  };
  for (const auto& [key, fs] : twins) {
    if (fs.size() != 2) {
      m.unmatched_crack += fs.size();
      continue;
    }
    const Vec3 a = ref_normal(fs[0]), b = ref_normal(fs[1]);
    m.not_opposite += !(a.dot(b) < 0.0 && std::abs(a.dot(b) + a.squaredNorm()) <= 1e-9 * a.squaredNorm());
  }
  CrackStatsOptions opt;
  opt.radius = 0.15;
  m.stats = crack_statistics(c, opt);
  double sum = 0.0;
  for (auto v : crack_vertices) sum += std::pow((s.reference[v] - point).dot(n), 2);
  m.rms_distance = std::sqrt(sum / static_cast<double>(crack_vertices.size()));
  // Open edges of the current surface (welded by source = embedded vertex).
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
  for (const auto& t : s.triangles)
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t a = s.source[t[static_cast<std::size_t>(e)]], b = s.source[t[static_cast<std::size_t>((e + 1) % 3)]];
      uses[{std::min(a, b), std::max(a, b)}] += a < b ? 1 : -1;  // a closed surface uses each edge both ways
    }
  for (const auto& [edge, balance] : uses) m.open_edges += balance != 0;
  for (std::size_t t = 0; t < w.embedded.tets.size(); ++t)
    m.min_volume_fraction = std::min(m.min_volume_fraction, tet_volume(w.embedded.reference_vertices, w.embedded.tets[t]) /
                                                                tet_volume(w.mesh.vertices, w.mesh.tets[t]));
  return m;
}

}  // namespace

TEST_CASE("crack smoothing: a stair-step crack gets closer to its plane, tets stay positive, pieces closed, sides coincide") {
  auto sc = test::box_scene(Vec3(0.6, 0.6, 0.3), 0.05, 5e5, 3e5);
  World world(sc);
  const Vec3 n = Vec3(1, 2.5, 0).normalized(), point(0.013, 0.007, 0.0);
  WorldState& w = cut_box(world, n, point);

  systems::smooth_crack_faces(w, 0);
  const Measure before = measure(w, n, point);
  const std::size_t moved = systems::smooth_crack_faces(w, 3);
  const std::vector<Vec3> first = w.embedded.reference_vertices;
  const Measure after = measure(w, n, point);
  MESSAGE("moved " << moved << "; area ratio " << before.stats.area_ratio << " -> " << after.stats.area_ratio
                   << "; mean dihedral " << before.stats.mean_dihedral << " -> " << after.stats.mean_dihedral
                   << " deg; rms distance to plane " << before.rms_distance << " -> " << after.rms_distance
                   << " m; min tet volume fraction " << after.min_volume_fraction);
  CHECK(moved > 0);
  CHECK(before.stats.faces == after.stats.faces);
  // Unsmoothed: a stair-step (tet faces on a plane 22° off the grid); the reference is exact.
  CHECK(before.min_volume_fraction == doctest::Approx(1.0).epsilon(1e-12));
  CHECK(before.stats.area_ratio > 1.1);
  // Smoothed: the excess area over the best-fit plane and the distance to the cut plane at least
  // halved, the mean dihedral angle down by at least a third (the flat answer is 1, 0 and 0°; the
  // rim on the box's faces only slides along the faces, which keeps some folds near it).
  CHECK(after.stats.area_ratio - 1.0 < 0.5 * (before.stats.area_ratio - 1.0));
  CHECK(after.stats.mean_dihedral < (2.0 / 3.0) * before.stats.mean_dihedral);
  CHECK(after.rms_distance < 0.5 * before.rms_distance);
  // Contracts: tets keep ≥ 0.2 of their volume, surfaces stay closed, the two sides coincide.
  CHECK(after.min_volume_fraction >= 0.2);
  CHECK(after.open_edges == 0);
  CHECK(before.open_edges == 0);
  CHECK(after.unmatched_crack == 0);
  CHECK(after.not_opposite == 0);
  // Restarts from the original mesh: the same result again, and 0 iterations restore it.
  systems::smooth_crack_faces(w, 3);
  CHECK(w.embedded.reference_vertices == first);
  systems::smooth_crack_faces(w, 0);
  for (std::size_t v = 0; v < w.embedded.reference_vertices.size(); ++v)
    CHECK(w.embedded.reference_vertices[v] == w.mesh.vertices[w.embedded.origin[v]]);
}

TEST_CASE("crack smoothing: a crack on a grid plane stays on it, and the outer box keeps its faces") {
  auto sc = test::box_scene(Vec3(0.6, 0.6, 0.3), 0.05, 5e5, 3e5);
  World world(sc);
  const Vec3 n(0, 1, 0), point(0, 0, 0);
  WorldState& w = cut_box(world, n, point);
  systems::smooth_crack_faces(w, 3);
  const Measure m = measure(w, n, point);
  CHECK(m.rms_distance < 1e-15);
  CHECK(m.open_edges == 0);
  // Vertices on the box's faces stay on them.
  std::size_t off_box = 0;
  for (std::size_t v = 0; v < w.embedded.reference_vertices.size(); ++v) {
    const Vec3 X0 = w.mesh.vertices[w.embedded.origin[v]], X = w.embedded.reference_vertices[v];
    const Vec3 half(0.3, 0.3, 0.15);
    for (int a = 0; a < 3; ++a)
      if (std::abs(std::abs(X0[a]) - half[a]) < 1e-12) off_box += std::abs(X[a] - X0[a]) > 1e-15;
  }
  CHECK(off_box == 0);
}

TEST_CASE("crack smoothing: no vertex is drawn out of its tets' reach (a shattered box with lone tets)") {
  // Lone debris tets are drawn rigidly from their one particle, so a crack vertex that smoothing pulls
  // far from it becomes a spike (the full glass walls, frame 2: a vertex moved from 1.30 to 2.56 cm of
  // its particle, δ = 2.39 cm). Shatter a box with cuts through the middle and free every 7th particle
  // of a band, then check every vertex's reach from every tet it belongs to.
  auto sc = test::box_scene(Vec3(0.6, 0.6, 0.3), 0.05, 5e5, 3e5);
  World world(sc);
  WorldState& w = world.state_mutable();
  const auto& x = w.particles.reference_position;
  Bonds& b = w.bonds;
  const Vec3 normals[] = {Vec3(1, 2.5, 0), Vec3(-2, 0.7, 1), Vec3(0.3, -1, 2.2), Vec3(1.7, 1.1, -0.4)};
  const Vec3 points[] = {Vec3(0.013, 0.007, 0), Vec3(-0.08, 0.02, 0.01), Vec3(0.05, -0.06, 0.02), Vec3(0.1, 0.1, -0.03)};
  auto freed = [&](std::uint32_t i) { return i % 7 == 3 && std::abs(x[i].z()) < 0.08 && x[i].norm() < 0.25; };
  std::size_t lone = 0;
  for (std::uint32_t i = 0; i < b.particle_count(); ++i) {
    lone += freed(i);
    for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k) {
      const std::uint32_t j = b.neighbor[k];
      bool cut = freed(i) || freed(j);
      for (int c = 0; c < 4; ++c)
        cut = cut || (((x[i] - points[c]).dot(normals[c]) > 0) != ((x[j] - points[c]).dot(normals[c]) > 0));
      if (b.alive[k] && cut) b.alive[k] = b.alive[systems::mirror_bond(b, i, k)] = 0;
    }
  }
  systems::collect_crack_faces(w);
  systems::split_mesh_vertices(w);
  const std::size_t moved = systems::smooth_crack_faces(w, 3);
  // Reach: the larger of the vertex's original distance and 0.9 δ from the particle of each of its tets.
  std::size_t out_of_reach = 0;
  double worst = 0.0;
  const auto& e = w.embedded;
  for (std::size_t t = 0; t < e.tets.size(); ++t)
    for (auto v : e.tets[t]) {
      const double d = (e.reference_vertices[v] - x[t]).norm(), d0 = (w.mesh.vertices[e.origin[v]] - x[t]).norm();
      const double reach = std::max(d0, 0.9 * w.model.horizon[t]);
      worst = std::max(worst, d / w.model.horizon[t]);
      out_of_reach += d > reach * (1.0 + 1e-12);
    }
  MESSAGE(lone << " lone particles, " << moved << " vertices moved; farthest vertex " << worst << " δ from a tet's particle");
  CHECK(moved > 100);
  CHECK(out_of_reach == 0);
}
