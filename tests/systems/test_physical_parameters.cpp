// Physical fracture and yield parameters (systems/README.md §12): fracture_energy G_c and yield_stress
// σ_y are converted per particle for its horizon, so the same material yields at the same stress and
// breaks at the same load at any resolution. Fast tests here; the dynamic notched-bar and tension-bar
// measurements at three resolutions run with PERIFX_LONG_TESTS=1 (they print the numbers the report
// assets/report/accuracy.md quotes).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>

#include "support.hpp"

using namespace perifx;

namespace {

constexpr double kKappa = 3.3e5, kMu = 2.0e5;

bool long_tests() {
  const char* v = std::getenv("PERIFX_LONG_TESTS");
  return v && *v && std::string(v) != "0";
}

// Index of the particle closest to the origin.
std::size_t central(const World& world) {
  const auto x = world.reference_positions();
  std::size_t best = 0;
  for (std::size_t i = 1; i < x.size(); ++i)
    if (x[i].norm() < x[best].norm()) best = i;
  return best;
}

}  // namespace

TEST_CASE("fracture_energy: s_c = sqrt(G_c / (K delta)) per particle, K = 5mu + 81/80 (kappa - 5mu/3)") {
  const double g_c = 30.0;
  for (double cell : {0.02, 0.01}) {
    auto sc = test::box_scene(Vec3(0.08, 0.08, 0.08), cell, kKappa, kMu);
    sc.materials[0].fracture_energy = g_c;
    World world(sc);
    const WorldState& w = world.state();
    CHECK(w.any_fracture);
    const double k = systems::kFractureEnergyFactor * (5.0 * kMu + 81.0 / 80.0 * (kKappa - 5.0 * kMu / 3.0));
    for (std::size_t i = 0; i < world.particle_count(); i += 97) {
      const double delta = w.model.horizon[i];
      CHECK(w.model.critical_stretch[i] == doctest::Approx(std::sqrt(g_c / (k * delta))).epsilon(1e-14));
    }
    // The break extension s_c δ grows like √δ: the energy per crossing bond area stays G_c.
    const double delta = w.model.horizon[0];
    CHECK(w.model.critical_stretch[0] * delta == doctest::Approx(std::sqrt(g_c * delta / k)).epsilon(1e-14));
  }
  CHECK(std::isinf(systems::critical_stretch_from_energy(kInfinity, kKappa, kMu, 0.01)));
  // Continuum relation for the paper's constants (§12.1): the energy of the bonds crossing a unit area,
  // each at extension s_c δ, is (2π/3) b δ⁶ s_c² (pair part) + (81/80)(κ − 5μ/3) δ s_c² (dilatation);
  // perifx sets s_c so that this energy is G_c / kFractureEnergyFactor (the measured factor).
  const double delta = 0.013, s_c = 0.02;
  const double b = 15.0 * kMu / (2.0 * kPi * std::pow(delta, 5));
  const double energy = 2.0 * kPi / 3.0 * b * std::pow(delta, 6) * s_c * s_c +
                        81.0 / 80.0 * (kKappa - 5.0 * kMu / 3.0) * delta * s_c * s_c;
  CHECK(systems::critical_stretch_from_energy(systems::kFractureEnergyFactor * energy, kKappa, kMu, delta) ==
        doctest::Approx(s_c).epsilon(1e-12));
}

