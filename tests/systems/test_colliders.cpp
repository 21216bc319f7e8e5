// Colliders (systems/colliders.cpp) and the surface frames they read (systems/surface_frames.cpp):
// a body meets a collider with its mesh surface (its tets' boundary triangles), placed by each
// particle's fitted deformation, not with its particle centres.
#include <doctest/doctest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

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
    // At rest is judged on positions over the last 10 ms, and the velocities (what a frame exports)
    // must say so too: before kick_end's support constraint (integration.cpp) a particle the plane
    // holds up ended each step with the half kick of its support load in its velocity, 3.3 and
    // 4.0 mm/s at the two cells, though it did not move.
    const int late = static_cast<int>(0.01 / world.dt());
    world.step(static_cast<int>(0.25 / world.dt()) - late);
    const std::vector<Vec3> before(world.positions().begin(), world.positions().end());
    world.step(late);
    const double surface = lowest_surface_y(world), centres = lowest_particle_y(world);
    double speed = 0.0, kick = 0.0;
    for (std::size_t i = 0; i < before.size(); ++i)
      speed = std::max(speed, (world.positions()[i] - before[i]).norm() / (late * world.dt()));
    for (const Vec3& v : world.velocities()) kick = std::max(kick, v.norm());
    MESSAGE("cell " << cell << " m: lowest surface vertex y " << surface << " m (" << surface / cell
                    << " cell), lowest particle centre " << centres / cell << " cell, fastest particle over the last 10 ms "
                    << speed << " m/s (largest velocity " << kick << " m/s)");
    CHECK(speed < 5e-5);  // at rest (0.5 µm in 10 ms); refitting the frames every step left 1e-4–5e-4 m/s
    CHECK(kick < 1e-3);   // measured 0.09 and 0.23 mm/s (the damped interior), against 3.3 and 4.0 before
    CHECK(std::abs(surface) < 0.01 * cell + 1e-4);        // the surface is on the plane
    CHECK(centres > 0.15 * cell);                         // the centres are not what touches it
  }
}

TEST_CASE("a body at rest in a corner of two or three colliders carries no velocity into any") {
  // The box of the test above, on a frictionless floor (plane y = 0) and pushed against a wall (plane
  // x = 0, normal +x), and for three also against a second wall (z = 0, normal +z), by gravity tilted
  // toward them, settles into the corner. The particles along its edges (and at its corner) there are
  // held by two (three) colliders in every step; kick_end's support constraint must take their velocity
  // into each of them. Keeping only the last collider that held a particle (ColliderContact before it
  // kept two) left the floor's half kick in the velocities of the edge at the wall: 3.1 mm/s; keeping
  // two left the third's at the three-collider corner. The third case is the three-collider corner
  // turned as a whole (body, gravity, colliders) by a rotation off the axes, so that the normals are
  // not exact in the float that ColliderContact keeps (the projection itself is tested below).
  for (const int variant : {1, 2, 3}) {
    const int walls = variant == 1 ? 1 : 2;
    const Mat3 turn = variant == 3 ? Mat3(Eigen::AngleAxisd(0.3, Vec3(1.0, 2.0, 0.5).normalized()).toRotationMatrix())
                                   : Mat3::Identity();
    CAPTURE(variant);
    auto sc = test::box_scene(Vec3(0.12, 0.06, 0.12), 0.02, 8e6, 4.8e6);
    sc.bodies[0].transform.translation = turn * Vec3(0.061, 0.032, walls == 2 ? 0.061 : 0.0);
    sc.bodies[0].transform.rotation = turn;
    sc.gravity = turn * Vec3(-4.0, -9.81, walls == 2 ? -4.0 : 0.0);
    sc.materials[0].damping = 60.0;
    scene::Collider floor, wall_x, wall_z;
    floor.normal = turn * Vec3::UnitY();
    wall_x.normal = turn * Vec3::UnitX();
    wall_z.normal = turn * Vec3::UnitZ();
    sc.colliders = {floor, wall_x};
    if (walls == 2) sc.colliders.push_back(wall_z);
    {
      World probe(sc);
      sc.time.dt = 0.5 * probe.stable_time_step();
    }
    World world(sc);
    world.step(static_cast<int>(0.25 / world.dt()));
    double kick = 0.0;
    Vec3 nearest = Vec3::Constant(kInfinity);  // the least centre coordinate along each axis
    for (const Vec3& v : world.velocities()) kick = std::max(kick, v.norm());
    for (const Vec3& y : world.positions()) nearest = nearest.cwiseMin(Vec3(turn.transpose() * y));
    std::size_t all = 0;  // particles held by every collider of the scene
    for (const ColliderContact& c : world.state().state.collider_contact) {
      int held = 0;
      for (int slot = 0; slot < ColliderContact::kSlots; ++slot) held += c.collider[slot] >= 0;
      all += held == walls + 1;
    }
    MESSAGE("largest velocity " << kick << " m/s; " << all << " particles held by all " << walls + 1
                                << " colliders; least centre coordinates " << nearest.transpose() << " m");
    CHECK(all > 0);  // the corner is exercised
    CHECK(nearest.y() > 0.0);
    CHECK(nearest.x() > 0.0);
    if (walls == 2) CHECK(nearest.z() > 0.0);
    CHECK(kick < 1e-3);
  }
}

