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
#include "systems/yield_law.hpp"

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
  const double eps_y = sigma_y / perifx::youngs_modulus(kKappa, kMu);  // 1e-3
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

TEST_CASE("offset_yield_stress: set-up converts it to the flow stress with that 0.2 % offset yield, and yields from it") {
  // A material given its 0.2 % offset yield stress builds the same model, to the bit, as the same
  // material given the flow stress that yield_law.hpp derives, and that flow stress's offset yield (by
  // the law) is the stress given.
  const double offset = 800.0;  // σ/E = 0.16 %: the law's offset ratio is about 0.97 here
  auto sc = test::box_scene(Vec3(0.06, 0.06, 0.06), 0.01, kKappa, kMu);
  sc.materials[0].offset_yield_stress = offset;
  sc.materials[0].plastic_cap_ratio = kInfinity;
  World from_offset(sc);
  const double flow = from_offset.state().settings.materials[0].yield_stress;
  CHECK(from_offset.state().any_plastic);
  CHECK(flow == systems::flow_stress_for_offset_yield(kKappa, kMu, offset));
  CHECK(flow * systems::offset_yield_ratio(kKappa, kMu, flow) == doctest::Approx(offset).epsilon(1e-8));
  CHECK(flow > offset);
  sc.materials[0].offset_yield_stress = 0.0;
  sc.materials[0].yield_stress = flow;
  World from_flow(sc);
  CHECK(from_offset.state().model.yield_extension == from_flow.state().model.yield_extension);
  // Given both (only possible from C++), the flow stress wins, as documented in scene.hpp.
  sc.materials[0].offset_yield_stress = offset;
  World both(sc);
  CHECK(both.state().settings.materials[0].yield_stress == flow);
}