// Homogeneous isochoric stretch x ↦ diag(1+ε, (1+ε)^-½, (1+ε)^-½) x, increased in small increments with
// the plastic update after each: at ε = 12 ε_y every bond of a central particle has yielded except a
// thin band, and its virial flow stress σ_xx − ½(σ_yy + σ_zz) must be σ_y (S_i averages three axes,
// so a lattice family can sit a few % off along one of them). Three resolutions
// (λ, λ/1.5, λ/2) and both normalizations.
TEST_CASE("yield_stress: sustained uniaxial plastic flow carries sigma_y within 5% at three resolutions") {
  const double sigma_y = 500.0;
  const double eps_y = sigma_y / test::youngs(kKappa, kMu);  // 1e-3
  for (auto norm : {scene::Normalization::paper, scene::Normalization::discrete}) {
    for (double cell : {0.012, 0.008, 0.006}) {
      auto sc = test::box_scene(Vec3(0.072, 0.072, 0.072), cell, kKappa, kMu);
      sc.normalization = norm;
      sc.materials[0].yield_stress = sigma_y;
      sc.materials[0].plastic_cap_ratio = kInfinity;
      World world(sc);
      WorldState& w = world.state_mutable();
      REQUIRE(w.any_plastic);
      const std::size_t i0 = central(world);
      const auto x = world.reference_positions();
      std::vector<Vec3> y(x.begin(), x.end());
      std::vector<double> flow;
      const int steps = 60;
      const double eps_max = 12.0 * eps_y;
      for (int s = 1; s <= steps; ++s) {
        const double e = eps_max * s / steps, lat = 1.0 / std::sqrt(1.0 + e);
        for (std::size_t i = 0; i < y.size(); ++i) y[i] = Vec3(x[i].x() * (1 + e), x[i].y() * lat, x[i].z() * lat);
        systems::compute_dilatation(w, y, w.state.dilatation, w.state.dilatation_coupling);
        systems::update_plastic_extension(w, y);
        if (s % 10 == 0) {
          const auto ev = test::evaluate(world, y, true);
          const Mat3& st = ev.stress[i0];
          flow.push_back(st(0, 0) - 0.5 * (st(1, 1) + st(2, 2)));
        }
      }
      MESSAGE(std::string(norm == scene::Normalization::paper ? "paper" : "discrete")
              << ", cell " << cell << " m, delta " << w.model.horizon[i0] << " m: flow stress / sigma_y at eps/eps_y = "
              << "2, 4, 6, 8, 10, 12: " << flow[0] / sigma_y << ", " << flow[1] / sigma_y << ", " << flow[2] / sigma_y
              << ", " << flow[3] / sigma_y << ", " << flow[4] / sigma_y << ", " << flow[5] / sigma_y);
      CHECK(flow.back() == doctest::Approx(sigma_y).epsilon(0.05));
    }
  }
}

TEST_CASE("yield_stress and fracture_energy: infinity means elastic / unbreakable; a finite yield_stress plastic") {
  auto sc = test::box_scene(Vec3(0.04, 0.04, 0.04), 0.02, kKappa, kMu);
  sc.materials[0].yield_stress = kInfinity;
  World elastic(sc);
  CHECK(!elastic.state().any_plastic);
  CHECK(std::isinf(elastic.state().model.yield_extension[0]));
  sc.materials[0].yield_stress = 1e3;
  World plastic(sc);
  CHECK(plastic.state().any_plastic);
  CHECK(std::isfinite(plastic.state().model.yield_extension[0]));
}

namespace {

struct PullResult {
  double peak_force = 0;     // N, largest tension the grips feel
  double dissipated = 0;     // J, grip work − (kinetic + elastic energy) at the end
  double plateau_stress = 0; // Pa, mean grip force / area over the last quarter of the run
  std::size_t particles = 0, broken = 0, fragments = 0;
  double horizon = 0;
};

// A bar `length` × 0.02 × 0.02 m along x pulled by its end slabs at ±v, no damping, no contact; the
// grips' work and force are summed every step. Roller grips prescribe x only, so the bar's section
// is free to contract at its ends too (uniaxial stress through the grips).
PullResult pull(scene::Material mat, double cell, double speed, double duration, bool notch, double length = 0.06,
                bool roller = false) {
  const Vec3 size(length, 0.02, 0.02);
  auto sc = test::box_scene(size, cell, mat.bulk_modulus, mat.shear_modulus, mat.density);
  mat.name = "m";
  sc.materials[0] = mat;
  sc.bodies[0].geometry.jitter = 0.3;
  sc.contact.mode = scene::Contact::Mode::off;
  if (notch) sc.cracks.push_back({{Vec3(0, 0.005, -1), Vec3(0, 0.011, -1), Vec3(0, 0.011, 1), Vec3(0, 0.005, 1)}});
  for (int side : {-1, 1}) {
    scene::BoundaryCondition bc;
    bc.kind = scene::BoundaryCondition::Kind::velocity;
    bc.region.kind = scene::Region::Kind::halfspace;
    bc.region.point = Vec3(side * (0.5 * size.x() - 1.01 * cell), 0, 0);
    bc.region.normal = Vec3(side, 0, 0);
    bc.velocity = Vec3(side * speed, 0, 0);
    bc.window = {0.0, 0.002, kInfinity};
    if (roller) bc.axes = {true, false, false};
    sc.boundary_conditions.push_back(bc);
  }
  sc.time.dt = 1.0;  // replaced below by half the stable step
  World probe(sc);
  sc.time.dt = 0.5 * probe.stable_time_step();
  World world(sc);
  const WorldState& w = world.state();
  const auto x = world.reference_positions();
  std::vector<int> grip(x.size(), 0);
  for (std::size_t i = 0; i < x.size(); ++i)
    grip[i] = x[i].x() >= 0.5 * size.x() - 1.01 * cell ? 1 : x[i].x() <= -(0.5 * size.x() - 1.01 * cell) ? -1 : 0;
  PullResult out;
  out.particles = x.size();
  out.horizon = w.model.horizon[0];
  double work = 0, late_force = 0;
  int late = 0;
  const auto steps = static_cast<std::uint64_t>(duration / sc.time.dt);
  std::vector<Vec3> before(world.positions().begin(), world.positions().end());
  for (std::uint64_t s = 0; s < steps; ++s) {
    world.step();
    const auto y = world.positions();
    double force = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
      if (!grip[i]) continue;
      const Vec3 f = -w.state.internal_force[i];  // what the grip applies to hold the particle
      work += f.dot(y[i] - before[i]);
      if (grip[i] > 0) force += f.x();
      before[i] = y[i];
    }
    out.peak_force = std::max(out.peak_force, force);
    if (s >= 3 * steps / 4) late_force += force, ++late;
  }
  const Diagnostics d = world.diagnostics();
  out.dissipated = work - d.kinetic_energy - d.elastic_energy;
  out.plateau_stress = late_force / late / (size.y() * size.z());
  out.broken = (world.bond_count() - world.alive_bond_count()) / 2;
  out.fragments = world.fragment_count();
  return out;
}

}  // namespace

