// Per-particle state, structure of arrays. Index i is particle i everywhere; particle i is also
// tetrahedron i of the body's embedded mesh (particles sit at tet barycenters, paper §5.2), and
// particles are stored in Morton order so a family is close in memory.
#pragma once
#include <cstdint>
#include <vector>

#include "components/math.hpp"

namespace perifx {

// Bit flags in Particles::flags.
enum ParticleFlag : std::uint8_t {
  kAnchored = 1u << 0,      // position held at its reference value (a boundary condition)
  // The velocity components a boundary condition prescribes this step, one bit per world axis.
  kPrescribedX = 1u << 1,
  kPrescribedY = 1u << 2,
  kPrescribedZ = 1u << 3,
  kPrescribed = kPrescribedX | kPrescribedY | kPrescribedZ,  // test with & for any axis, == for all
};

struct Particles {
  // All arrays have length count().
  std::vector<Vec3> reference_position;  // x, m
  std::vector<Vec3> position;            // y, m
  std::vector<Vec3> velocity;            // m/s
  std::vector<Vec3> acceleration;        // m/s², from the last force evaluation (velocity Verlet)
  std::vector<double> volume;            // V, m³ (tet volume)
  std::vector<double> mass;              // m = ρV, kg
  std::vector<std::uint16_t> material_id;
  std::vector<std::uint16_t> body_id;
  std::vector<std::uint8_t> flags;       // ParticleFlag bits

