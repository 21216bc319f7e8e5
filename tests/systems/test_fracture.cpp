// Fracture (Eq 18–19, systems/README.md §5 decisions), damage, fragments and initial cracks.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>

#include "systems/bond_rules.hpp"
#include "support.hpp"
#include "scheduler.hpp"
#include "systems/pipeline.hpp"

using namespace perifx;

namespace {

constexpr double kKappa = 5.0e5, kMu = 3.0e5;

std::size_t broken(const World& w) { return w.bond_count() - w.alive_bond_count(); }

}  // namespace

TEST_CASE("a bond breaks in the first step its measure exceeds s_c, not one earlier, compression never breaks") {
  auto sc = test::box_scene(Vec3(0.04, 0.04, 0.04), 0.02, kKappa, kMu);
  const double s_c = 0.01;
  sc.materials[0].critical_stretch = s_c;
  World world(sc);
  WorldState& w = world.state_mutable();
  const std::size_t i = 0;
  const std::uint32_t k = w.bonds.offsets[i];
  const std::uint32_t j = w.bonds.neighbor[k], m = systems::mirror_bond(w.bonds, i, k);
  const auto& x = w.particles.reference_position;
  const Vec3 dir = (x[j] - x[i]).normalized();
  const double delta = w.model.horizon[i];
  // measure = e/(|ξ| ω) = e/δ with e = n·v·dt: first n with n v dt/δ > s_c.
  const double v = 0.01, dt = 1e-3;
  const double crossing = s_c * delta / (v * dt);
  const auto expected = static_cast<std::uint64_t>(std::floor(crossing)) + 1;
  REQUIRE(crossing - std::floor(crossing) > 0.05);  // not at a step boundary: round-off cannot move it
  REQUIRE(crossing - std::floor(crossing) < 0.95);
  std::vector<Vec3> y(x.begin(), x.end());
  std::uint64_t broke_at = 0;
  for (std::uint64_t n = 1; n <= expected + 5 && !broke_at; ++n) {
    y[j] = x[j] + (double(n) * v * dt) * dir;
    systems::update_fracture(w, y);
    CHECK(w.bonds.alive[k] == w.bonds.alive[m]);  // both directions at once
    if (!w.bonds.alive[k]) broke_at = n;
  }
  MESSAGE("crossing at step " << crossing << ": broke at step " << broke_at);
  CHECK(broke_at == expected);

  // Compression far past |e| = s_c δ: nothing breaks.
  World other(sc);
  WorldState& w2 = other.state_mutable();
  std::vector<Vec3> z(x.begin(), x.end());
  z[j] = x[j] - 0.5 * (x[j] - x[i]);
  for (auto& p : z) p = x[0] + 0.5 * (p - x[0]);  // halve every distance: every bond compressed by 50%
  systems::update_fracture(w2, z);
  CHECK(std::count(w2.bonds.alive.begin(), w2.bonds.alive.end(), 0) == 0);
}

namespace {

// Plate in the x–y plane pulled apart in y by its top and bottom rows (displacement ramp, hold).
scene::Scene plate_scene(bool notch) {
  const Vec3 size(0.1, 0.05, 0.005);
  const double cell = 0.005;
  auto sc = test::box_scene(size, cell, kKappa, kMu);
  sc.materials[0].critical_stretch = 0.02;
  sc.materials[0].damping = 20.0;
  sc.time.dt = 8e-5;  // 0.63 of the stable step under the default (`corrected`) constants
  const double strain = 0.6 * 0.02;  // far-field strain 60% of s_c
  for (int side : {-1, 1}) {
    scene::BoundaryCondition bc;
    bc.kind = scene::BoundaryCondition::Kind::displacement;
    bc.region.kind = scene::Region::Kind::box;
    bc.region.min = Vec3(-1, side < 0 ? -1.0 : 0.5 * size.y() - cell, -1);
    bc.region.max = Vec3(1, side < 0 ? -0.5 * size.y() + cell : 1.0, 1);
    bc.displacement = Vec3(0, side * 0.5 * strain * size.y(), 0);
    bc.window = {0.0, 0.01, kInfinity};  // 10 ms ramp: ~5 transit times of the plate height
    sc.boundary_conditions.push_back(bc);
  }
  if (notch) {  // through-thickness notch from the left edge to x = −0.02 on the plane y = 0
    scene::Crack c;
    c.polygon = {Vec3(-0.06, 0, -0.01), Vec3(-0.02, 0, -0.01), Vec3(-0.02, 0, 0.01), Vec3(-0.06, 0, 0.01)};
    sc.cracks.push_back(c);
  }
  return sc;
}

}  // namespace