TEST_CASE("fracture_energy: notched bar at three resolutions (PERIFX_LONG_TESTS=1)" * doctest::skip(!long_tests())) {
  scene::Material mat;
  mat.bulk_modulus = 3.3e6;
  mat.shear_modulus = 2.0e6;
  mat.fracture_energy = 25.0;
  const double ligament = 0.02 * 0.015;  // the notch takes 5 mm of the 20 mm depth
  std::vector<PullResult> r;
  std::vector<double> cells_deep = {4, 6, 8};
  if (const char* e = std::getenv("PERIFX_NOTCH_CELLS")) cells_deep = {std::atof(e), 1.5 * std::atof(e), 2 * std::atof(e)};
  for (double n : cells_deep) {
    const double cell = 0.02 / n;
    r.push_back(pull(mat, cell, 0.05, 0.03, true));
    const auto& p = r.back();
    MESSAGE("cell " << cell << " m (delta " << p.horizon << " m, " << p.particles << " particles): peak force "
                    << p.peak_force << " N, dissipated " << p.dissipated << " J = " << p.dissipated / ligament
                    << " J/m2 per ligament area (G_c " << mat.fracture_energy << "), broken pairs " << p.broken
                    << ", pieces " << p.fragments);
    std::cout << "FRACTURE {\"cell\": " << cell << ", \"peak_force\": " << p.peak_force << ", \"dissipated_per_area\": "
              << p.dissipated / ligament << ", \"fragments\": " << p.fragments << "}" << std::endl;
  }
  const auto [lo, hi] = std::minmax_element(r.begin(), r.end(), [](auto& a, auto& b) { return a.peak_force < b.peak_force; });
  // Issue 12's targets: the same peak load within 10 % at the three resolutions, and G_c within 20 %
  // dissipated per unit of new crack (ligament) area.
  CHECK(hi->peak_force <= 1.10 * lo->peak_force);
  for (const auto& p : r) CHECK(p.dissipated / ligament == doctest::Approx(mat.fracture_energy).epsilon(0.20));
}

TEST_CASE("yield_stress: a bar in tension flows at sigma_y at three resolutions (PERIFX_LONG_TESTS=1)" *
          doctest::skip(!long_tests())) {
  scene::Material mat;
  mat.bulk_modulus = 3.3e6;
  mat.shear_modulus = 2.0e6;
  mat.yield_stress = 2.0e4;  // ε_y = σ_y/E = 0.4 %
  mat.plastic_cap_ratio = kInfinity;
  mat.damping = 0.0;
  for (double cell : {0.02 / 4, 0.02 / 6, 0.02 / 8}) {
    // A 6:1 bar, so the grips' lateral constraint stays near the ends; 0.02 m/s each end: strain rate
    // 0.33/s; 0.12 s reaches 4 % = 10 ε_y.
    const PullResult p = pull(mat, cell, 0.02, 0.12, false, 0.12, true);
    MESSAGE("cell " << cell << " m: grip stress over the last quarter " << p.plateau_stress << " Pa = "
                    << p.plateau_stress / mat.yield_stress << " sigma_y");
    std::cout << "YIELD {\"cell\": " << cell << ", \"plateau_over_sigma_y\": " << p.plateau_stress / mat.yield_stress
              << "}" << std::endl;
    WARN(p.plateau_stress == doctest::Approx(mat.yield_stress).epsilon(0.05));  // target; see the report
  }
}
