// External loads (systems/external_loads.cpp, systems/README.md §8.6) against numbers the physics
// dictates: a bar pulled by end tractions reaches the static stress T and strain T/E (within the
// model's own accuracy on that bar); a blast's impulse is the integral of its pressure over the exposed
// area and time; a time window and ramp are followed exactly; the momentum gained is the impulse
// applied, to round-off; and every load is bit-identical for any thread count.
#include <doctest/doctest.h>

#include <cstring>

#include "support.hpp"

using namespace perifx;

namespace {

scene::Load traction_on_end(double x_face, double sign, double stress) {
  scene::Load l;
  l.kind = scene::Load::Kind::traction;
  l.region.kind = scene::Region::Kind::halfspace;
  l.region.point = Vec3(x_face - sign * 1e-9, 0, 0);
  l.region.normal = Vec3(sign, 0, 0);
  l.magnitude = stress;  // along the outward normal: pulls
  return l;
}

Vec3 total_external_force(const World& w) {
  Vec3 f = Vec3::Zero();
  for (const Vec3& v : w.state().state.external_force) f += v;
  return f;
}

Vec3 momentum(const World& w) {
  Vec3 p = Vec3::Zero();
  const auto& s = w.state().particles;
  for (std::size_t i = 0; i < s.count(); ++i) p += s.mass[i] * s.velocity[i];
  return p;
}

// Steps `steps` times and returns the impulse velocity Verlet applied from the external forces:
// dt/2 F_0 + dt (F_1 + … + F_{N−1}) + dt/2 F_N (each F_k is what the kicks used).
Vec3 run_and_sum_impulse(World& w, std::uint64_t steps, std::vector<Vec3>* forces = nullptr) {
  const double dt = w.dt();
  Vec3 impulse = 0.5 * dt * total_external_force(w);
  if (forces) forces->push_back(total_external_force(w));
  for (std::uint64_t k = 1; k <= steps; ++k) {
    w.step();
    const Vec3 f = total_external_force(w);
    if (forces) forces->push_back(f);
    impulse += (k == steps ? 0.5 : 1.0) * dt * f;
  }
  return impulse;
}

// ∫_0^t of the trapezoidal window (0 before start, ramp, 1 until end, 0 after), closed form.
double window_integral(const scene::TimeWindow& win, double t) {
  const auto upto = [&](double s) {
    if (s <= win.start) return 0.0;
    const double u = s - win.start;
    if (u <= win.ramp) return 0.5 * u * u / win.ramp;
    return 0.5 * win.ramp + (u - win.ramp);
  };
  return upto(std::min(t, win.end));
}

}  // namespace

namespace {

// Interior strain (least-squares slope of u_x against x over |x| < 0.05) and mean virial σ_xx there.
std::pair<double, double> bar_interior(const World& w) {
  const auto x = w.reference_positions();
  const auto y = w.positions();
  const auto now = test::evaluate(w, std::vector<Vec3>(y.begin(), y.end()), true);
  double sx = 0, su = 0, sxx = 0, sxu = 0, sigma = 0, n = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (std::abs(x[i].x()) >= 0.05) continue;
    const double u = y[i].x() - x[i].x();
    sx += x[i].x(), su += u, sxx += x[i].x() * x[i].x(), sxu += x[i].x() * u;
    sigma += now.stress[i](0, 0), n += 1;
  }
  return {(n * sxu - sx * su) / (n * sxx - sx * sx), sigma / n};
}

}  // namespace

