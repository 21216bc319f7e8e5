// Colliders (systems/colliders.cpp) and the surface frames they read (systems/surface_frames.cpp):
// a body meets a collider with its mesh surface (its tets' boundary triangles), placed by each
// particle's fitted deformation, not with its particle centres.
#include <doctest/doctest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "support.hpp"
#include "systems/collider_shapes.hpp"
#include "systems/systems.hpp"

using namespace perifx;

namespace {

double lowest_surface_y(const World& world) {
  double lowest = kInfinity;
  for (const Vec3& v : world.surface().vertices) lowest = std::min(lowest, v.y());
  return lowest;
}

double lowest_particle_y(const World& world) {
  double lowest = kInfinity;
  for (const Vec3& y : world.positions()) lowest = std::min(lowest, y.y());
  return lowest;
}

}  // namespace

TEST_CASE("a body settles on the ground with its mesh surface on the plane, at any resolution") {
  // A 12 × 6 × 12 cm box, 2 mm above the ground, falls and settles (mass damping). Its weight
  // compresses it by ρgH/E ≈ 6e-5 m, under 1 % of the finer cell: the surface must end on the plane.
  // Before the faces took part, the particle centres rested on the plane and the rendered surface sank
  // a resolution-dependent 0.25–0.5 cell into it.
  for (const double cell : {0.03, 0.015}) {
    CAPTURE(cell);
    auto sc = test::box_scene(Vec3(0.12, 0.06, 0.12), cell, 8e6, 4.8e6);
    sc.bodies[0].transform.translation = Vec3(0.0, 0.032, 0.0);
    sc.gravity = Vec3(0.0, -9.81, 0.0);
    sc.materials[0].damping = 60.0;
    sc.output.obj = true;  // the embedded mesh, whose surface is measured
    scene::Collider ground;
    sc.colliders.push_back(ground);
    {
      World probe(sc);
      sc.time.dt = 0.5 * probe.stable_time_step();
    }
    World world(sc);
    REQUIRE_FALSE(world.state().state.surface_frame.empty());
    world.step(static_cast<int>(0.25 / world.dt()));
    const double surface = lowest_surface_y(world), centres = lowest_particle_y(world);
    double speed = 0.0;
    for (const Vec3& v : world.velocities()) speed = std::max(speed, v.norm());
    MESSAGE("cell " << cell << " m: lowest surface vertex y " << surface << " m (" << surface / cell
                    << " cell), lowest particle centre " << centres / cell << " cell, fastest particle " << speed
                    << " m/s");
    CHECK(speed < 0.01);                                  // at rest
    CHECK(std::abs(surface) < 0.01 * cell + 1e-4);        // the surface is on the plane
    CHECK(centres > 0.15 * cell);                         // the centres are not what touches it
  }
}

TEST_CASE("a turned body is met at its turned faces: the push is the depth of its lowest face") {
  // A 6 × 4 × 4 cm box turned by 90° about z (its reference −x face now faces down) and lowered so
  // that face is 1 mm below the ground plane. One collider pass must lift exactly the particles with a
  // boundary face touching that face (a corner on it), each by 1 mm, and move no other particle.
  // Faces moved with the particles but not turned would put the old −y face's particles at the
  // bottom instead and push by other amounts.
  const double cell = 0.01, sink = 1e-3;
  auto sc = test::box_scene(Vec3(0.06, 0.04, 0.04), cell, 8e6, 4.8e6);
  scene::Collider ground;
  sc.colliders.push_back(ground);
  World world(sc);
  WorldState& w = world.state_mutable();
  const Mat3 turn = Eigen::AngleAxisd(0.5 * M_PI, Vec3::UnitZ()).toRotationMatrix();
  const auto& x = w.particles.reference_position;
  double x_min = kInfinity;
  for (const Vec3& v : w.mesh.vertices) x_min = std::min(x_min, v.x());
  // The reference −x face at x_min goes to height turn·(x_min, ·, ·).y = x_min; lower it to −sink.
  const Vec3 shift(0.0, -sink - x_min, 0.0);
  for (std::size_t i = 0; i < x.size(); ++i) w.particles.position[i] = turn * x[i] + shift;
  systems::update_surface_frames(w);
  const std::vector<Vec3> before = w.particles.position;
  systems::collider_system(w).run();
  std::size_t lifted = 0, expected = 0;
  double worst = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    // Particles with a boundary face that has a corner on the reference −x face.
    bool on_face = false;
    for (std::uint32_t q = w.surface.offsets[i]; q < w.surface.offsets[i + 1]; ++q)
      for (const Vec3& corner : w.surface.corner[q]) on_face = on_face || x[i].x() + corner.x() < x_min + 1e-12;
    const Vec3 moved = w.particles.position[i] - before[i];
    if (on_face) {
      ++expected;
      worst = std::max(worst, (moved - Vec3(0.0, sink, 0.0)).norm());
      if (moved.y() > 0.0) ++lifted;
    } else {
      worst = std::max(worst, moved.norm());
    }
  }
  MESSAGE(expected << " particles on the turned face, " << lifted << " lifted; largest error of a push " << worst
                   << " m");
  CHECK(expected > 0);
  CHECK(lifted == expected);
  CHECK(worst < 1e-8);  // F in float: ~1e-7 of a corner offset (~5 mm)
}