TEST_CASE("notched plate in tension cracks from the notch tip, the unnotched plate does not break") {
  World plain(plate_scene(false));
  World notched(plate_scene(true));
  MESSAGE("particles " << plain.particle_count() << ", stable dt " << plain.stable_time_step() << " s");
  REQUIRE(plain.dt() < 0.7 * plain.stable_time_step());
  REQUIRE(notched.bond_count() < plain.bond_count());  // the notch removed bonds at setup
  CHECK(notched.alive_bond_count() == notched.bond_count());
  const Vec3 tip(-0.02, 0, 0);
  const double delta = notched.state().model.horizon[0];
  // Step until the first break and record where it happened.
  double first_distance = -1;
  for (int s = 0; s < 250; ++s) {  // 20 ms: the 10 ms ramp, then a hold
    notched.step();
    if (first_distance < 0 && broken(notched) > 0) {
      const auto& st = notched.state();
      first_distance = kInfinity;
      for (std::size_t i = 0; i < notched.particle_count(); ++i)
        if (st.state.broken_bonds[i] > 0)
          first_distance = std::min(first_distance, (st.particles.reference_position[i] - tip).norm());
      MESSAGE("first break at step " << s + 1 << ", nearest broken particle " << first_distance / delta << " δ from the tip");
    }
  }
  plain.step(250);
  CHECK(broken(plain) == 0);
  REQUIRE(first_distance >= 0);
  CHECK(first_distance < 1.5 * delta);
  // Damage near the tip (within 2δ) versus the rest of the plate.
  const auto& st = notched.state();
  double near = 0, far = 0;
  int n_near = 0, n_far = 0;
  for (std::size_t i = 0; i < notched.particle_count(); ++i) {
    const double d = (st.particles.reference_position[i] - tip).norm();
    if (d < 2 * delta) near += st.state.damage[i], ++n_near;
    else if (d > 4 * delta) far += st.state.damage[i], ++n_far;
  }
  near /= n_near, far /= n_far;
  MESSAGE("broken bonds: notched " << broken(notched) << ", plain " << broken(plain) << "; mean damage near tip "
                                   << near << ", far " << far);
  CHECK(near > 2 * far);
  CHECK(near > 0.0);
}

TEST_CASE("fracture conserves linear momentum (body torn apart by initial velocities)") {
  auto sc = test::box_scene(Vec3(0.06, 0.03, 0.03), 0.01, kKappa, kMu);
  sc.materials[0].critical_stretch = 0.01;
  sc.time.dt = 5e-5;
  World world(sc);
  auto v = world.velocities_mutable();
  const auto x = world.reference_positions();
  const auto& mass = world.state().particles.mass;
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = Vec3(x[i].x() > 0 ? 2.0 : -1.0, 0.3 * x[i].y() / 0.03, 0.0);
  const Vec3 p0 = world.diagnostics().linear_momentum;
  double scale = 0;
  for (std::size_t i = 0; i < v.size(); ++i) scale += mass[i] * v[i].norm();
  world.step(400);
  const Vec3 p1 = world.diagnostics().linear_momentum;
  MESSAGE("broken bonds " << broken(world) << ", fragments " << world.fragment_count() << ", |ΔP|/Σm|v| = "
                          << (p1 - p0).norm() / scale);
  CHECK(broken(world) > 0);
  CHECK(world.fragment_count() >= 2);
  CHECK((p1 - p0).norm() / scale < 1e-10);
}

