// The continuum per-bond yield law in tension (systems/yield_law.hpp, systems/README.md §12.2).
#include <doctest/doctest.h>

#include <cmath>

#include "support.hpp"
#include "systems/yield_law.hpp"

using namespace perifx;

TEST_CASE("yield law: the per-bond law yields first at 3 sqrt(3)/10 sigma_y, its 0.2 % offset yield below sigma_y, flows at it") {
  const double kappa = 3.3e6, mu = 2.0e6, youngs = perifx::youngs_modulus(kappa, mu);
  // The first bonds to reach the cap are the axial ones: deviatoric strain (2/3)(1 + ν) ε = s_c with
  // s_c = √3 σ_y/(10 μ), at the stress E ε = 3√3/10 σ_y for any ν. A tiny offset reads it.
  for (double bulk : {1.0e6, 3.3e6, 2.0e7}) {  // ν −0.1, 0.25, 0.45
    const double first = systems::offset_yield_ratio(bulk, mu, 0.004 * perifx::youngs_modulus(bulk, mu), 1e-9);
    CHECK(first == doctest::Approx(3.0 * std::sqrt(3.0) / 10.0).epsilon(0.005));
  }
  // The engineering (0.2 %) offset yield depends on how far 0.2 % lies along the knee, i.e. on σ_y/E.
  // Reference: an independent model of the same law (assets/report/yield_knee.py, NumPy, 4000
  // directions): 0.9829 at steel's ratio 0.125 %, 0.9329 at aluminium's 0.4 %, 0.8506 at 1 %.
  const double steel = systems::offset_yield_ratio(kappa, mu, 0.00125 * youngs);
  const double aluminium = systems::offset_yield_ratio(kappa, mu, 0.004 * youngs);
  const double soft = systems::offset_yield_ratio(kappa, mu, 0.01 * youngs);
  MESSAGE("0.2 % offset yield / flow stress: " << steel << " (0.125 %), " << aluminium << " (0.4 %), " << soft << " (1 %)");
  CHECK(steel == doctest::Approx(0.9829).epsilon(0.002));
  CHECK(aluminium == doctest::Approx(0.9329).epsilon(0.002));
  CHECK(soft == doctest::Approx(0.8506).epsilon(0.002));
  // A large offset (12.5 ε_y) reads the flow stress itself, which every bond at the cap carries.
  CHECK(systems::offset_yield_ratio(kappa, mu, 0.004 * youngs, 0.05) == doctest::Approx(1.0).epsilon(0.002));
  // Nothing to read for an elastic or a malformed material.
  CHECK(std::isnan(systems::offset_yield_ratio(kappa, mu, INFINITY)));
  CHECK(std::isnan(systems::offset_yield_ratio(kappa, 0.0, 1e4)));
}

TEST_CASE("yield law: the flow stress for a given 0.2 % offset yield stress inverts the offset ratio") {
  const double kappa = 3.3e6, mu = 2.0e6, youngs = perifx::youngs_modulus(kappa, mu);
  // Offset stresses at σ/E of 0.1 %, 0.4 % and 1 %: the flow stress found has exactly that offset yield
  // under the law, and lies above it by the law's factor (about 1/0.93 at 0.4 %, as the table above).
  for (double strain : {0.001, 0.004, 0.01}) {
    const double offset = strain * youngs;
    const double flow = systems::flow_stress_for_offset_yield(kappa, mu, offset);
    CAPTURE(strain);
    CHECK(flow * systems::offset_yield_ratio(kappa, mu, flow) == doctest::Approx(offset).epsilon(1e-8));
    CHECK(flow > offset);
    CHECK(flow < offset / (0.3 * std::sqrt(3.0)));  // the offset stress is above the first yield
  }
  const double aluminium = systems::flow_stress_for_offset_yield(kappa, mu, 0.004 * youngs) / (0.004 * youngs);
  MESSAGE("flow stress / offset yield stress at sigma/E = 0.4 %: " << aluminium);
  CHECK(aluminium > 1.0 / 0.9329);  // the flow stress's own σ/E is larger, where the knee is rounder
  CHECK(aluminium < 1.1);
  CHECK(std::isnan(systems::flow_stress_for_offset_yield(kappa, mu, 0.0)));
  CHECK(std::isnan(systems::flow_stress_for_offset_yield(kappa, mu, INFINITY)));
  CHECK(std::isnan(systems::flow_stress_for_offset_yield(kappa, -1.0, 1e4)));
}