TEST_CASE("triangle penetration: exact against a plane, a sphere and a box") {
  scene::Collider plane;
  const systems::PlacedCollider pp = systems::place_collider(plane, 0.0);
  const std::array<Vec3, 3> t{Vec3(0, -0.2, 0), Vec3(1, 0.3, 0), Vec3(0, 0.5, 1)};
  CHECK(systems::triangle_penetration(pp, t).depth == doctest::Approx(0.2).epsilon(1e-15));

  scene::Collider ball;
  ball.kind = scene::Collider::Kind::sphere;
  ball.center = Vec3(0.25, 1.0, 0.25);
  ball.radius = 1.1;
  const auto ps = systems::place_collider(ball, 0.0);
  // The flat triangle z = 0 spanning (0,0), (1,0), (0,1) in x–y; the sphere's centre projects to
  // (0.25, 1.0), beyond the hypotenuse x + y = 1, so the nearest point is on that edge.
  const std::array<Vec3, 3> flat{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  const Vec3 nearest(0.125, 0.875, 0.0);  // the foot of (0.25, 1.0) on x + y = 1
  const auto pen = systems::triangle_penetration(ps, flat);
  CHECK(pen.depth == doctest::Approx(1.1 - (nearest - ball.center).norm()).epsilon(1e-14));
  CHECK((pen.normal - (nearest - ball.center).normalized()).norm() < 1e-14);

  scene::Collider box;
  box.kind = scene::Collider::Kind::box;
  box.half_extents = Vec3(1, 1, 1);
  const auto pb = systems::place_collider(box, 0.0);
  // A triangle dipping 0.1 into the top face (y = 1), well inside in x and z: pushed up by 0.1.
  const std::array<Vec3, 3> dip{Vec3(0, 0.9, 0), Vec3(0.5, 1.5, 0), Vec3(0, 1.5, 0.5)};
  const auto pen_box = systems::triangle_penetration(pb, dip);
  CHECK(pen_box.depth == doctest::Approx(0.1).epsilon(1e-14));
  CHECK(pen_box.normal.isApprox(Vec3::UnitY()));
  // Beside the box: no overlap.
  const std::array<Vec3, 3> beside{Vec3(1.2, 0, 0), Vec3(1.5, 0.5, 0), Vec3(1.3, 0, 0.5)};
  CHECK(systems::triangle_penetration(pb, beside).depth <= 0.0);
}

TEST_CASE("a particle with no face toward the ground meets it with its sphere of reach") {
  // A tet exposed by a crack (or any particle without an original face toward the collider) rests on
  // its sphere of reach, half the contact distance, like the projectiles' contact: one collider pass
  // lifts an interior particle placed with its centre a quarter of its reach above the plane to exactly
  // its reach above it. Its neighbours stay where they are (the body floats 10 cm up).
  auto sc = test::box_scene(Vec3(0.06, 0.06, 0.06), 0.01, 8e6, 4.8e6);
  sc.bodies[0].transform.translation = Vec3(0.0, 0.1, 0.0);
  scene::Collider ground;
  sc.colliders.push_back(ground);
  World world(sc);
  WorldState& w = world.state_mutable();
  std::size_t interior = w.particles.count();
  for (std::size_t i = 0; i < w.particles.count() && interior == w.particles.count(); ++i)
    if (w.surface.offsets[i] == w.surface.offsets[i + 1] && (w.particles.reference_position[i] - Vec3(0, 0.1, 0)).norm() < 0.01)
      interior = i;
  REQUIRE(interior < w.particles.count());
  const double reach = 0.5 * w.contact.distance_factor * w.contact.size[interior];
  w.particles.position[interior].y() = 0.25 * reach;
  systems::update_surface_frames(w);
  const std::vector<Vec3> before = w.particles.position;
  systems::collider_system(w).run();
  MESSAGE("interior particle " << interior << ": reach " << reach << " m, lifted to " << w.particles.position[interior].y());
  CHECK(w.particles.position[interior].y() == doctest::Approx(reach).epsilon(1e-12));
  for (std::size_t i = 0; i < w.particles.count(); ++i)
    if (i != interior) CHECK(w.particles.position[i] == before[i]);
}