TEST_CASE("support projection: the nearest velocity that moves into none of two or three colliders") {
  // kick_end's support constraint (systems/README.md §8.3) against a brute-force projection: every
  // active set of the constraints (v − s_c)·n_c ≥ 0, v projected onto its planes by the Gram system,
  // the nearest candidate that satisfies all. Random corners with the normals rounded to float, as
  // ColliderContact keeps them; sets whose normals are within 18° of parallel or opposed are left out
  // (there the answer is ill-conditioned and the routine takes the planes one after another).
  // Measured: the first three-collider version (which tested a candidate against the planes it was put
  // on, reading the float rounding as a violation) was farther than the projection in about a third of
  // the three-collider cases.
  std::mt19937_64 random(20261205);
  std::normal_distribution<double> normal(0.0, 1.0);
  const auto random_vector = [&] { return Vec3(normal(random), normal(random), normal(random)); };
  int tested[4] = {0, 0, 0, 0}, farther[4] = {0, 0, 0, 0};
  double worst_violation = 0.0;
  for (int trial = 0; trial < 20000; ++trial) {
    const int count = 2 + trial % 2;
    Vec3 n[3], surface[3];
    bool conditioned = true;
    for (int c = 0; c < count; ++c) {
      n[c] = random_vector().normalized().cast<float>().cast<double>();
      surface[c] = trial % 3 == 0 ? Vec3(Vec3::Zero()) : Vec3(0.1 * random_vector());
      for (int d = 0; d < c; ++d) conditioned = conditioned && std::abs(n[c].dot(n[d])) < 0.95;
    }
    const Vec3 v = random_vector();
    if (!conditioned) continue;
    Vec3 best = v;
    double best_distance = kInfinity;
    for (unsigned set = 0; set < (1u << count); ++set) {
      int member[3], size = 0;
      for (int c = 0; c < count; ++c)
        if (set >> c & 1u) member[size++] = c;
      Vec3 u = v;
      if (size > 0) {
        Eigen::MatrixXd gram(size, size);
        Eigen::VectorXd gap(size);
        for (int a = 0; a < size; ++a) {
          gap[a] = (v - surface[member[a]]).dot(n[member[a]]);
          for (int b = 0; b < size; ++b) gram(a, b) = n[member[a]].dot(n[member[b]]);
        }
        const Eigen::VectorXd lambda = gram.ldlt().solve(gap);
        for (int a = 0; a < size; ++a) u -= lambda[a] * n[member[a]];
      }
      bool feasible = true;
      for (int c = 0; c < count; ++c) feasible = feasible && (u - surface[c]).dot(n[c]) > -1e-9 * (1.0 + u.norm());
      if (feasible && (u - v).norm() < best_distance) best = u, best_distance = (u - v).norm();
    }
    const Vec3 got = systems::support_projection(v, n, surface, count);
    ++tested[count];
    if ((got - v).norm() > best_distance + 1e-6 * (1.0 + best_distance)) ++farther[count];
    for (int c = 0; c < count; ++c) worst_violation = std::max(worst_violation, -(got - surface[c]).dot(n[c]) / (1.0 + got.norm()));
  }
  MESSAGE(tested[2] << " two- and " << tested[3] << " three-collider cases; farther than the projection: " << farther[2]
                    << " and " << farther[3] << "; largest velocity into a collider " << worst_violation << " (relative)");
  CHECK(tested[2] > 5000);
  CHECK(tested[3] > 3000);
  CHECK(farther[2] == 0);
  CHECK(farther[3] == 0);
  CHECK(worst_violation < 1e-6);  // the float normals' rounding, |1 − |n|²| ~ 1e-7
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
  // It arrived there in this step (moving down 2 mm): the whole depth is this step's motion, which
  // is taken out at once (a depth it already had would be taken out at kDepenetrationSpeed).
  for (Vec3& v : w.particles.velocity) v = Vec3(0.0, -2.0 * sink / w.clock.dt, 0.0);
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
  SUBCASE("arriving in this step: out at once") {
    w.particles.velocity[interior] = Vec3(0.0, -reach / w.clock.dt, 0.0);  // from 1.25 reach above
    const std::vector<Vec3> before = w.particles.position;
    systems::collider_system(w).run();
    MESSAGE("interior particle " << interior << ": reach " << reach << " m, lifted to " << w.particles.position[interior].y());
    CHECK(w.particles.position[interior].y() == doctest::Approx(reach).epsilon(1e-12));
    CHECK(w.particles.velocity[interior].y() == 0.0);
    for (std::size_t i = 0; i < w.particles.count(); ++i)
      if (i != interior) CHECK(w.particles.position[i] == before[i]);
  }
  SUBCASE("already inside at the start of the step: out at 0.5 m/s") {
    // At rest 0.75 reach deep (its sphere of reach has just taken over, say): a push-out by the whole
    // depth in one step would do work against whatever holds it there (in the glass plate under the
    // ball, the fragments above it), so it is moved out at kDepenetrationSpeed = 0.5 m/s.
    w.particles.velocity[interior] = Vec3::Zero();
    systems::collider_system(w).run();
    CHECK(w.particles.position[interior].y() == doctest::Approx(0.25 * reach + 0.5 * w.clock.dt).epsilon(1e-12));
  }
}