TEST_CASE("loads: a bar pulled by end tractions reaches the static stress T and strain T/E") {
  // Free bar along x, traction T on both end faces along their outward normals (self-equilibrated),
  // ramped up over 20 ms and damped to rest.
  const Vec3 size(0.2, 0.04, 0.04);
  const double E = 1e6, nu = 0.25, T = 1e3;
  auto sc = test::box_scene(size, 0.01, perifx::bulk_modulus(E, nu), perifx::shear_modulus(E, nu));
  sc.materials[0].damping = 800.0;
  World probe(sc);
  sc.time.dt = 0.8 * probe.stable_time_step();
  auto pulled = sc;
  auto left = traction_on_end(-0.1, -1, T), right = traction_on_end(0.1, 1, T);
  left.window.ramp = right.window.ramp = 0.02;
  pulled.loads = {left, right};
  World w(pulled);

  // The end faces' patches: their areas add up to the face, 0.04², and point along ±x.
  const auto& ws = w.state();
  for (std::size_t l = 0; l < 2; ++l) {
    Vec3 sum = Vec3::Zero();
    for (std::uint32_t q : ws.loads.patches[l]) sum += ws.surface.area[q] * ws.surface.normal[q];
    CHECK(sum.x() == doctest::Approx(l == 0 ? -0.0016 : 0.0016).epsilon(1e-12));
    CHECK(std::abs(sum.y()) + std::abs(sum.z()) < 1e-15);
  }
  const auto steps = static_cast<std::uint64_t>(0.1 / w.dt());
  w.step(steps * 4 / 5);
  const double strain_before = bar_interior(w).first;
  w.step(steps - steps * 4 / 5);
  const auto [strain, sigma] = bar_interior(w);

  // What the default model reaches on this bar by other means: the same bar stretched by prescribed
  // end displacements (boundary conditions on the last cell at each end) to about the same strain.
  auto held = sc;
  for (double sign : {-1.0, 1.0}) {
    scene::BoundaryCondition bc;
    bc.kind = scene::BoundaryCondition::Kind::displacement;
    bc.region.kind = scene::Region::Kind::halfspace;
    bc.region.point = Vec3(sign * 0.09, 0, 0);
    bc.region.normal = Vec3(sign, 0, 0);
    bc.displacement = Vec3(sign * 0.1 * T / E * 1.3, 0, 0);
    bc.window.ramp = 0.02;
    held.boundary_conditions.push_back(bc);
  }
  World d(held);
  d.step(steps);
  const auto [strain_d, sigma_d] = bar_interior(d);
  const double E_model = sigma_d / strain_d;

  MESSAGE("bar under end traction T = " << T << " Pa: interior strain " << strain << " (T/E = " << T / E << ", "
          << 100 * (strain * E / T - 1) << "%), mean interior virial stress " << sigma << " Pa ("
          << 100 * (sigma / T - 1) << "%). Same bar stretched by prescribed displacements: E_model = "
          << E_model << " Pa (" << 100 * (E_model / E - 1) << "% from E); T/E_model = " << T / E_model
          << " (traction strain " << 100 * (strain * E_model / T - 1) << "% from it)");
  CHECK(std::abs(strain / strain_before - 1.0) < 1e-3);  // static: the strain no longer changes
  CHECK(std::abs(sigma / T - 1.0) < 0.01);                // the stress is T
  CHECK(std::abs(strain * E_model / T - 1.0) < 0.02);     // the strain is T/E of the model on this bar
  CHECK(std::abs(strain * E / T - 1.0) <= std::abs(E / E_model - 1.0) + 0.02);  // so as close to T/E as it gets
}

