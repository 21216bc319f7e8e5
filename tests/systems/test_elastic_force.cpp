// Elastic model checks against numbers the physics dictates (systems/README.md §2.2 and §2.4).
#include <doctest/doctest.h>

#include <Eigen/Geometry>
#include <algorithm>

#include "support.hpp"

using namespace perifx;

namespace {

const Vec3 kSize(0.2, 0.16, 0.12);
constexpr double kCell = 0.02;
constexpr double kKappa = 3.3e6, kMu = 2.0e6;

double max_norm(const std::vector<Vec3>& f) {
  double m = 0.0;
  for (const auto& v : f) m = std::max(m, v.norm());
  return m;
}

std::vector<Vec3> mapped(const World& world, const std::function<Vec3(const Vec3&)>& map) {
  std::vector<Vec3> y;
  for (const auto& x : world.reference_positions()) y.push_back(map(x));
  return y;
}

}  // namespace

// World set-up skips the initial dilatation and force passes when every particle is at its reference
// position (engine/setup/world_setup.cpp), relying on this: there θ and the force are exactly 0.0, for
// every normalization, with plasticity, anisotropy and an initial crack present.
TEST_CASE("the reference configuration has exactly zero dilatation and internal force") {
  for (auto norm : {scene::Normalization::paper, scene::Normalization::discrete, scene::Normalization::corrected}) {
    auto sc = test::box_scene(kSize, kCell, kKappa, kMu);
    sc.normalization = norm;
    sc.bodies[0].geometry.jitter = 0.3;
    sc.materials[0].yield_stress = 1e4;
    sc.materials[0].anisotropy = Vec3(1.0, 2.0, 1.5).asDiagonal();
    const std::size_t uncut_bonds = World(sc).bond_count();
    sc.cracks.push_back({{Vec3(0, -1, -1), Vec3(0, 0, -1), Vec3(0, 0, 1), Vec3(0, -1, 1)}});
    const World world(sc);
    const auto x = world.reference_positions();
    const auto e = test::evaluate(world, std::vector<Vec3>(x.begin(), x.end()));
    std::size_t nonzero = 0;
    for (std::size_t i = 0; i < x.size(); ++i) nonzero += e.theta[i] != 0.0 || e.coupling[i] != 0.0 || e.force[i] != Vec3::Zero();
    CHECK(nonzero == 0);
    CHECK(world.state().any_plastic);
    CHECK(world.state().any_anisotropic);
    CHECK(world.bond_count() < uncut_bonds);  // the crack removed bonds
  }
}