TEST_CASE("a particle meets a collider with the crack faces of its tet once their bonds broke") {
  // An interior tet of a breakable body has no original face; when the bond to the tet across one of
  // its faces breaks, that face is fracture surface (WorldState::openable_faces), and a piece lying on
  // it must rest on it, as on an original face, not on the particle's sphere of reach. The body is
  // translated rigidly (so each frame F is the identity to float rounding) to put one interior particle
  // a quarter of its reach above the plane, with its downward face cracked; one collider pass must
  // put that face's lowest corner exactly on the plane. With the bond intact the particle is lifted to
  // its sphere of reach, as before.
  auto sc = test::box_scene(Vec3(0.06, 0.06, 0.06), 0.01, 8e6, 4.8e6);
  sc.materials[0].critical_stretch = 0.05;  // breakable, so the openable faces exist; nothing is stepped
  scene::Collider ground;
  sc.colliders.push_back(ground);
  World world(sc);
  WorldState& w = world.state_mutable();
  const OpenableFaces& of = w.openable_faces;
  REQUIRE(of.corner.size() == w.particles.count());
  REQUIRE(w.state.open_faces.size() == w.particles.count());
  std::size_t interior = w.particles.count();
  const Vec3 middle = [&] {
    Vec3 sum = Vec3::Zero();
    for (const Vec3& x : w.particles.reference_position) sum += x;
    return Vec3(sum / double(w.particles.count()));
  }();
  for (std::size_t i = 0; i < w.particles.count() && interior == w.particles.count(); ++i)
    if (w.surface.offsets[i] == w.surface.offsets[i + 1] && (w.particles.reference_position[i] - middle).norm() < 0.01)
      interior = i;
  REQUIRE(interior < w.particles.count());
  int down = 0;  // the face whose outward normal points most nearly down
  for (int k = 1; k < 4; ++k)
    if (systems::openable_face(of, interior, k).normal.normalized().y() < systems::openable_face(of, interior, down).normal.normalized().y())
      down = k;
  const std::uint16_t slot = of.bond_slot[interior][static_cast<std::size_t>(down)];
  REQUIRE(slot < OpenableFaces::kAlwaysOpen);
  const std::size_t bond = w.bonds.offsets[interior] + slot;
  const double reach = 0.5 * w.contact.distance_factor * w.contact.size[interior];
  const Vec3 shift(0.0, 0.25 * reach - w.particles.reference_position[interior].y(), 0.0);
  const auto place = [&](bool cracked) {
    w.bonds.alive[bond] = cracked ? 0 : 1;
    for (std::size_t i = 0; i < w.particles.count(); ++i) {
      w.particles.position[i] = w.particles.reference_position[i] + shift;
      w.particles.velocity[i] = Vec3(0.0, -0.01 / w.clock.dt, 0.0);  // arriving in this step, from 1 cm up
    }
    systems::update_surface_frames(w);
  };
  SUBCASE("cracked: the crack face rests on the plane") {
    place(true);
    CHECK(w.state.open_faces[interior] == (1u << down));
    const Mat3 F = w.state.surface_frame[interior].cast<double>();
    CHECK((F - Mat3::Identity()).norm() < 1e-6);
    systems::collider_system(w).run();
    double lowest = kInfinity;  // the face's lowest corner, placed as the colliders place it
    for (const Vec3& c : systems::openable_face(of, interior, down).corner)
      lowest = std::min(lowest, w.particles.position[interior].y() + (F * c).y());
    MESSAGE("interior particle " << interior << ": reach " << reach << " m, centre lifted to "
                                 << w.particles.position[interior].y() << " m, its crack face's lowest corner at " << lowest << " m");
    CHECK(std::abs(lowest) < 1e-12);
    CHECK(w.particles.position[interior].y() > 1.5 * reach);  // the face reaches deeper than the sphere
    CHECK(w.particles.velocity[interior].y() == 0.0);
  }
  SUBCASE("intact: the sphere of reach, as before") {
    place(false);
    CHECK(w.state.open_faces[interior] == 0);
    systems::collider_system(w).run();
    CHECK(w.particles.position[interior].y() == doctest::Approx(reach).epsilon(1e-12));
  }
}

