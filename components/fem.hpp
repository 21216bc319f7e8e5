// Finite-element reference model on the same tetrahedral mesh as the peridynamic particles
// (paper §6 compares against linear and corotated linear FEM). In FEM mode the simulated points
// (Particles) are the mesh VERTICES, with lumped mass m_v = Σ ρ V_t / 4 over the incident tets, so
// boundary conditions, colliders, gravity, damping and velocity Verlet run on them unchanged.
// Per tet t with reference edge matrix Dm = [X1−X0, X2−X0, X3−X0] and current Ds likewise:
//   F = Ds Dm⁻¹;  linear:     ε = sym(F) − I,          P = λ tr(ε) I + 2μ ε
//                 corotated:  F = R S (polar),  ε = sym(RᵀF) − I,  P = R (λ tr(ε) I + 2μ ε)
//   corner forces [f1 f2 f3] = −V P Dm⁻ᵀ,  f0 = −(f1 + f2 + f3)     (f = −V Bᵀσ)
// Lamé constants from the material's κ, μ: λ = κ − 2μ/3.
#pragma once
#include <vector>

#include "components/math.hpp"

namespace perifx {

struct FemModel {
  bool corotated = false;
  // Per tet (index = tet index of WorldState::mesh; vertex indices there are particle indices).
  std::vector<Mat3> dm_inverse;            // Dm⁻¹, 1/m
  std::vector<double> volume;              // V_t, m³
  std::vector<double> lame_lambda;         // λ, Pa
  std::vector<double> lame_mu;             // μ, Pa
  // Vertex → incident (tet, corner) in CSR, sorted by tet: entry = 4·tet + corner. The force gather
  // walks it in this fixed order, so forces are bit-identical for any thread count.
  std::vector<std::uint32_t> vertex_offsets;  // length vertices + 1
  std::vector<std::uint32_t> vertex_corners;  // length 4·tets
  std::vector<Vec3> corner_force;             // scratch, length 4·tets, N (written by fem_force)
};

}  // namespace perifx