  std::size_t count() const { return position.size(); }
};

// Per-particle model constants, fixed after setup (they depend on material, horizon and, under the
// discrete normalization, on the particle's own family). With them every bond force is
//   A_ij = ω_ij (Λ_ij·P_i + b4_i·(e_ij − e^p_ij)),   P_i = (a4_i − b4_i·β_i)·θ_i,
// which is Eq 4 + Eq 8/12 regrouped: a4 = 4a, b4 = 4b, β = δ/4 in the paper's normalization.
// M = GᵀG of a particle's material (Eq 17) as its six distinct entries: the weighted length of a bond
// side is ℓ_ij = |G_i ξ| = sqrt(ξᵀ M_i ξ). Kept per particle, so a bond kernel gathers it from j like
// the positions (through material_id, a two-level gather, GCC 12 would not vectorize the bond loop).
struct AnisotropyMetric {
  double xx, yy, zz, xy, xz, yz;
};

// Values of ParticleModel::anisotropic_family.
enum class RowForm : std::uint8_t {
  isotropic = 0,     // ℓ = |ξ|
  anisotropic = 1,   // ℓ_ij = |G_i ξ| and ℓ_ji = |G_j ξ|, each from its particle's metric
  shared_metric = 2  // anisotropic, and every neighbour's metric equals this particle's: ℓ_ji = ℓ_ij
};

// A particle's reference position and volume, one 32-byte vector (ParticleModel::reference_point).
struct alignas(32) ReferencePoint {
  double x, y, z;  // m
  double volume;   // m³
};

struct ParticleModel {
  std::vector<double> horizon;          // δ, m
  // Per particle when some material has G ≠ I (WorldState::any_anisotropic), else empty.
  std::vector<AnisotropyMetric> anisotropy_metric;
  // Per particle when some material has G ≠ I, else empty: the form of the particle's row in the bond
  // kernels (bond_rules.hpp, dispatch_row), a RowForm value. Anisotropic when the particle's body holds
  // an anisotropic particle (or is joined by a bond to a body that does), so a body of an isotropic
  // material runs the isotropic form in any scene; per body, so both ends of every bond use the same
  // form and compute the same bits. Of those rows, the ones whose every neighbour has the particle's
  // own GᵀG bit for bit (inside one material) take one weighted length per bond, not two.
  std::vector<std::uint8_t> anisotropic_family;
  std::vector<double> dilatation_scale; // θ_i = dilatation_scale_i · Σ ω e Λ V  (paper: 9/(4πδ⁴))
  std::vector<double> a4;               // 4a, Pa/m⁴ (paper: 4·9κ/(8πδ⁴))
  std::vector<double> b4;               // 4b, Pa/m⁵ (paper: 4·15μ/(2πδ⁵))
  std::vector<double> beta;             // β in e^d = e − β Λ θ, m (paper: δ/4)
  std::vector<double> damping;          // mass-proportional damping rate, 1/s
  // Inelastic constants of the particle's material, per particle so a bond pass gathers them like
  // the elastic ones (no material lookup per bond).
  std::vector<double> yield_extension;  // Y = √(2Ψ0)/(b4 δ) (Eq 14): a bond side yields when
                                        // |e^d − e^p| > Y·|G ξ|; ∞ = purely elastic
  std::vector<double> plastic_cap;      // γ/|ξ| (Eq 16), dimensionless
  std::vector<double> critical_stretch; // s_c (Eq 19); ∞ = unbreakable
  std::vector<double> damage_alpha;     // α (Eq 19, systems/README.md §5)
  // A copy of particles.reference_position and particles.volume packed per particle (set with the
  // constants above), for the bond kernels' gathers: a neighbour's ξ end and V_j come in with one
  // aligned 32-byte load (systems/bond_gather.hpp) instead of a masked load and a scalar V_j.
  std::vector<ReferencePoint> reference_point;
};

// What the fused bond pass reads of the far end j of a bond i→j, packed in one 64-byte line per
// particle: one cache line per neighbour instead of nine scattered arrays. A copy of the arrays it
// is made from (ParticleModel, ParticleState), refreshed by the bond pass itself at its start.
struct alignas(64) BondEnd {
  // What the force needs (every bond pass) ...
  double coupling;         // P_j, Pa/m⁴ (ParticleState::dilatation_coupling)
  double b4;               // 4b_j, Pa/m⁵
  double volume;           // V_j, m³
  double horizon;          // δ_j, m
  // ... and what plasticity and fracture add: each half is loaded as one 32-byte vector
  // (systems/bond_gather.hpp), so the order matters.
  double beta_theta;       // β_j θ_j, m
  double yield_extension;  // Y_j (ParticleModel::yield_extension)
  double plastic_cap;      // γ/|ξ| of j's material
  double break_extension;  // (1 + α_j φ_j) s_c,j δ_j, m
};

// Which colliders held a particle in this step, and along which normals (systems/colliders.cpp), for
// kick_end's support constraint (systems/integration.cpp). Three slots: a particle at the corner of a
// room (a floor and two walls) is held by all three; a fourth collider at once is not recorded (three
// independent normals already hold a velocity fully). 48 bytes; float: a normal only decides a
// direction, to ~1e-7.
struct ColliderContact {
  static constexpr std::int32_t kNone = -1;
  static constexpr int kSlots = 3;
  float normal[kSlots][3] = {};                       // unit, out of the collider
  std::int32_t collider[kSlots] = {kNone, kNone, kNone};  // index into StepSettings::colliders, or kNone; filled in order
};

// Per-particle results of the step's systems.
struct ParticleState {
  std::vector<double> dilatation;           // θ_i (Eq 6), written by the dilatation system
  std::vector<double> dilatation_coupling;  // P_i = (a4_i − b4_i β_i) θ_i, Pa/m⁴
  std::vector<Vec3> internal_force;         // N, peridynamic force on the particle (Eq 2 × V_i)
  std::vector<Vec3> external_force;         // N, gravity and loads
  std::vector<Vec3> contact_force;          // N, particle–particle and projectile contact (contact systems)
  std::vector<double> damage;               // φ_i = 1 − n_i/N_i (Eq 19), from the end of the last step
  std::vector<double> break_extension;      // (1 + α_i φ_i) s_c,i δ_i from that damage, m (∞: unbreakable)
  std::vector<std::uint32_t> broken_bonds;  // N_i − n_i, written with damage (damage system)
  std::vector<BondEnd> bond_end;            // packed far-end view for the fused bond pass (bond_pass.cpp)
  // Per particle (only in peridynamic worlds with colliders): the deformation F = N K⁻¹ of its family
  // at the end of the last step, for particles with boundary faces near a collider; zero where not
  // computed or the family does not fit. The colliders place each boundary-face corner X at
  // y + F·(X − x) (surface_frames.cpp). Float: it only places contact geometry, to ~1e-7 of a tet size.
  std::vector<Eigen::Matrix3f> surface_frame;
  // Per particle (with WorldState::openable_faces): bit k set when face k of its tet is an open crack
  // face (its bond broke, OpenableFaces), from the bonds at the end of the last step; written with the
  // frame (surface_frames.cpp), read by the colliders, which meet those faces too.
  std::vector<std::uint8_t> open_faces;
  // Per particle (only in worlds with colliders): written by the colliders every step, read by kick_end
  // in the same step.
  std::vector<ColliderContact> collider_contact;
  // Health of the step: the lowest particle index whose position or velocity kick_end found non-finite
  // or whose speed exceeds StepSettings::max_speed, or kAllStable. Written by kick_end with the
  // velocity (part of the velocity component); World::step reads it after every step.
  static constexpr std::uint64_t kAllStable = ~std::uint64_t(0);
  std::uint64_t unstable_particle = kAllStable;
};

}  // namespace perifx