namespace {

struct PullResult {
  double peak_force = 0;     // N, largest tension the grips feel
  double dissipated = 0;     // J, grip work − (kinetic + elastic energy) at the end
  double plateau_stress = 0; // Pa, mean grip force / area over the last quarter of the run
  std::size_t particles = 0, broken = 0, fragments = 0;
  double horizon = 0;
  double free_length = 0;   // m, between the grip slabs' inner faces (the strain's gauge length)
  std::vector<double> time, strain, stress;  // per step: s, grip-to-grip engineering strain, grip force / area (Pa)
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
  // The grips are rigid slabs: the free length between their inner faces, and its change from the mean
  // x of each slab, give the bar's engineering strain.
  out.free_length = size.x() - 2.0 * 1.01 * cell;
  double grip_count[2] = {0, 0}, grip_x0[2] = {0, 0};
  for (std::size_t i = 0; i < x.size(); ++i)
    if (grip[i]) grip_count[grip[i] > 0] += 1, grip_x0[grip[i] > 0] += x[i].x();
  for (std::uint64_t s = 0; s < steps; ++s) {
    world.step();
    const auto y = world.positions();
    double force = 0, grip_x[2] = {0, 0};
    for (std::size_t i = 0; i < x.size(); ++i) {
      if (!grip[i]) continue;
      const Vec3 f = -w.state.internal_force[i];  // what the grip applies to hold the particle
      work += f.dot(y[i] - before[i]);
      if (grip[i] > 0) force += f.x();
      grip_x[grip[i] > 0] += y[i].x();
      before[i] = y[i];
    }
    out.peak_force = std::max(out.peak_force, force);
    if (s >= 3 * steps / 4) late_force += force, ++late;
    const double stretch = (grip_x[1] - grip_x0[1]) / grip_count[1] - (grip_x[0] - grip_x0[0]) / grip_count[0];
    out.time.push_back(double(s + 1) * sc.time.dt);
    out.strain.push_back(stretch / out.free_length);
    out.stress.push_back(force / (size.y() * size.z()));
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

namespace {

// The gripped bar of the two tests below, pulled to 4 % strain: its 0.2 % offset yield (ASTM E8) and
// its flow stress at multiples of ε_y = flow_stress / E, as stresses (Pa).
struct YieldBar {
  double cell = 0, modulus = 0, offset_yield = 0, offset_strain = 0, plateau = 0;
  double flow_2_5 = 0, flow_5 = 0, flow_10 = 0;  // smoothed stress at 2.5, 5 and 10 ε_y
};

YieldBar pull_yield_bar(const scene::Material& mat, double cells, double flow_stress) {
  const double cell = 0.02 / cells;
  // A 6:1 bar, so the grips' lateral constraint stays near the ends; 0.02 m/s each end: strain rate
  // 0.33/s; 0.12 s reaches 4 % = 10 ε_y at ε_y = 0.4 %.
  const PullResult p = pull(mat, cell, 0.02, 0.12, false, 0.12, true);
  // Stress smoothed over one period of the bar's axial ringing between the grips (no damping):
  // T = 2 L / c with the bar wave speed c = √(E/ρ), 3.4 ms here. A moving mean over exactly T removes
  // that mode; a shorter one leaves it in the elastic fit and the offset crossing.
  const std::size_t n = p.stress.size();
  const double dt = p.time[0];
  const double youngs = perifx::youngs_modulus(mat.bulk_modulus, mat.shear_modulus);
  const double period = 2.0 * p.free_length / std::sqrt(youngs / mat.density);
  const auto half = static_cast<std::size_t>(0.5 * period / dt);
  std::vector<double> smooth(n, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t lo = k > half ? k - half : 0, hi = std::min(n - 1, k + half);
    for (std::size_t q = lo; q <= hi; ++q) smooth[k] += p.stress[q];
    smooth[k] /= double(hi - lo + 1);
  }
  // Yield stress by the 0.2 % offset rule (the engineering definition, e.g. ASTM E8): the elastic line
  // σ = E ε + b is fitted (least squares) where 0.1 σ_y ≤ σ ≤ 0.5 σ_y; the yield stress is the curve's
  // value where it first falls below that line shifted by 0.002 in strain.
  double se = 0, ss = 0, see = 0, ses = 0, count = 0;
  for (std::size_t k = 0; k < n; ++k)
    if (smooth[k] >= 0.1 * flow_stress && smooth[k] <= 0.5 * flow_stress && p.strain[k] > 0)
      se += p.strain[k], ss += smooth[k], see += p.strain[k] * p.strain[k], ses += p.strain[k] * smooth[k], count += 1;
  REQUIRE(count > 10);
  YieldBar out;
  out.cell = cell;
  out.modulus = (count * ses - se * ss) / (count * see - se * se);
  const double intercept = (ss - out.modulus * se) / count;
  for (std::size_t k = 1; k < n; ++k) {
    const double gap = smooth[k] - (out.modulus * (p.strain[k] - 0.002) + intercept);
    if (gap <= 0) {
      const double gap0 = smooth[k - 1] - (out.modulus * (p.strain[k - 1] - 0.002) + intercept), f = gap0 / (gap0 - gap);
      out.offset_yield = smooth[k - 1] + f * (smooth[k] - smooth[k - 1]);
      out.offset_strain = p.strain[k - 1] + f * (p.strain[k] - p.strain[k - 1]);
      break;
    }
  }
  const double eps_y = flow_stress / youngs;
  auto stress_at = [&](double strain) {  // smoothed stress at the first sample past this strain
    for (std::size_t k = 0; k < n; ++k)
      if (p.strain[k] >= strain) return smooth[k];
    return smooth.back();
  };
  out.flow_2_5 = stress_at(2.5 * eps_y), out.flow_5 = stress_at(5 * eps_y), out.flow_10 = stress_at(10 * eps_y);
  out.plateau = p.plateau_stress;
  return out;
}

std::vector<double> yield_bar_cells() {
  if (const char* e = std::getenv("PERIFX_YIELD_CELLS")) return {std::atof(e)};  // one resolution, for studies
  return {4, 6, 8};
}

scene::Material yield_bar_material() {
  scene::Material mat;
  mat.bulk_modulus = 3.3e6;
  mat.shear_modulus = 2.0e6;
  mat.plastic_cap_ratio = kInfinity;
  mat.damping = 0.0;
  return mat;
}

}  // namespace

TEST_CASE("yield_stress: a bar in tension flows at sigma_y at three resolutions (PERIFX_LONG_TESTS=1)" *
          doctest::skip(!long_tests())) {
  scene::Material mat = yield_bar_material();
  mat.yield_stress = 2.0e4;  // ε_y = σ_y/E = 0.4 %
  const double sigma_y = mat.yield_stress;
  const double youngs = perifx::youngs_modulus(mat.bulk_modulus, mat.shear_modulus), eps_y = sigma_y / youngs;
  for (double cells : yield_bar_cells()) {
    const YieldBar bar = pull_yield_bar(mat, cells, sigma_y);
    MESSAGE("cell " << bar.cell << " m: fitted modulus " << bar.modulus / youngs << " E; 0.2 % offset yield "
                    << bar.offset_yield / sigma_y << " sigma_y at strain " << bar.offset_strain / eps_y
                    << " eps_y; flow stress at 2.5 / 5 / 10 eps_y " << bar.flow_2_5 / sigma_y << " / "
                    << bar.flow_5 / sigma_y << " / " << bar.flow_10 / sigma_y << "; grip stress over the last quarter "
                    << bar.plateau / sigma_y << " sigma_y");
    std::cout << "YIELD {\"cell\": " << bar.cell << ", \"modulus_over_E\": " << bar.modulus / youngs
              << ", \"offset_yield_over_sigma_y\": " << bar.offset_yield / sigma_y << ", \"flow_2_5\": " << bar.flow_2_5 / sigma_y
              << ", \"flow_5\": " << bar.flow_5 / sigma_y << ", \"flow_10\": " << bar.flow_10 / sigma_y
              << ", \"plateau_over_sigma_y\": " << bar.plateau / sigma_y << "}" << std::endl;
    // Issue 12: the bar yields at σ_y within 5 %. σ_y is the flow stress (what every bond at ±A_c
    // carries, systems/README.md §12.2): the bar flows at it at 5 and 10 ε_y, at every resolution.
    // The paper's per-bond law yields gradually (axial bonds first, at half σ_y), so its 0.2 % offset
    // yield stress is below σ_y by a factor the law itself sets (0.933 for this σ_y/E, yield_law.hpp):
    // the bar's must be that value within 5 %.
    const double knee = systems::offset_yield_ratio(mat.bulk_modulus, mat.shear_modulus, sigma_y);
    CHECK(bar.flow_5 == doctest::Approx(sigma_y).epsilon(0.05));
    CHECK(bar.flow_10 == doctest::Approx(sigma_y).epsilon(0.05));
    CHECK(bar.offset_yield == doctest::Approx(knee * sigma_y).epsilon(0.05));
  }
}

TEST_CASE("offset_yield_stress: a bar in tension has its 0.2 % offset yield at the given stress at three resolutions (PERIFX_LONG_TESTS=1)" *
          doctest::skip(!long_tests())) {
  // The same bar given a datasheet's yield strength, σ_p0.2 = 2e4 Pa: set-up finds the flow stress
  // whose per-bond law has that offset yield (1.07 × it here), so the engineering reading of the bar
  // (ASTM E8's 0.2 % offset) must give σ_p0.2, and the bar still flows at the derived flow stress.
  scene::Material mat = yield_bar_material();
  mat.offset_yield_stress = 2.0e4;
  const double offset = mat.offset_yield_stress;
  const double flow = systems::flow_stress_for_offset_yield(mat.bulk_modulus, mat.shear_modulus, offset);
  const double youngs = perifx::youngs_modulus(mat.bulk_modulus, mat.shear_modulus);
  for (double cells : yield_bar_cells()) {
    const YieldBar bar = pull_yield_bar(mat, cells, flow);
    MESSAGE("cell " << bar.cell << " m: fitted modulus " << bar.modulus / youngs << " E; 0.2 % offset yield "
                    << bar.offset_yield / offset << " sigma_p0.2; flow stress at 5 / 10 eps_y " << bar.flow_5 / flow
                    << " / " << bar.flow_10 / flow << " of the derived " << flow << " Pa");
    std::cout << "OFFSET_YIELD {\"cell\": " << bar.cell << ", \"offset_yield_over_given\": " << bar.offset_yield / offset
              << ", \"flow_stress\": " << flow << ", \"flow_5\": " << bar.flow_5 / flow << ", \"flow_10\": " << bar.flow_10 / flow
              << "}" << std::endl;
    CHECK(bar.offset_yield == doctest::Approx(offset).epsilon(0.05));
    CHECK(bar.flow_10 == doctest::Approx(flow).epsilon(0.05));
  }
}
