// Contact (systems/contact.cpp) and rigid projectiles (systems/projectiles.cpp): momentum exchange,
// non-interpenetration, resting contact on a collider, thread-count independence.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "support.hpp"

using namespace perifx;

namespace {

constexpr double kKappa = 1.0e7, kMu = 6.0e3 * 1e3, kRho = 1200.0;  // paper Fig. 4 (table1.md)

scene::Body box_body(const std::string& name, const Vec3& size, double cell, const Vec3& center,
                     const Vec3& velocity = Vec3::Zero()) {
  scene::Body b;
  b.name = name;
  b.material = 0;
  b.geometry.kind = scene::Geometry::Kind::box;
  b.geometry.size = size;
  b.geometry.edge_length = cell;
  b.transform.translation = center;
  b.velocity = velocity;
  return b;
}

// Sets dt to `fraction` of the stable step of the scene's bodies.
void stable_dt(scene::Scene& sc, double fraction) {
  World probe(sc);
  sc.time.dt = fraction * probe.stable_time_step();
}

Vec3 total_momentum(const World& w) {
  const auto& st = w.state();
  Vec3 p = w.diagnostics().linear_momentum;
  for (const auto& pr : st.projectiles.bodies) p += pr.mass * pr.velocity;
  return p;
}

double momentum_scale(const World& w) {  // Σ m|v|: what "relative" is measured against
  const auto& st = w.state();
  double s = 0.0;
  for (std::size_t i = 0; i < w.particle_count(); ++i) s += st.particles.mass[i] * w.velocities()[i].norm();
  for (const auto& pr : st.projectiles.bodies) s += pr.mass * pr.velocity.norm();
  return s;
}

double mean_size(const World& w) {
  const auto& s = w.state().contact.size;
  double sum = 0.0;
  for (double x : s) sum += x;
  return sum / double(s.size());
}

// Largest penetration beyond the contact distance over pairs of particles of different bodies:
// max(0, d_c − |y_j − y_i|), m (brute force over particles whose reference positions are within
// `band` of the other body's reference bounding box: the test scenes are small and barely slide).
double worst_penetration(const World& w, double band) {
  const auto& st = w.state();
  const auto& p = st.particles;
  const double f = st.contact.distance_factor;
  std::vector<Vec3> lo(st.bodies.size(), Vec3::Constant(kInfinity)), hi(st.bodies.size(), Vec3::Constant(-kInfinity));
  for (std::size_t i = 0; i < p.count(); ++i) {
    lo[p.body_id[i]] = lo[p.body_id[i]].cwiseMin(p.reference_position[i]);
    hi[p.body_id[i]] = hi[p.body_id[i]].cwiseMax(p.reference_position[i]);
  }
  auto near_other = [&](std::size_t i) {
    for (std::size_t b = 0; b < lo.size(); ++b)
      if (b != p.body_id[i] && ((p.reference_position[i].array() >= lo[b].array() - band).all() &&
                                (p.reference_position[i].array() <= hi[b].array() + band).all()))
        return true;
    return false;
  };
  std::vector<std::size_t> candidates;
  for (std::size_t i = 0; i < p.count(); ++i)
    if (near_other(i)) candidates.push_back(i);
  double worst = 0.0;
  for (std::size_t a = 0; a < candidates.size(); ++a)
    for (std::size_t c = a + 1; c < candidates.size(); ++c) {
      const std::size_t i = candidates[a], j = candidates[c];
      if (p.body_id[i] == p.body_id[j]) continue;
      const double dc = f * 0.5 * (st.contact.size[i] + st.contact.size[j]);
      worst = std::max(worst, dc - (p.position[j] - p.position[i]).norm());
    }
  return worst;
}

scene::Scene wall_and_sphere() {
  auto sc = test::box_scene(Vec3(0.16, 0.16, 0.02), 0.01, kKappa, kMu, kRho);
  scene::Projectile pr;
  pr.radius = 0.025;
  pr.mass = 7800.0 * 4.0 / 3.0 * kPi * pr.radius * pr.radius * pr.radius;  // steel, 0.51 kg
  pr.center = Vec3(0.0, 0.0, 0.01 + pr.radius + 0.004);
  pr.velocity = Vec3(0.0, 0.0, -30.0);
  sc.projectiles.push_back(pr);
  stable_dt(sc, 0.5);
  return sc;
}

}  // namespace