TEST_CASE("a glass plate pressed into the ground by a ball does not shatter, and the ball gains no energy") {
  // The fig15 preview (a 1 × 0.1 × 1 m glass plate, two cells thick, on the ground; a 260 kg ball at
  // 5 m/s), 3 ms. The plane and the plate can only take energy from the ball: it rebounds at most at
  // 5 m/s (plus g·t). Before the colliders limited how fast a particle already inside is moved out,
  // every crack that exposed a tet at the ground pushed it out by up to half a cell in one step against
  // the fragments above it: the plate shattered (2 % of its bonds left, against 90 % in the full scene)
  // and the ball left at 6.4 m/s.
  auto sc = scene::load_scene_file(std::filesystem::path(PERIFX_SOURCE_DIR) / "assets/scenes/paper/fig15_glass_ball_press.preview.json");
  World world(sc);
  const auto steps = static_cast<int>(std::lround(3e-3 / world.dt()));
  world.step(steps);
  const ProjectileView ball = world.projectiles().at(0);
  const double alive = double(world.alive_bond_count()) / double(world.bond_count());
  MESSAGE("after 3 ms: ball velocity " << ball.velocity.y() << " m/s, " << alive << " of the bonds alive, "
                                        << world.fragment_count() << " fragments");
  CHECK(ball.velocity.y() <= 5.0 + 9.81 * 3e-3);
  CHECK(alive > 0.8);  // the full scene keeps 90 % (299,568 particles, 6 ms)
}