TEST_CASE("loads: a blast's impulse is the integral of its pressure over the exposed area and time") {
  // A plate facing +z, blasted from a point on its axis. p = P (R/r)² (1 − s/τ): the impulse per area
  // is P τ/2 (R/r)², the total ∫∫ over the front face (the only face turned towards the point).
  const Vec3 size(0.4, 0.4, 0.05);
  auto sc = test::box_scene(size, 0.025, 1e7, 6e6);
  const double h = 0.3, R = 0.1, P = 1000.0, tau = 2e-3;
  scene::Load blast;
  blast.kind = scene::Load::Kind::blast;
  blast.center = Vec3(0, 0, 0.025 + h);
  blast.radius = R;
  blast.magnitude = P;
  blast.duration = tau;
  blast.window.start = 3e-4;
  // Reference: midpoint rule on a 2000² grid over the face, independent of the mesh.
  const int m = 2000;
  double integral = 0.0;
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) {
      const double px = -0.2 + (a + 0.5) * 0.4 / m, py = -0.2 + (b + 0.5) * 0.4 / m;
      integral += R * R / (h * h + px * px + py * py);
    }
  integral *= (0.4 / m) * (0.4 / m);

  SUBCASE("blast, instantaneous front") {}
  SUBCASE("blast, front at 600 m/s") { blast.front_speed = 600.0; }
  SUBCASE("radial impulse over one instant") {
    blast.kind = scene::Load::Kind::radial_impulse;
    blast.magnitude = P * tau / 2;  // the same impulse per area
    blast.duration = 0.0;
  }
  sc.loads = {blast};
  World probe(sc);
  sc.time.dt = 0.7 * probe.stable_time_step();
  World w(sc);
  const Vec3 p0 = momentum(w);
  const Vec3 applied = run_and_sum_impulse(w, static_cast<std::uint64_t>((blast.window.start + tau + 1.5e-3) / w.dt()));
  const Vec3 gained = momentum(w) - p0;
  const double expected = P * tau / 2 * integral;
  MESSAGE("impulse: applied " << -applied.z() << " N·s, expected ∫∫∫ p dA dt = " << expected << " N·s ("
          << 100 * (-applied.z() / expected - 1) << "%); momentum gained " << -gained.z());
  CHECK(std::abs(-applied.z() / expected - 1.0) < 0.01);
  CHECK(std::abs(applied.x()) + std::abs(applied.y()) < 1e-6 * expected);
  CHECK((gained - applied).norm() < 1e-11 * expected);
}

TEST_CASE("loads: a time window and ramp are followed exactly") {
  // A uniform acceleration moves the body rigidly, so every step's total external force is
  // M a × (the window's mean over that step's interval), and the whole impulse M a ∫ r dt.
  auto sc = test::box_scene(Vec3(0.1, 0.1, 0.1), 0.05, 2e4, 1.2e4);
  sc.time.dt = 1e-3;
  scene::Load push;
  push.kind = scene::Load::Kind::body_force;
  push.vector = Vec3(0, 2.0, 0);
  push.window = {0.0123, 0.0071, 0.031};
  sc.loads = {push};
  World w(sc);
  REQUIRE(w.dt() < w.stable_time_step());
  double mass = 0.0;
  for (double mi : w.state().particles.mass) mass += mi;
  std::vector<Vec3> forces;
  const Vec3 p0 = momentum(w);
  const Vec3 applied = run_and_sum_impulse(w, 40, &forces);
  const double dt = w.dt();
  for (std::size_t k = 0; k < forces.size(); ++k) {
    CAPTURE(k);
    const double t = double(k) * dt, a = std::max(0.0, t - 0.5 * dt), b = t + 0.5 * dt;
    const double mean = (window_integral(push.window, b) - window_integral(push.window, a)) / (b - a);
    CHECK(forces[k].y() == doctest::Approx(mass * 2.0 * mean).epsilon(1e-12).scale(mass * 2.0));
    CHECK(forces[k].x() == 0.0);
    // Inside the ramp, away from its ends, the force is the ramp's value at t itself.
    if (a > push.window.start && b < push.window.start + push.window.ramp)
      CHECK(forces[k].y() == doctest::Approx(mass * 2.0 * (t - push.window.start) / push.window.ramp).epsilon(1e-12));
    if (b <= push.window.start || a >= push.window.end) CHECK(forces[k].y() == 0.0);
  }
  const double exact = mass * 2.0 * (push.window.end - push.window.start - 0.5 * push.window.ramp);
  MESSAGE("window impulse " << applied.y() << " N·s, exact M a (end − start − ramp/2) = " << exact);
  CHECK(applied.y() == doctest::Approx(exact).epsilon(1e-13));
  CHECK((momentum(w) - p0 - applied).norm() < 1e-13 * exact);
}