TEST_CASE("a sphere shot into a thin free wall slows down and linear momentum is conserved") {
  World world(wall_and_sphere());
  REQUIRE(world.state().projectiles.bodies.size() == 1);
  const Vec3 p0 = total_momentum(world);
  const double scale = momentum_scale(world);
  const double v0 = world.state().projectiles.bodies[0].velocity.norm();
  double worst = 0.0;
  // 3 ms: the sphere crosses the wall thickness several times over at 30 m/s.
  const auto steps = static_cast<int>(3e-3 / world.dt());
  for (int k = 0; k < steps; ++k) {
    world.step();
    worst = std::max(worst, (total_momentum(world) - p0).norm() / scale);
  }
  const auto& pr = world.state().projectiles.bodies[0];
  const double v1 = pr.velocity.norm();
  MESSAGE("sphere speed " << v0 << " -> " << v1 << " m/s after " << steps << " steps; wall momentum "
                          << world.diagnostics().linear_momentum.z() << " kg m/s; worst relative momentum error " << worst);
  CHECK(v1 < 0.9 * v0);
  CHECK(world.diagnostics().linear_momentum.z() < -0.1 * pr.mass * v0);  // the wall took momentum
  CHECK(worst < 1e-10);
}

TEST_CASE("an elastic ball dropped on the ground plane comes to rest without penetrating") {
  auto sc = test::box_scene(Vec3(1, 1, 1), 0.0125, 1.0e6, 6.0e5, 1000.0);
  sc.bodies[0].geometry.kind = scene::Geometry::Kind::sphere;
  sc.bodies[0].geometry.radius = 0.05;
  sc.bodies[0].transform.translation = Vec3(0.0, 0.051, 0.0);
  sc.materials[0].damping = 40.0;
  sc.gravity = Vec3(0.0, -9.81, 0.0);
  sc.contact.mode = scene::Contact::Mode::on;  // one body: contact must leave it alone
  scene::Collider ground;
  ground.kind = scene::Collider::Kind::plane;
  sc.colliders.push_back(ground);
  stable_dt(sc, 0.5);
  World world(sc);
  const double spacing = mean_size(world);
  double lowest = kInfinity;
  // Velocities right after kick_end carry the half kick of the contact load on particles the plane
  // just projected; rest is judged on positions instead: the largest speed of any particle over the
  // last 20 ms.
  const auto steps = static_cast<int>(0.2 / world.dt()), late = static_cast<int>(0.02 / world.dt());
  std::vector<Vec3> before;
  for (int k = 0; k < steps; ++k) {
    if (k == steps - late) before.assign(world.positions().begin(), world.positions().end());
    world.step();
    for (const Vec3& y : world.positions()) lowest = std::min(lowest, y.y());
  }
  double vmax = 0.0;
  for (std::size_t i = 0; i < world.particle_count(); ++i)
    vmax = std::max(vmax, (world.positions()[i] - before[i]).norm() / (double(late) * world.dt()));
  MESSAGE(world.particle_count() << " particles; after 0.2 s: largest mean speed over the last 20 ms " << vmax
                                 << " m/s, kinetic energy " << world.diagnostics().kinetic_energy
                                 << " J, lowest particle y " << lowest << " m (spacing " << spacing << " m)");
  CHECK(vmax < 0.01);  // it hit the ground at ≈ 0.14 m/s (1 mm drop, slowed by the mass damping)
  CHECK(lowest > -0.1 * spacing);
}