namespace {

// A breaking, yielding (and optionally anisotropic) box torn apart by its initial velocities.
World tearing_box(int threads, bool anisotropic) {
  auto sc = test::box_scene(Vec3(0.06, 0.03, 0.03), 0.01, kKappa, kMu);
  sc.threads = threads;
  sc.materials[0].critical_stretch = 0.02;
  sc.materials[0].damage_alpha = 1.0;
  sc.materials[0].yield_energy = 1e9;
  sc.materials[0].plastic_cap_ratio = 0.05;
  if (anisotropic) sc.materials[0].anisotropy = Vec3(1.5, 1.0, 1.0).asDiagonal();
  sc.time.dt = 5e-5;
  World w(sc);
  auto v = w.velocities_mutable();
  const auto x = w.reference_positions();
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = Vec3(x[i].x() > 0 ? 2.0 : -1.0, 10 * x[i].z(), 0.0);
  return w;
}

// The test oracle for the fused bond pass: the step with the separate bond systems, plasticity →
// elastic_force in place of bond_pass and fracture → damage after kick_end, everything else as the
// production step (systems/pipeline.cpp, PipelineOptions::separate_bond_systems) schedules it. Runs on the world's state with its own
// scheduler; the world's own step is not used.
class SeparateBondSystemsStep {
 public:
  explicit SeparateBondSystemsStep(World& world) : world_(world.state_mutable()), scheduler_(world.threads()) {
    REQUIRE(world_.settings.solver == scene::Solver::peridynamics);
    systems::PipelineOptions options;
    options.separate_bond_systems = true;
    for (auto& system : systems::step_pipeline(world_, options)) scheduler_.add(std::move(system));
    scheduler_.build();
  }
  void step(std::uint64_t count) {
    for (std::uint64_t s = 0; s < count; ++s) {
      scheduler_.run_step();
      auto& c = world_.clock;  // as World::step
      ++c.step;
      c.time = static_cast<double>(c.step) * c.dt;
    }
  }

 private:
  WorldState& world_;
  Scheduler scheduler_;
};

bool same_bits(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](const Vec3& p, const Vec3& q) {
           return p.x() == q.x() && p.y() == q.y() && p.z() == q.z();
         });
}

// Both runs must have broken and yielded bonds, and agree bit for bit in everything the step evolves.
void check_identical(const World& a, const World& b) {
  const auto& sa = a.state();
  const auto& sb = b.state();
  std::size_t plastic = 0;
  for (double ep : sa.bonds.plastic_extension) plastic += ep != 0.0;
  MESSAGE("broken " << broken(a) << ", plastic bonds " << plastic);
  CHECK(broken(a) > 0);
  CHECK(plastic > 0);
  CHECK(sa.bonds.alive == sb.bonds.alive);
  CHECK(sa.bonds.plastic_extension == sb.bonds.plastic_extension);
  CHECK(same_bits(sa.particles.position, sb.particles.position));
  CHECK(same_bits(sa.particles.velocity, sb.particles.velocity));
  CHECK(sa.state.damage == sb.state.damage);
  CHECK(sa.state.broken_bonds == sb.state.broken_bonds);
}

}  // namespace

TEST_CASE("fracture + plasticity + anisotropy: 1 and 2 threads give bit-identical results") {
  World a = tearing_box(1, true), b = tearing_box(2, true);
  REQUIRE(a.threads() == 1);
  REQUIRE(b.threads() == 2);
  a.step(300);
  b.step(300);
  check_identical(a, b);
}

