// The per-bond yield law (Eq 12–15) read in the continuum, for uniaxial tension: how the flow stress
// σ_y that perifx converts to A_c (systems/README.md §12.2) relates to an engineering offset yield
// stress (a datasheet's R_p0.2). Used by set-up (a material given `offset_yield_stress`), `perifx info`
// and the yield tests; not by the step.
#pragma once

namespace perifx::systems {

// Stress at the given plastic offset strain (0.002 for R_p0.2), as a fraction of the flow stress, for
// a material of bulk modulus κ and shear modulus μ (Pa) whose full-flow stress is `flow_stress` (Pa).
// Bonds in every direction n of a full isotropic family carry the deviatoric strain
// s(n) = n·ε_d·n − p(n) capped at ±s_c, s_c = √3 σ_y/(10 μ) (every bond at the cap carries σ_y); the
// stress is κ tr ε I + (15μ/4π) ∫ s n⊗n dΩ; the lateral strain keeps σ_yy = σ_zz = 0. The axial bonds
// reach the cap first, at about half σ_y, so the ratio is below 1 and depends on σ_y/E: 0.983 at
// 0.125 %, 0.933 at 0.4 %, 0.851 at 1 % (ν = 0.25). About 20 ms; NaN for a non-positive or
// infinite input.
double offset_yield_ratio(double kappa, double mu, double flow_stress, double offset_strain = 0.002);

// The inverse: the flow stress whose offset yield stress is `offset_yield` (Pa), i.e. the σ_y with
// σ_y · offset_yield_ratio(κ, μ, σ_y) = offset_yield. A datasheet's yield strength is an offset (proof)
// stress; a scene gives it as `offset_yield_stress` and set-up converts it here. The offset stress lies
// between the first yield, 3√3/10 σ_y, and σ_y, so the root is bracketed by [Y, Y / 0.5196] and found
// by regula falsi (Illinois) to a relative 1e-10: 6–10 evaluations, 0.1–0.2 s per material. NaN for a
// non-positive or infinite input.
double flow_stress_for_offset_yield(double kappa, double mu, double offset_yield, double offset_strain = 0.002);

}  // namespace perifx::systems