TEST_CASE("a box dropped onto a box resting on the ground never interpenetrates it") {
  auto sc = test::box_scene(Vec3(0.1, 0.05, 0.1), 0.01, kKappa, kMu, kRho);
  sc.bodies[0].transform.translation = Vec3(0.0, 0.025, 0.0);
  sc.bodies.push_back(box_body("top", Vec3(0.06, 0.04, 0.06), 0.01, Vec3(0.013, 0.053 + 0.02, -0.007),
                               Vec3(0.0, -0.5, 0.0)));
  sc.gravity = Vec3(0.0, -9.81, 0.0);
  sc.materials[0].damping = 20.0;
  sc.contact.friction = 0.3;
  scene::Collider ground;
  ground.kind = scene::Collider::Kind::plane;
  sc.colliders.push_back(ground);
  stable_dt(sc, 0.5);
  World world(sc);
  REQUIRE(world.state().contact.enabled);
  const double spacing = mean_size(world);
  double worst = 0.0;
  const auto steps = static_cast<int>(0.03 / world.dt());
  double top_v = 0.0;
  for (int k = 0; k < steps; ++k) {
    world.step();
    if (k % 4 == 0 || k == steps - 1) worst = std::max(worst, worst_penetration(world, 0.012));
  }
  const auto& st = world.state();
  for (std::size_t i = st.bodies[1].first_particle; i < world.particle_count(); ++i)
    top_v += world.velocities()[i].y() / double(st.bodies[1].particle_count);
  MESSAGE("worst penetration beyond d_c " << worst << " m = " << worst / spacing << " spacings; top box mean v_y "
                                          << top_v << " m/s after 0.03 s; " << steps << " steps");
  CHECK(top_v > -0.1);  // it was stopped (from −0.5 m/s, plus gravity)
  CHECK(worst < 0.1 * spacing);
}

TEST_CASE("two free boxes colliding conserve linear momentum") {
  auto sc = test::box_scene(Vec3(0.06, 0.06, 0.06), 0.01, kKappa, kMu, kRho);
  sc.bodies[0].transform.translation = Vec3(-0.031, 0.0, 0.0);
  sc.bodies[0].velocity = Vec3(2.0, 0.3, 0.0);
  sc.bodies.push_back(box_body("b", Vec3(0.04, 0.04, 0.04), 0.01, Vec3(0.021, 0.012, 0.005), Vec3(-3.0, 0.0, 0.5)));
  sc.contact.friction = 0.4;
  stable_dt(sc, 0.5);
  World world(sc);
  const Vec3 p0 = total_momentum(world);
  const double scale = momentum_scale(world);
  const auto& st = world.state();
  auto body_v = [&](int b) {
    Vec3 m = Vec3::Zero();
    double mass = 0.0;
    for (std::uint32_t i = st.bodies[b].first_particle; i < st.bodies[b].first_particle + st.bodies[b].particle_count; ++i) {
      m += st.particles.mass[i] * st.particles.velocity[i];
      mass += st.particles.mass[i];
    }
    return Vec3(m / mass);
  };
  const Vec3 va0 = body_v(0);
  double worst = 0.0;
  const auto steps = static_cast<int>(0.01 / world.dt());
  for (int k = 0; k < steps; ++k) {
    world.step();
    worst = std::max(worst, (total_momentum(world) - p0).norm() / scale);
  }
  const Vec3 va1 = body_v(0);
  MESSAGE("box a velocity " << va0.transpose() << " -> " << va1.transpose() << "; worst relative momentum error "
                            << worst << " over " << steps << " steps");
  CHECK(va1.x() < 0.5);  // they collided: box a lost most of its 2 m/s
  CHECK(worst < 1e-10);
}

TEST_CASE("contact and projectiles give bit-identical results on 1 and 2 threads") {
  auto run = [](int threads) {
    auto sc = wall_and_sphere();
    sc.bodies.push_back(box_body("b", Vec3(0.04, 0.04, 0.04), 0.01, Vec3(0.03, 0.0, -0.0305), Vec3(0.0, 0.0, 5.0)));
    sc.contact.friction = 0.3;
    sc.projectiles[0].friction = 0.2;
    sc.projectiles[0].angular_velocity = Vec3(0.0, 50.0, 0.0);
    sc.threads = threads;
    World world(sc);
    REQUIRE(world.state().contact.enabled);
    world.step(150);
    std::vector<Vec3> out(world.positions().begin(), world.positions().end());
    out.push_back(world.state().projectiles.bodies[0].center);
    out.push_back(world.state().projectiles.bodies[0].velocity);
    return out;
  };
  const auto a = run(1), b = run(2);
  REQUIRE(a.size() == b.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < a.size(); ++i) differ += (a[i].array() != b[i].array()).any();
  double moved = (a.back() - Vec3(0, 0, -30)).norm();
  MESSAGE(differ << " of " << a.size() << " vectors differ; projectile velocity change " << moved << " m/s");
  CHECK(moved > 0.1);  // the projectile did hit something
  CHECK(differ == 0);
}

