// Turns a typed scene into a ready WorldState: meshes every body, places one particle per tet
// (barycenter, V = tet volume, m = ρV, paper §5.2) in Morton order, builds families and the model
// constants, resolves boundary-condition regions and evaluates the initial acceleration.
#pragma once
#include <memory>

#include "scheduler.hpp"
#include "world_state.hpp"

namespace perifx::model {

std::unique_ptr<WorldState> build_world_state(const scene::Scene& scene, Scheduler& scheduler);

// Registers the per-step systems with the scheduler, in their logical order.
void add_step_systems(WorldState& world, Scheduler& scheduler);

// Largest stable velocity-Verlet step 2/ω_max, ω_max² the largest eigenvalue of M⁻¹K for the
// linearized elastic force at the reference configuration (power iteration with a Rayleigh quotient).
double estimate_stable_time_step(const WorldState& world);

// Elastic energy of the current state (notes.md): Σ_i V_i [k_i θ_i² + b_i Σ_j ω_ij (e_ij − e^p_ij)² V_j],
// k_i = (a_i − b_i β_i)/c_i, whose negative gradient is the paired force of Eq 2 (to first order in Λ).
double elastic_energy(const WorldState& world);

}  // namespace perifx::model
