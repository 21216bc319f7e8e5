// engine/animation.*: per-piece best-fit rigid motion (Kabsch, mass-weighted) and the vertex history
// behind the point cache: a spinning, drifting box is recovered exactly; on a breaking pane, copies
// sit on their original until they exist, pieces know their parents, and the cache's last frame is
// the world's final surface.
#include <doctest/doctest.h>

#include <set>

#include "animation.hpp"
#include "support.hpp"

using namespace perifx;

TEST_CASE("a rigidly spinning box: the piece's rotation, translation and velocities are the imposed motion") {
  World world(test::box_scene(Vec3(0.3, 0.2, 0.1), 0.05, 1e6, 6e5));
  const Vec3 v0(0.5, -0.25, 1.0), w0(0.0, 3.0, 1.0);
  const auto x = world.reference_positions();
  Vec3 c = Vec3::Zero();
  for (const Vec3& p : x) c += p;
  c /= double(x.size());  // uniform masses: the box's centre of mass
  auto v = world.velocities_mutable();
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = v0 + w0.cross(x[i] - c);
  AnimationHistory h;
  world.tet_mesh();  // the caller evaluates the vertices once per frame
  record_animation_frame(h, world, 0);
  world.step(200);
  world.tet_mesh();
  record_animation_frame(h, world, 1);
  REQUIRE(h.frames.size() == 2);
  REQUIRE(h.frames[1].pieces.size() == 1);
  const PieceSample& p = h.frames[1].pieces[0];
  CHECK(p.particles == world.particle_count());
  double mass = 0.0;
  const auto* m = static_cast<const double*>(world.field("mass").data);
  for (std::size_t i = 0; i < world.particle_count(); ++i) mass += m[i];
  CHECK(p.mass == doctest::Approx(mass).epsilon(1e-12));
  // The fit reproduces every particle to within the solid's small elastic wobble.
  const auto y = world.positions();
  double worst = 0.0;
  for (std::size_t i = 0; i < y.size(); ++i) worst = std::max(worst, (p.rotation * x[i] + p.translation - y[i]).norm());
  CHECK(worst < 1e-3);
  CHECK((p.rotation * p.rotation.transpose() - Mat3::Identity()).norm() < 1e-12);
  CHECK(p.rotation.determinant() == doctest::Approx(1.0));
  CHECK((p.velocity - v0).norm() < 1e-9);
  CHECK((p.angular_velocity - w0).norm() < 0.02 * w0.norm());
  // The rotation turned by about |w| t.
  const double angle = Eigen::AngleAxisd(p.rotation).angle();
  CHECK(angle == doctest::Approx(w0.norm() * world.time()).epsilon(0.02));
  CHECK(h.origins.at(p.id).birth_frame == 0);
  CHECK(h.origins.at(p.id).parent == kNoPiece);
  const Eigen::Vector4d q = rotation_quaternion(p.rotation);
  CHECK(q.norm() == doctest::Approx(1.0));
  CHECK(q[3] >= 0.0);
}

TEST_CASE("a breaking pane: pieces have parents, copies sit on their original, the cache ends on the final surface") {
  World world = World::from_file(std::string(PERIFX_SOURCE_DIR) + "/tests/engine/data/export_pane.json");
  AnimationHistory h;
  h.record_vertices = true;
  h.min_piece_tets = world.scene().output.min_piece_tets;
  const std::uint64_t steps_per_frame = 25;
  SurfaceMesh final_surface;
  for (std::uint64_t k = 0; k <= 8; ++k) {
    if (k) world.step(steps_per_frame);
    final_surface = world.surface();  // one evaluation of the vertices per frame, as the runner does
    record_animation_frame(h, world, k);
  }
  REQUIRE(h.frames.size() == 9);
  // Fracture happened: vertex copies and more than one piece, each later one with a parent that
  // existed before it.
  CHECK(h.vertex_parent.size() > h.frames.front().vertex_count);
  CHECK(h.frames.back().pieces.size() > 1);
  int born_later = 0;
  for (const auto& [id, o] : h.origins) {
    if (o.birth_frame == 0) {
      CHECK(o.parent == kNoPiece);
      continue;
    }
    ++born_later;
    REQUIRE(h.origins.count(o.parent) == 1);
    CHECK(h.origins.at(o.parent).birth_frame < o.birth_frame);
  }
  CHECK(born_later > 0);
  for (std::size_t v = 0; v < h.vertex_parent.size(); ++v) {
    CHECK(h.vertex_parent[v] <= v);
    if (h.vertex_parent[v] != v) CHECK(h.vertex_birth[v] > 0);
  }
  // Before it exists a copy is where its parent is.
  for (std::size_t f = 0; f < h.frames.size(); ++f)
    for (std::uint32_t v = h.frames[f].vertex_count; v < h.vertex_parent.size(); ++v)
      CHECK((vertex_position(h, f, v) - vertex_position(h, f, h.vertex_parent[v])).norm() == 0.0);
  // Pieces that do not exist yet take their ancestor's pose.
  for (const auto& [id, o] : h.origins)
    if (o.birth_frame > 0 && h.frames.back().pieces.end() !=
                                 std::find_if(h.frames.back().pieces.begin(), h.frames.back().pieces.end(),
                                              [&](const PieceSample& p) { return p.id == id; })) {
      const PieceSample* before = piece_pose(h, 0, id);
      REQUIRE(before != nullptr);
      CHECK(before->id != id);
    }

  const AnimationCache cache = build_animation_cache(h, final_surface);
  REQUIRE(cache.frames.size() == 9);
  CHECK(cache.surface.vertices.size() == final_surface.vertices.size());
  CHECK(cache.surface.triangles.size() == final_surface.triangles.size());
  double worst = 0.0;
  for (std::size_t k = 0; k < cache.surface.vertices.size(); ++k)
    for (int d = 0; d < 3; ++d)
      worst = std::max(worst, std::abs(double(cache.frames.back()[3 * k + d]) - cache.surface.vertices[k][d]));
  CHECK(worst < 1e-6);
  // Vertices in first-use order, triangles by (piece, crack).
  std::uint32_t next = 0;
  for (const auto& t : cache.surface.triangles)
    for (auto v : t) {
      CHECK(v <= next);
      if (v == next) ++next;
    }
  for (std::size_t f = 1; f < cache.surface.triangles.size(); ++f) {
    const auto a = std::make_pair(cache.surface.fragment[f - 1], cache.surface.crack[f - 1]);
    const auto b = std::make_pair(cache.surface.fragment[f], cache.surface.crack[f]);
    CHECK(a <= b);
  }
  // Crack faces get UVs in [0, 1].
  for (std::size_t f = 0; f < cache.crack_uv.size(); ++f)
    for (const auto& uv : cache.crack_uv[f])
      for (double c : uv) CHECK((c >= -1e-12 && c <= 1.0 + 1e-12));
}