TEST_CASE("the contact pair list holds every unbonded pair within the contact distance while bodies move and break") {
  // Two boxes collide fast enough to break bonds; the list (a Verlet list with a skin, rebuilt on
  // motion or breaks) must contain every pair a brute-force search finds closer than the largest
  // contact distance and not joined by an alive bond, whenever the contact system runs.
  auto sc = test::box_scene(Vec3(0.06, 0.06, 0.06), 0.01, kKappa, kMu, kRho);
  sc.materials[0].critical_stretch = 0.01;
  sc.bodies[0].transform.translation = Vec3(-0.031, 0.0, 0.0);
  sc.bodies[0].velocity = Vec3(6.0, 0.3, 0.0);
  sc.bodies.push_back(box_body("b", Vec3(0.04, 0.04, 0.04), 0.01, Vec3(0.021, 0.012, 0.005), Vec3(-6.0, 0.0, 0.5)));
  stable_dt(sc, 0.5);
  World world(sc);
  WorldState& w = world.state_mutable();
  REQUIRE(w.contact.enabled);
  const SystemDecl contact = systems::contact_system(w);
  const std::size_t n = w.particles.count();
  std::size_t checks = 0, missing = 0, close_pairs = 0, one_sided = 0, duplicated = 0, touching = 0, far_touching = 0,
              overfull = 0;
  const int steps = 400;
  for (int s = 0; s < steps; ++s) {
    world.step();
    if (s % 20 != 19) continue;
    contact.run();  // what the next step's contact system sees
    const auto& pr = w.contact.pairs;
    const double reach2 = w.contact.largest_distance * w.contact.largest_distance;
    for (std::uint32_t i = 0; i < n; ++i) {
      std::vector<std::uint32_t> listed(pr.neighbor.begin() + pr.offsets[i], pr.neighbor.begin() + pr.offsets[i] + pr.length[i]);
      overfull += pr.length[i] > pr.offsets[i + 1] - pr.offsets[i];  // a row beyond its room
      std::sort(listed.begin(), listed.end());
      duplicated += std::adjacent_find(listed.begin(), listed.end()) != listed.end();  // a pair twice: twice the force
      // The forces read only a row's near part: every pair within its own (uncapped) d_c must be there.
      const auto near_first = pr.neighbor.begin() + pr.offsets[i], near_last = near_first + pr.near_count[i];
      for (std::uint32_t j = 0; j < n; ++j) {
        const double dc = w.contact.distance_factor * 0.5 * (w.contact.size[i] + w.contact.size[j]);
        const double d2 = (w.particles.position[j] - w.particles.position[i]).squaredNorm();
        if (j != i && d2 < dc * dc && std::binary_search(listed.begin(), listed.end(), j)) {
          ++touching;
          far_touching += std::find(near_first, near_last, j) == near_last;
        }
        if (j == i || (w.particles.position[j] - w.particles.position[i]).squaredNorm() >= reach2) continue;
        const auto first = w.bonds.neighbor.begin() + w.bonds.offsets[i], last = w.bonds.neighbor.begin() + w.bonds.offsets[i + 1];
        const auto it = std::lower_bound(first, last, j);
        if (it != last && *it == j && w.bonds.alive[static_cast<std::size_t>(it - w.bonds.neighbor.begin())]) continue;
        ++close_pairs;
        missing += !std::binary_search(listed.begin(), listed.end(), j);
      }
      // Symmetric: j lists i whenever i lists j (each particle gathers its own force from its list).
      for (std::uint32_t j : listed) {
        const auto first = pr.neighbor.begin() + pr.offsets[j], last = first + pr.length[j];
        one_sided += std::find(first, last, i) == last;
      }
    }
    ++checks;
  }
  MESSAGE(checks << " checks, " << close_pairs << " unbonded close pairs, " << missing << " missing; "
                 << w.contact.pairs.builds << " full list builds, " << w.contact.pairs.partial_updates
                 << " moved-particle updates (" << w.contact.pairs.searched << " searches) and "
                 << w.contact.pairs.additions << " additions of broken pairs in " << steps
                 << " steps; broken bonds " << world.bond_count() - world.alive_bond_count()
                 << "; one-sided entries " << one_sided << "; lists with a pair twice " << duplicated
                 << "; listed pairs within d_c " << touching << ", in the far part " << far_touching
                 << "; rows beyond their room " << overfull << "; rows laid out anew " << w.contact.pairs.layouts
                 << " times; search grid built " << w.contact.pairs.search_grid_builds << " times, displaced grid "
                 << w.contact.pairs.displaced_grid_builds << " times");
  CHECK(world.bond_count() > world.alive_bond_count());  // bonds broke, so the list had to follow
  CHECK(close_pairs > 0);
  CHECK(missing == 0);
  CHECK(one_sided == 0);
  CHECK(duplicated == 0);
  CHECK(touching > 0);
  CHECK(far_touching == 0);
  CHECK(overfull == 0);
  CHECK(w.contact.pairs.builds > 1);           // full rebuilds (the half search) after the first
  CHECK(w.contact.pairs.partial_updates > 0);  // the moved-particle update was exercised
  CHECK(w.contact.pairs.layouts > 0);          // and so was a row outgrowing its room
  CHECK(w.contact.pairs.search_grid_builds > 0);  // and the search grid, built anew and
  CHECK(w.contact.pairs.search_grid_builds < w.contact.pairs.partial_updates);  // reused with displaced particles
  CHECK(w.contact.pairs.displaced_grid_builds > 0);  // found through their own grid
}