TEST_CASE("a ball resting on the ground plane only loses energy") {
  // A 0.1 m elastic ball (mass damping 40/s) dropped 1 mm onto a frictionless plane. Once it touches,
  // nothing but the damping and the plane acts on it, and neither may add energy. Motion is judged
  // on positions, (y(t) − y(t − dt))/dt: a particle the plane holds up ends each step with the
  // half kick of its support load in its velocity though it does not move. A push-out whose faces
  // follow the neighbours' fit every step did work the velocity never saw (found 2026-12-04: the
  // ball spun up in place, its motion 2e-4 J after 0.1 s).
  // Three meshes: the built-in mesher's ball at 8 and 12 cells across (stair-stepped where its
  // carve-and-snap holds vertices back) and the 320-facet icosphere filled by tetgen (no grid at all).
  const bool tetgen = std::system("command -v tetgen > /dev/null 2>&1") == 0;
  if (!tetgen) MESSAGE("tetgen is not installed: the icosphere ball is skipped");
  for (const double cells : {8.0, 12.0, -12.0}) {
    if (cells < 0.0 && !tetgen) continue;
    CAPTURE(cells);
    const double radius = 0.05, cell = 2.0 * radius / std::abs(cells);
    auto sc = test::box_scene(Vec3(1, 1, 1), cell, 1.0e6, 6.0e5, 1000.0);
    if (cells > 0.0) {
      sc.bodies[0].geometry.kind = scene::Geometry::Kind::sphere;
      sc.bodies[0].geometry.radius = radius;
    } else {
      sc.bodies[0].geometry.kind = scene::Geometry::Kind::surface;
      sc.bodies[0].geometry.path = std::filesystem::path(PERIFX_SOURCE_DIR) / "assets/meshes/icosphere.obj";
      sc.bodies[0].geometry.edge_length = 2.0 * cell;  // the file's radius is 0.1 m; scaled by 0.5 below
      sc.bodies[0].transform.scale = 0.5;
      // Resting on a vertex or an edge the faceted ball would tip over onto a facet, a motion gravity
      // drives; so it is turned to land on its first facet (the file's first triangle).
      std::vector<Vec3> v;
      std::array<int, 3> f{};
      std::ifstream obj(sc.bodies[0].geometry.path);
      for (std::string tag; obj >> tag;) {
        if (tag == "v") v.emplace_back(), obj >> v.back().x() >> v.back().y() >> v.back().z();
        else if (tag == "f" && f[0] == 0) obj >> f[0] >> f[1] >> f[2];
        else std::getline(obj, tag);
      }
      REQUIRE(v.size() == 162);
      const Vec3 n = (v[f[1] - 1] - v[f[0] - 1]).cross(v[f[2] - 1] - v[f[0] - 1]).normalized();
      const Mat3 turn = Eigen::Quaterniond::FromTwoVectors(n.dot(v[f[0] - 1]) > 0.0 ? n : Vec3(-n), -Vec3::UnitY())
                            .toRotationMatrix();
      sc.bodies[0].transform.rotation = turn;
      double lowest = kInfinity;
      for (const Vec3& x : v) lowest = std::min(lowest, (turn * (0.5 * x)).y());
      sc.bodies[0].transform.translation = Vec3(0.0, 0.001 - lowest, 0.0);
    }
    if (cells > 0.0) sc.bodies[0].transform.translation = Vec3(0.0, radius + 0.001, 0.0);
    sc.materials[0].damping = 40.0;
    sc.gravity = Vec3(0.0, -9.81, 0.0);
    scene::Collider ground;
    sc.colliders.push_back(ground);
    {
      World probe(sc);
      sc.time.dt = 0.5 * probe.stable_time_step();
    }
    World world(sc);
    const double mass = 1000.0 * 4.0 / 3.0 * M_PI * radius * radius * radius / double(world.particle_count());
    std::vector<Vec3> before(world.positions().begin(), world.positions().end());
    const auto motion_energy = [&] {  // Σ ½ m |Δy/dt|², with the mean particle mass
      double e = 0.0;
      for (std::size_t i = 0; i < before.size(); ++i)
        e += 0.5 * mass * ((world.positions()[i] - before[i]) / world.dt()).squaredNorm();
      before.assign(world.positions().begin(), world.positions().end());
      return e;
    };
    // The envelope: the largest energy of motion over 30 ms (more than a period of the ball's
    // bounce on the plane, about 20 ms) from 0.1 s and from 0.2 s. The mass damping c = 40/s takes an
    // oscillation's energy down by e^(−c Δt) = e^(−4) ≈ 0.018 over 0.1 s; the plane may only add loss.
    const double window = 0.03;
    double early = 0.0, late = 0.0;
    const auto steps = static_cast<int>((0.2 + window) / world.dt());
    for (int k = 0; k < steps; ++k) {
      world.step();
      const double t = (k + 1) * world.dt(), e = motion_energy();
      if (t >= 0.1 && t < 0.1 + window) early = std::max(early, e);
      if (t >= 0.2) late = std::max(late, e);
    }
    MESSAGE(world.particle_count() << " particles: largest energy of motion " << early << " J over 0.10–0.13 s, "
                                   << late << " J over 0.20–0.23 s, ratio " << late / early);
    CHECK(late < 0.05 * early);
  }
}