TEST_CASE("rigid translation and rotation give zero internal force") {
  World world(test::box_scene(kSize, kCell, kKappa, kMu));
  const double eps = 1e-3;
  const double stretch_force = max_norm(test::evaluate(world, mapped(world, [&](const Vec3& x) { return Vec3((1 + eps) * x); })).force);
  REQUIRE(stretch_force > 0.0);

  const Vec3 shift(0.37, -1.25, 2.5);
  const double translated = max_norm(test::evaluate(world, mapped(world, [&](const Vec3& x) { return Vec3(x + shift); })).force);
  CHECK(translated / stretch_force < 1e-10);

  const Mat3 rot = Eigen::AngleAxisd(1.1, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const double rotated = max_norm(test::evaluate(world, mapped(world, [&](const Vec3& x) { return Vec3(rot * x + shift); })).force);
  CHECK(rotated / stretch_force < 1e-10);
  MESSAGE("force ratio: translation " << translated / stretch_force << ", rotation " << rotated / stretch_force);
}

TEST_CASE("paper normalization: uniform stretch gives theta = 3 eps V_H / (4 pi delta^3 / 3) for every particle") {
  auto sc = test::box_scene(kSize, kCell, kKappa, kMu);
  sc.normalization = scene::Normalization::paper;  // the paper's θ scale (the default is `corrected`)
  World world(sc);
  const double eps = 1e-3;
  const auto ev = test::evaluate(world, mapped(world, [&](const Vec3& x) { return Vec3((1 + eps) * x); }));
  const WorldState& w = world.state();
  double worst = 0.0;
  for (std::size_t i = 0; i < world.particle_count(); ++i) {
    double family_volume = 0.0;
    for (std::uint32_t k = w.bonds.offsets[i]; k < w.bonds.offsets[i + 1]; ++k)
      family_volume += w.particles.volume[w.bonds.neighbor[k]];
    const double delta = w.model.horizon[i];
    const double expected = 3.0 * eps * family_volume / (4.0 * kPi * delta * delta * delta / 3.0);
    worst = std::max(worst, std::abs(ev.theta[i] - expected) / std::abs(expected));
  }
  // Round-off: the stretch is computed from positions of magnitude ~0.1 m, so e carries ~1e-16/1e-3
  // relative error per bond.
  CHECK(worst < 1e-9);
}

TEST_CASE("discrete normalization: theta = 3 eps everywhere, virial stress 3 kappa eps and mu gamma inside") {
  auto sc = test::box_scene(kSize, kCell, kKappa, kMu);
  sc.normalization = scene::Normalization::discrete;
  World world(sc);
  const double eps = 1e-4;
  const auto dil = test::evaluate(world, mapped(world, [&](const Vec3& x) { return Vec3((1 + eps) * x); }), true);
  double worst_theta = 0.0;
  for (double th : dil.theta) worst_theta = std::max(worst_theta, std::abs(th - 3 * eps) / (3 * eps));
  CHECK(worst_theta < 0.01);

  const double delta = world.state().model.horizon[0];
  const auto inside = test::interior(world, kSize, delta + 1e-9);
  REQUIRE(inside.size() > 0);
  double worst_pressure = 0.0;
  for (auto i : inside) {
    const double p = dil.stress[i].trace() / 3.0;
    worst_pressure = std::max(worst_pressure, std::abs(p - 3 * kKappa * eps) / (3 * kKappa * eps));
  }
  CHECK(worst_pressure < 0.03);  // exact by construction of a and beta: this is round-off

  const double gamma = 1e-4;
  const auto shear = test::evaluate(world, mapped(world, [&](const Vec3& x) { return Vec3(x + Vec3(gamma * x.y(), 0, 0)); }), true);
  double worst_shear = 0.0, mean_shear = 0.0, mean_theta = 0.0;
  for (auto i : inside) {
    const double s = 0.5 * (shear.stress[i](0, 1) + shear.stress[i](1, 0));
    worst_shear = std::max(worst_shear, std::abs(s - kMu * gamma) / (kMu * gamma));
    mean_shear += s / (kMu * gamma) / double(inside.size());
    mean_theta += std::abs(shear.theta[i]) / gamma / double(inside.size());
  }
  // The homogenized (mean) response is what waves and deformation see: within 3%. Single particles of
  // the structured lattice differ by their tet type's fourth moments, a few percent either way.
  CHECK(std::abs(mean_shear - 1.0) < 0.03);
  CHECK(worst_shear < 0.07);
  MESSAGE("mean shear ratio " << mean_shear << ", mean |theta|/gamma under shear " << mean_theta);
  MESSAGE("discrete normalization: theta error " << worst_theta << ", pressure error " << worst_pressure
                                                 << ", shear error " << worst_shear << " over " << inside.size()
                                                 << " interior particles");
}

TEST_CASE("paper normalization: how far the discrete virial stress is from 3 kappa eps and mu gamma (report)") {
  World world(test::box_scene(kSize, kCell, kKappa, kMu));
  const double eps = 1e-4, gamma = 1e-4;
  const auto dil = test::evaluate(world, mapped(world, [&](const Vec3& x) { return Vec3((1 + eps) * x); }), true);
  const auto shear = test::evaluate(world, mapped(world, [&](const Vec3& x) { return Vec3(x + Vec3(gamma * x.y(), 0, 0)); }), true);
  const double delta = world.state().model.horizon[0];
  const auto inside = test::interior(world, kSize, delta + 1e-9);
  double p_mean = 0.0, s_mean = 0.0, th_mean = 0.0;
  for (auto i : inside) {
    p_mean += dil.stress[i].trace() / 3.0 / (3 * kKappa * eps);
    s_mean += 0.5 * (shear.stress[i](0, 1) + shear.stress[i](1, 0)) / (kMu * gamma);
    th_mean += dil.theta[i] / (3 * eps);
  }
  const double n = double(inside.size());
  MESSAGE("paper normalization, interior means: theta/3eps = " << th_mean / n << ", pressure/(3 kappa eps) = "
                                                               << p_mean / n << ", shear/(mu gamma) = " << s_mean / n);
  // The paper's constants are exact for a continuous ball; a discrete lattice family differs by a
  // lattice-dependent factor, but must stay within tens of percent or the constants are wrong.
  CHECK(std::abs(th_mean / n - 1.0) < 0.3);
  CHECK(std::abs(p_mean / n - 1.0) < 0.5);
  CHECK(std::abs(s_mean / n - 1.0) < 0.5);
}

// `corrected` scales a particle's constants by powers of its fill f = m_i/m_body (§2.4), which must be
// 1 for a complete family. On a jittered mesh the complete families' m_i scatter (1.4 % s.d. at jitter
// 0.3); measured against the body's largest single m_i they read as cut, and the interior lost 3 % of
// its bulk and 2 % of its shear stiffness. With the reference taken from family-averaged m and f
// clamped at 1, only the particles below the reference by their scatter stay (slightly) scaled: the
// interior's mean response to a uniform dilatation and to the three axis shears is within 1 %.
TEST_CASE("corrected normalization: a jittered body's interior keeps the material's bulk and shear stiffness") {
  const Vec3 size(0.04, 0.04, 0.04);
  auto sc = test::box_scene(size, 0.005, kKappa, kMu);
  sc.bodies[0].geometry.jitter = 0.3;
  REQUIRE(sc.normalization == scene::Normalization::corrected);
  World world(sc);
  const double eps = 1e-5;
  const double delta = world.state().model.horizon[0];
  const auto inside = test::interior(world, size, delta + 1e-9);
  REQUIRE(inside.size() > 200);
  const auto dil = test::evaluate(world, mapped(world, [&](const Vec3& x) { return Vec3((1 + eps) * x); }), true);
  double pressure = 0.0;
  for (auto i : inside) pressure += dil.stress[i].trace() / 3.0 / (3 * kKappa * eps) / double(inside.size());
  double shear = 0.0;
  for (int a = 0; a < 3; ++a) {
    const int b = (a + 1) % 3;
    const auto s = test::evaluate(world, mapped(world, [&](const Vec3& x) { Vec3 y = x; y[a] += eps * x[b]; return y; }), true);
    for (auto i : inside) shear += 0.5 * (s.stress[i](a, b) + s.stress[i](b, a)) / (kMu * eps) / (3.0 * double(inside.size()));
  }
  MESSAGE("jittered interior (" << inside.size() << " particles): pressure / 3 kappa eps " << pressure
                                << ", axis shear / mu gamma " << shear);
  CHECK(pressure == doctest::Approx(1.0).epsilon(0.01));
  CHECK(shear == doctest::Approx(1.0).epsilon(0.01));
}