namespace {

// One small body under every kind of load at once (gravity too), optionally breakable.
scene::Scene all_loads_scene(int threads, bool breakable) {
  auto sc = test::box_scene(Vec3(0.2, 0.1, 0.08), 0.02, 2e6, 1.2e6);
  sc.threads = threads;
  sc.gravity = Vec3(0, -9.81, 0);
  sc.time.dt = 2e-5;
  if (breakable) sc.materials[0].critical_stretch = 0.01;
  using K = scene::Load::Kind;
  scene::Load traction;
  traction.kind = K::traction;
  traction.region.kind = scene::Region::Kind::halfspace;
  traction.region.point = Vec3(0.0999, 0, 0);
  traction.region.normal = Vec3(1, 0, 0);
  traction.magnitude = 3e4;
  traction.along_normal = false;
  traction.direction = Vec3(0.6, 0.8, 0);
  traction.window = {0.0, 4e-4, 2e-3};
  scene::Load body;
  body.kind = K::body_force;
  body.vector = Vec3(500, 0, 0);
  body.per_volume = true;
  body.region.kind = scene::Region::Kind::sphere;
  body.region.center = Vec3(-0.05, 0, 0);
  body.region.radius = 0.05;
  scene::Load blast;
  blast.kind = K::blast;
  blast.center = Vec3(0, 0.2, 0.1);
  blast.radius = 0.05;
  blast.magnitude = 2e5;
  blast.duration = 3e-4;
  blast.front_speed = 500;
  blast.window.start = 1e-4;
  scene::Load kick = blast;
  kick.kind = K::radial_impulse;
  kick.center = Vec3(-0.3, 0, 0);
  kick.magnitude = 20.0;
  kick.duration = 0.0;
  kick.window.start = 5.01e-4;
  scene::Load wind;
  wind.kind = K::directional;
  wind.vector = Vec3(-10, 0, 3);
  wind.drag = 50;
  wind.quadratic_drag = 0.6;
  wind.window = {2e-4, 3e-4, 1.0};
  scene::Load noise;
  noise.kind = K::noise;
  noise.magnitude = 300;
  noise.feature_size = 0.05;
  noise.speed = 20;
  noise.direction = Vec3(0, 0, 1);
  noise.seed = 7;
  sc.loads = {traction, body, blast, kick, wind, noise};
  return sc;
}

}  // namespace

TEST_CASE("loads: the linear momentum gained equals the impulse applied, to round-off") {
  auto sc = all_loads_scene(2, false);
  sc.gravity = Vec3::Zero();  // gravity is an external force too, but keep the sum to the loads
  World w(sc);
  const Vec3 p0 = momentum(w);
  const Vec3 applied = run_and_sum_impulse(w, 60);
  const Vec3 gained = momentum(w) - p0;
  MESSAGE("applied impulse " << applied.transpose() << " N·s, momentum gained " << gained.transpose()
          << ", difference " << (gained - applied).norm());
  CHECK(applied.norm() > 0.0);
  CHECK((gained - applied).norm() < 1e-12 * applied.norm());
}

TEST_CASE("loads: bit-identical for any thread count") {
  std::vector<std::vector<Vec3>> positions, forces;
  std::vector<std::size_t> alive;
  for (int threads : {1, 2, 3}) {
    World w(all_loads_scene(threads, true));
    REQUIRE(w.threads() == threads);
    w.step(60);
    positions.emplace_back(w.positions().begin(), w.positions().end());
    forces.push_back(w.state().state.external_force);
    alive.push_back(w.alive_bond_count());
  }
  MESSAGE("bonds alive after 60 steps: " << alive[0] << " of " << World(all_loads_scene(1, true)).bond_count());
  for (std::size_t k = 1; k < positions.size(); ++k) {
    CHECK(alive[k] == alive[0]);
    CHECK(std::memcmp(positions[k].data(), positions[0].data(), positions[0].size() * sizeof(Vec3)) == 0);
    CHECK(std::memcmp(forces[k].data(), forces[0].data(), forces[0].size() * sizeof(Vec3)) == 0);
  }
}