TEST_CASE("a projectile first touches a body where its mesh surface is, at any resolution") {
  // A 0.2 x 0.2 x 0.1 m block (top face at z = 0.05) at 2, 4 and 8 cells through its depth; a sphere of
  // radius 4 cm comes down at 10 m/s from 4.05 mm above the top face (mid-step: 40.5 steps of dt = 1e-5 s),
  // its pole over (13, 7) mm (no
  // symmetry with the grid). The sphere moves at constant speed until it touches (no gravity), so the
  // first step whose contact force is nonzero is the first n with c_z(n) − R < 0.05: n = ⌊g/(v dt)⌋ + 1.
  // The boundary-face discs (systems/projectiles.cpp) cover the top face, so that n holds at every
  // resolution. Control: the step at which the particles' spheres of reach alone would first be touched,
  // computed here from the particles, is far off at 2 cells (the test would fail without the discs).
  const double radius = 0.04, gap = 0.00405, speed = 10.0, dt = 1e-5;
  const long expected = static_cast<long>(std::floor(gap / (speed * dt))) + 1;
  // 0.06 (the fig07 preview's walls: 1 m wide, 0.1 m thick, jittered as breakable bodies are by
  // default): cells of 0.0588 × 0.0588 × 0.05 m, where spheres of reach of the top layer stick out
  // above the top face (one by 4 mm there): alone they would be touched early, so outside a face they
  // must not count.
  for (double cell : {0.05, 0.025, 0.0125, 0.06}) {
    CAPTURE(cell);
    const bool flat = cell == 0.06;
    const double side = flat ? 1.0 : 0.2, lateral_x = flat ? 0.0 : 0.013, lateral_y = flat ? 0.0 : 0.007;
    auto sc = test::box_scene(Vec3(side, side, 0.1), cell, kKappa, kMu, kRho);
    if (flat) sc.bodies[0].geometry.jitter = 0.3;  // what a breakable body gets by default
    sc.time.dt = dt;
    scene::Projectile pr;
    pr.radius = radius;
    pr.mass = 7800.0 * 4.0 / 3.0 * kPi * radius * radius * radius;
    pr.center = Vec3(lateral_x, lateral_y, 0.05 + radius + gap);
    pr.velocity = Vec3(0.0, 0.0, -speed);
    sc.projectiles.push_back(pr);
    World world(sc);
    const auto& st = world.state();
    REQUIRE(st.surface.offsets.size() == world.particle_count() + 1);  // the faces are set up for projectiles
    // The reach-only first touch, from the particles at rest.
    long reach_step = std::numeric_limits<long>::max();
    for (std::size_t i = 0; i < world.particle_count(); ++i) {
      const Vec3 x = st.particles.reference_position[i];
      const double reach = 0.5 * st.contact.distance_factor * st.contact.size[i];
      const double across2 = (x.x() - lateral_x) * (x.x() - lateral_x) + (x.y() - lateral_y) * (x.y() - lateral_y);
      const double span2 = (radius + reach) * (radius + reach) - across2;
      if (span2 <= 0.0) continue;
      const double centre_z = x.z() + std::sqrt(span2);  // the sphere's centre height at first touch
      reach_step = std::min(reach_step, static_cast<long>(std::floor((pr.center.z() - centre_z) / (speed * dt))) + 1);
    }
    long touched = -1;
    for (long n = 1; n <= 2 * expected && touched < 0; ++n) {
      world.step();
      if (st.projectiles.bodies[0].contact_force.norm() > 0.0) touched = n;
    }
    MESSAGE("cell " << cell << ": first touch at step " << touched << ", surface " << expected
                    << ", spheres of reach alone " << reach_step);
    CHECK(touched == expected);
    if (cell == 0.05) CHECK(reach_step - expected > 5);   // the spheres of reach lie inside: late
    if (cell == 0.06) CHECK(reach_step < expected);       // they stick out: early
  }
}