TEST_CASE("the fused bond pass gives the same bits as the separate plasticity, force, fracture, damage systems") {
  for (const bool anisotropic : {false, true}) {
    CAPTURE(anisotropic);
    World fused = tearing_box(2, anisotropic), separate = tearing_box(2, anisotropic);
    fused.step(300);
    SeparateBondSystemsStep(separate).step(300);
    check_identical(fused, separate);
    // Each particle keeps a mirror copy of the other side's plastic extension; it must never drift
    // from the original, or the two ends of a bond would disagree on yield and breaking.
    for (const World* w : {&fused, &separate}) {
      const auto& bonds = w->state().bonds;
      std::size_t mismatched = 0;
      const auto mirror = systems::mirror_bonds(bonds);
      for (std::size_t k = 0; k < bonds.count(); ++k)
        mismatched += bonds.plastic_extension_mirror[k] != bonds.plastic_extension[mirror[k]];
      CHECK(mismatched == 0);
    }
  }
}

TEST_CASE("initial crack polygon removes exactly the bonds crossing it, damage starts at zero") {
  auto sc = test::box_scene(Vec3(0.04, 0.04, 0.04), 0.01, kKappa, kMu);
  scene::Crack c;  // the plane x = 0.001 over the whole cross-section (no particle lies on it)
  c.polygon = {Vec3(0.001, -1, -1), Vec3(0.001, 1, -1), Vec3(0.001, 1, 1), Vec3(0.001, -1, 1)};
  World whole(sc);
  sc.cracks.push_back(c);
  World cut(sc);
  const auto& a = whole.state();
  const auto& b = cut.state();
  std::size_t crossing = 0;
  const auto& x = a.particles.reference_position;
  for (std::size_t i = 0; i < whole.particle_count(); ++i)
    for (std::uint32_t k = a.bonds.offsets[i]; k < a.bonds.offsets[i + 1]; ++k)
      crossing += (x[i].x() - 0.001) * (x[a.bonds.neighbor[k]].x() - 0.001) < 0;
  CHECK(crossing > 0);
  CHECK(whole.bond_count() - cut.bond_count() == crossing);
  CHECK(cut.fragment_count() == 2);
  const auto mirror = systems::mirror_bonds(b.bonds);  // every kept bond kept its mirror
  for (std::size_t i = 0; i < cut.particle_count(); ++i)
    for (std::uint32_t k = b.bonds.offsets[i]; k < b.bonds.offsets[i + 1]; ++k) {
      REQUIRE(mirror[k] < b.bonds.count());
      CHECK(b.bonds.neighbor[mirror[k]] == i);
      CHECK(mirror[mirror[k]] == k);
    }
  for (double d : b.state.damage) CHECK(d == 0.0);
}

namespace {

// A free brittle plate (x–y) shot through by a fast kinematic sphere collider along −z.
std::pair<std::size_t, std::size_t> impact(double alpha) {
  auto sc = test::box_scene(Vec3(0.06, 0.06, 0.005), 0.005, kKappa, kMu);
  sc.materials[0].critical_stretch = 0.005;
  sc.materials[0].damage_alpha = alpha;
  sc.time.dt = 2e-5;
  scene::Collider ball;
  ball.kind = scene::Collider::Kind::sphere;
  ball.center = Vec3(0, 0, 0.015);
  ball.radius = 0.008;
  ball.velocity = Vec3(0, 0, -20.0);
  sc.colliders.push_back(ball);
  World world(sc);
  world.step(250);  // the ball crosses the plate in ~1.5 ms; 5 ms in all
  return {world.fragment_count(), world.bond_count() - world.alive_bond_count()};
}

}  // namespace

TEST_CASE("the same impact with alpha > 0 gives fewer fragments than with alpha = 0") {
  const auto [f0, b0] = impact(0.0);
  const auto [f3, b3] = impact(3.0);
  MESSAGE("alpha 0: " << f0 << " fragments, " << b0 << " broken bonds; alpha 3: " << f3 << " fragments, " << b3
                      << " broken bonds");
  CHECK(f0 > 1);
  CHECK(f3 < f0);
}