TEST_CASE("loads: noise is bounded and seeded, and wind pushes only the faces it meets") {
  // Noise: the external force of a noise load on a body at rest, sampled at two seeds.
  auto sc = test::box_scene(Vec3(0.2, 0.2, 0.2), 0.02, 1e6, 6e5);
  scene::Load noise;
  noise.kind = scene::Load::Kind::noise;
  noise.magnitude = 3.0;
  noise.feature_size = 0.1;
  sc.loads = {noise};
  sc.time.dt = 1e-5;
  World a(sc);
  sc.loads[0].seed = 1;
  World b(sc);
  const auto& s = a.state();
  double largest = 0.0, differ = 0.0;
  for (std::size_t i = 0; i < s.particles.count(); ++i) {
    // At t = 0 the window's mean over [0, dt/2] is 1: the force is m·A·N(x).
    const Vec3 acc = s.state.external_force[i] / s.particles.mass[i];
    largest = std::max(largest, acc.cwiseAbs().maxCoeff());
    differ = std::max(differ, (acc - b.state().state.external_force[i] / s.particles.mass[i]).norm());
  }
  CHECK(largest <= 3.0);
  CHECK(largest > 0.9);  // the field reaches a good part of its amplitude
  CHECK(differ > 0.5);
  // Wind against a plate at rest: only the face turned towards it is pushed, by drag·area·|u|.
  auto plate = test::box_scene(Vec3(0.1, 0.1, 0.02), 0.02, 1e6, 6e5);
  scene::Load wind;
  wind.kind = scene::Load::Kind::directional;
  wind.vector = Vec3(0, 0, -5);  // blowing towards −z: meets the +z face
  wind.drag = 2.0;
  plate.loads = {wind};
  World p(plate);
  // With loads the system reads the moving state, so it runs after the drift (gravity alone reads nothing).
  CHECK(p.schedule().find("external_loads  reads time,position,velocity  writes external_force") != std::string::npos);
  const Vec3 f = total_external_force(p);
  CHECK(f.z() == doctest::Approx(-2.0 * 0.01 * 5.0).epsilon(1e-12));
  CHECK(std::abs(f.x()) + std::abs(f.y()) < 1e-15);
}

TEST_CASE("loads: a traction with a depth keeps its total force and moves it below the face") {
  auto sc = test::box_scene(Vec3(0.2, 0.04, 0.04), 0.01, 1e6, 6e5);
  auto pull = traction_on_end(0.1, 1, 1e3);
  sc.loads = {pull};
  World shallow(sc);
  sc.loads[0].depth = 0.02;
  World deep(sc);
  const Vec3 f0 = total_external_force(shallow), f1 = total_external_force(deep);
  CHECK(f0.x() == doctest::Approx(1e3 * 0.0016).epsilon(1e-12));
  CHECK((f1 - f0).norm() < 1e-12 * f0.norm());
  double deepest_0 = 1.0, deepest_1 = 1.0;
  std::size_t loaded_0 = 0, loaded_1 = 0;
  for (std::size_t i = 0; i < shallow.particle_count(); ++i) {
    const double x = shallow.reference_positions()[i].x();
    if (shallow.state().state.external_force[i].norm() > 0) deepest_0 = std::min(deepest_0, x), ++loaded_0;
    if (deep.state().state.external_force[i].norm() > 0) deepest_1 = std::min(deepest_1, x), ++loaded_1;
  }
  MESSAGE("particles carrying the traction: " << loaded_0 << " (faces only), " << loaded_1 << " (2 cm layer)");
  CHECK(deepest_0 > 0.1 - 0.01);
  CHECK(deepest_1 < 0.1 - 0.015);
  CHECK(deepest_1 > 0.1 - 0.021);
  CHECK(loaded_1 > 2 * loaded_0);
}

TEST_CASE("loads: in FEM mode a traction's faces are shared by their vertices and keep the total force") {
  auto sc = test::box_scene(Vec3(0.2, 0.04, 0.04), 0.01, 1e6, 6e5);
  sc.solver = scene::Solver::fem_linear;
  sc.loads = {traction_on_end(0.1, 1, 1e3)};
  World w(sc);
  const Vec3 f = total_external_force(w);
  CHECK(f.x() == doctest::Approx(1e3 * 0.0016).epsilon(1e-12));
  CHECK(std::abs(f.y()) + std::abs(f.z()) < 1e-15);
  for (std::size_t i = 0; i < w.particle_count(); ++i)  // only vertices on the end face carry it
    if (w.state().state.external_force[i].norm() > 0) CHECK(w.reference_positions()[i].x() == doctest::Approx(0.1));
}