namespace {

// contact/time_scale `tau` (0: "auto"), the step `dt` (0: "auto"), frames every 0.1 ms.
void set_timing(scene::Scene& sc, double tau, double dt, double duration) {
  sc.contact.time_scale = tau;
  sc.time.auto_dt = dt == 0.0;
  sc.time.dt = dt;
  sc.time.duration = duration;
  sc.time.frame_rate = 1e4;
}

// The largest value of `measure(world)` after each step of the scene's duration.
template <class Measure>
double largest_over_run(const scene::Scene& sc, Measure measure) {
  World world(sc);
  double largest = -kInfinity;
  const auto steps = static_cast<long>(std::llround(sc.time.duration / world.dt()));
  for (long k = 0; k < steps; ++k) {
    world.step();
    largest = std::max(largest, measure(world));
  }
  return largest;
}

// A steel sphere dropped at 5 m/s onto the top of a slab clamped over its bottom half.
scene::Scene sphere_on_slab(double tau, double dt) {
  auto sc = test::box_scene(Vec3(0.16, 0.16, 0.04), 0.01, kKappa, kMu, kRho);
  scene::BoundaryCondition clamp;  // anchor: the bottom half held
  clamp.region.kind = scene::Region::Kind::halfspace;
  clamp.region.point = Vec3::Zero();
  clamp.region.normal = Vec3(0, 0, -1);
  sc.boundary_conditions.push_back(clamp);
  scene::Projectile pr;
  pr.radius = 0.025;
  pr.mass = 7800.0 * 4.0 / 3.0 * kPi * pr.radius * pr.radius * pr.radius;
  pr.center = Vec3(0.0, 0.0, 0.02 + pr.radius + 0.001);
  pr.velocity = Vec3(0.0, 0.0, -5.0);
  sc.projectiles.push_back(pr);
  set_timing(sc, tau, dt, 2e-3);
  return sc;
}

// The sphere's deepest reach below the slab's top face (m): the slab's give plus the spring's overlap.
double deepest_reach(const scene::Scene& sc) {
  const double top = 0.02, radius = sc.projectiles[0].radius;
  return largest_over_run(sc, [&](const World& w) { return top - (w.state().projectiles.bodies[0].center.z() - radius); });
}

// Two boxes meeting face to face at 2 m/s each.
scene::Scene boxes_meeting(double tau, double dt) {
  auto sc = test::box_scene(Vec3(0.08, 0.08, 0.04), 0.01, kKappa, kMu, kRho);
  sc.bodies.clear();
  sc.bodies.push_back(box_body("below", Vec3(0.08, 0.08, 0.04), 0.01, Vec3(0, 0, -0.0205), Vec3(0, 0, 2.0)));
  sc.bodies.push_back(box_body("above", Vec3(0.08, 0.08, 0.04), 0.01, Vec3(0, 0, 0.0205), Vec3(0, 0, -2.0)));
  set_timing(sc, tau, dt, 1e-3);
  return sc;
}

// The deepest overlap of a pair of their particles within the contact distance over the run (m).
double deepest_overlap(const scene::Scene& sc) {
  return largest_over_run(sc, [](const World& w) { return worst_penetration(w, 0.012); });
}

}  // namespace

TEST_CASE("the contact time scale is the automatic step before it is fitted to the frames, for any step") {
  const auto given = sphere_on_slab(0.0, 1e-6), automatic = sphere_on_slab(0.0, 0.0);
  World a(given), b(automatic);
  const double lambda = a.state().bodies[0].mean_edge_length, radius = given.projectiles[0].radius;
  const double expected = std::min(0.8 * a.stable_time_step(), 0.25 * std::min(lambda, radius) / 5.0);
  MESSAGE("stable limit " << a.stable_time_step() << " s, motion rule " << 0.25 * std::min(lambda, radius) / 5.0
                          << " s, contact time scale " << a.contact_time_scale() << " s, automatic step " << b.dt() << " s");
  CHECK(a.contact_time_scale() == doctest::Approx(expected).epsilon(1e-12));
  CHECK(b.contact_time_scale() == a.contact_time_scale());  // the same bits: the scene's, not the step's
  CHECK(b.dt() <= b.contact_time_scale());                  // "auto" steps within it
  World c(sphere_on_slab(3e-6, 1e-6));                      // given: taken as is, no estimate needed
  CHECK(c.contact_time_scale() == 3e-6);
  auto single = test::box_scene(Vec3(0.08, 0.08, 0.04), 0.01, kKappa, kMu, kRho);  // nothing touches
  CHECK(World(single).contact_time_scale() == 0.0);
}

TEST_CASE("an impact does not depend on the step below the contact time scale") {
  // Shortening the step from τ/2 to about τ/4 (frames must fall on steps) leaves the sphere's reach
  // into the clamped slab and the deepest particle overlap of two boxes meeting at 4 m/s within 3 %
  // (what remains is the step's own error). With the spring tied to the step (a given time scale
  // below dt: k = factor·m/dt²), the same change stiffens it threefold: the overlap shrinks by about
  // 1/√3, and the sphere's reach, which the slab's own give dilutes, by over 5 %.
  const double tau = World(sphere_on_slab(0.0, 1e-6)).contact_time_scale();
  REQUIRE(tau > 0.0);
  auto on_grid = [](double dt) { return 1e-4 / std::ceil(1e-4 / dt); };  // frames of 0.1 ms fall on steps
  const double half = on_grid(tau / 2), quarter = on_grid(tau / 4);
  const double reach_half = deepest_reach(sphere_on_slab(0.0, half));
  const double reach_quarter = deepest_reach(sphere_on_slab(0.0, quarter));
  const double tied_half = deepest_reach(sphere_on_slab(1e-12, half));
  const double tied_quarter = deepest_reach(sphere_on_slab(1e-12, quarter));
  MESSAGE("sphere reach below the top face at dt " << half << " / " << quarter << " s: " << reach_half << " / "
                                                    << reach_quarter << " m; tied to the step: " << tied_half << " / "
                                                    << tied_quarter << " m");
  CHECK(std::abs(reach_quarter / reach_half - 1.0) < 0.03);
  CHECK(tied_quarter / tied_half < 0.95);

  const double tau2 = World(boxes_meeting(0.0, 1e-6)).contact_time_scale();
  const double h2 = on_grid(tau2 / 2), q2 = on_grid(tau2 / 4);
  const double overlap_half = deepest_overlap(boxes_meeting(0.0, h2)), overlap_quarter = deepest_overlap(boxes_meeting(0.0, q2));
  const double tied_overlap_half = deepest_overlap(boxes_meeting(1e-12, h2));
  const double tied_overlap_quarter = deepest_overlap(boxes_meeting(1e-12, q2));
  MESSAGE("boxes' deepest particle overlap at dt " << h2 << " / " << q2 << " s: " << overlap_half << " / "
                                                   << overlap_quarter << " m; tied to the step: " << tied_overlap_half
                                                   << " / " << tied_overlap_quarter << " m");
  CHECK(std::abs(overlap_quarter / overlap_half - 1.0) < 0.03);
  CHECK(tied_overlap_quarter / tied_overlap_half < 0.8);
}
