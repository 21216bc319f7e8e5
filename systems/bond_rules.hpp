// Per-bond rules shared by the bond systems (dilatation, plasticity, elastic_force, fracture) and by
// their fused form (bond_pass.cpp). Each rule is one inline function, so the separate systems and the
// fused pass execute the same IEEE operations and produce the same bits (CMakeLists.txt passes
// -ffp-contract=off: no FMA contraction that could differ between call sites).
//
// Symmetry: every rule is evaluated from the two ends of a bond, by particle i's loop for bond
// k = i→j and by j's loop for its mirror m = j→i. The geometry (e, Λ, 1/|y_j − y_i|) is bit-symmetric
// (y_i − y_j is the exact negation of y_j − y_i, and so is ξ), and the per-side rules take the side's
// own constants as arguments, so "side j as seen from i" and "side j as seen from j" are the same
// call with the same arguments. That is what lets each particle own and update its own bond slots in
// place, with no atomics and no dependence on thread count.
#pragma once
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <type_traits>
#include <vector>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include "components/bonds.hpp"
#include "components/math.hpp"
#include "components/particles.hpp"
#include "components/world_state.hpp"

namespace perifx::systems {

// |ξ| = |x_j − x_i| of a bond, recomputed wherever it is needed: Bonds stores no reference length
// (components/bonds.hpp). Every caller uses this one expression, so a bond has the same |ξ| to the
// bit in every kernel and from both of its ends (x_i − x_j is the exact negation of x_j − x_i).
inline double reference_length(double dxx, double dxy, double dxz) {
  return std::sqrt(dxx * dxx + dxy * dxy + dxz * dxz);
}
inline double reference_length(const Vec3& xi) { return reference_length(xi.x(), xi.y(), xi.z()); }

// Weighted length of a bond side, ℓ_ij = |G_i ξ| (Eq 17; ω_ij = δ_i/ℓ_ij, Eq 5): |ξ| = r for the
// isotropic weight. The yield and break limits below scale with it. Evaluated as sqrt(ξᵀ M ξ) with
// M = GᵀG per particle (ParticleModel::anisotropy_metric): six gathered numbers instead of a 3×3
// matrix through the material table. Bit-symmetric: every term is a product of two components of ξ,
// unchanged to the bit when ξ is negated. The max guards a rounding below zero for a degenerate G.
inline AnisotropyMetric anisotropy_metric(const Mat3& g) {
  const Mat3 m = g.transpose() * g;
  return {m(0, 0), m(1, 1), m(2, 2), m(0, 1), m(0, 2), m(1, 2)};
}
inline double anisotropic_length(const AnisotropyMetric& m, double dxx, double dxy, double dxz) {
  const double diagonal = m.xx * dxx * dxx + m.yy * dxy * dxy + m.zz * dxz * dxz;
  const double mixed = m.xy * dxx * dxy + m.xz * dxx * dxz + m.yz * dxy * dxz;
  return std::sqrt(std::max(diagonal + 2.0 * mixed, 0.0));
}
// GᵀG of particle i, or the identity in an isotropic world (which stores none).
inline const AnisotropyMetric& particle_metric(const std::vector<AnisotropyMetric>& metric, std::size_t i) {
  static constexpr AnisotropyMetric kIdentity{1.0, 1.0, 1.0, 0.0, 0.0, 0.0};
  return metric.empty() ? kIdentity : metric[i];
}
template <bool kAnisotropic>
inline double weighted_length(const AnisotropyMetric& m, double r, double dxx, double dxy, double dxz) {
  if constexpr (kAnisotropic) return anisotropic_length(m, dxx, dxy, dxz);
  else return r;
}

// Both sides' weighted lengths of a bond and their reciprocals, for the kernels that need both sides
// (force, plasticity, fracture): one division, u = 1/(ℓ_ij ℓ_ji), gives 1/ℓ_ij = ℓ_ji u and
// 1/ℓ_ji = ℓ_ij u (the pass is bound by divisions and square roots). Still bit-symmetric: seen from
// j, the same two lengths are multiplied in the other order, which is exact. Isotropic: ℓ = r on both
// sides, and the reciprocals are not used (the isotropic 1/|ξ| enters with BondGeometry).
// kSharedMetric (a RowForm::shared_metric row: j's metric is i's, bit for bit): ℓ_ji is ℓ_ij, computed
// once and m_j not read; the same bits as computing it twice, since both are the same expression of the
// same numbers.
struct SideLengths {
  double ij, ji;                  // ℓ_ij, ℓ_ji, m
  double inverse_ij, inverse_ji;  // 1/ℓ_ij, 1/ℓ_ji, 1/m (anisotropic worlds only)
};
template <bool kAnisotropic, bool kSharedMetric = false>
inline SideLengths side_lengths(const AnisotropyMetric& m_i, const AnisotropyMetric& m_j, double r, double dxx,
                                double dxy, double dxz) {
  if constexpr (kAnisotropic && kSharedMetric) {
    const double l = anisotropic_length(m_i, dxx, dxy, dxz);
    const double u = 1.0 / (l * l);
    return {l, l, l * u, l * u};
  } else if constexpr (kAnisotropic) {
    const double l_ij = anisotropic_length(m_i, dxx, dxy, dxz), l_ji = anisotropic_length(m_j, dxx, dxy, dxz);
    const double u = 1.0 / (l_ij * l_ji);
    return {l_ij, l_ji, l_ji * u, l_ij * u};
  } else {
    return {r, r, 0.0, 0.0};
  }
}

// Influence ramp of the `corrected` model (systems/README.md §2.6): a bond side's weight is
// ω_ij = δ̃_i(|ξ|)/ℓ_ij with δ̃ = min(δ, (δ − |ξ|)/τ), full up to (1 − τ)δ and falling linearly to 0
// at the horizon. It is the partial volume of a neighbour near the horizon's edge: the force state of a
// bond is unchanged (yield and break tests read the unramped δ), only how much of the neighbour's
// volume counts. Without it the lattice's stiffness is a step function of δ (whole shells of
// neighbours enter at once; assets/report/accuracy.md §12.3). `paper` and `discrete` keep the sharp
// cut: δ̃ = δ bit for bit. With the ramp, a side slightly past its own horizon (family_build's 1e-9
// slack, or the far side of a bond between two horizons) gets weight 0, never a negative one.
inline constexpr double kInfluenceRampWidth = 0.3;  // τ, as a fraction of δ (§2.6)
// δ̃ = min(δ, max(δ − r, floor) · slope): with the ramp floor 0 and slope 1/τ; without it floor +∞,
// which gives min(δ, ∞) = δ exactly. Pure arithmetic on two loop-invariant numbers: a select on a
// flag here kept GCC 12 from vectorizing the bond loops (182 → 140 vectorized loops in bond_pass.cpp).
struct InfluenceRamp {
  double floor = kInfinity;
  double slope = 1.0;
};
inline InfluenceRamp influence_ramp(const WorldState& w) {
  if (w.settings.normalization != scene::Normalization::corrected) return {};
  return {0.0, 1.0 / kInfluenceRampWidth};
}
inline double ramped_horizon(double horizon, double r, const InfluenceRamp& ramp) {
  return std::min(horizon, std::max(horizon - r, ramp.floor) * ramp.slope);
}

// ω_ij = δ̃_i/ℓ_ij of particle i's bond with reference vector ξ (Eq 5, 17, with the ramp above), for
// code off the bond kernels' hot path (model constants, deformation fits, energy, virial stress).
inline double bond_weight(const WorldState& w, std::size_t i, const Vec3& xi) {
  const double r = reference_length(xi);
  const double l = w.any_anisotropic ? anisotropic_length(w.model.anisotropy_metric[i], xi.x(), xi.y(), xi.z()) : r;
  return ramped_horizon(w.model.horizon[i], r, influence_ramp(w)) / l;
}

// k_i = (a_i − b_i β_i)/c_i (Pa), the bulk coefficient of particle i's energy V_i k_i θ_i²: the elastic
// energy (elastic_force.cpp) and the stable-step bound that bounds it. Only where c_i > 0.
inline double bulk_energy_coefficient(const ParticleModel& md, std::size_t i) {
  return (0.25 * md.a4[i] - 0.25 * md.b4[i] * md.beta[i]) / md.dilatation_scale[i];
}

// The mirror j→i of particle i's bond k (binary search in j's sorted row). Setup code and tests only.
inline std::uint32_t mirror_bond(const Bonds& b, std::size_t i, std::size_t k) {
  const std::uint32_t j = b.neighbor[k];
  const auto first = b.neighbor.begin() + b.offsets[j], last = b.neighbor.begin() + b.offsets[j + 1];
  return static_cast<std::uint32_t>(std::lower_bound(first, last, static_cast<std::uint32_t>(i)) - b.neighbor.begin());
}
// Every bond's mirror index (length bonds; family_build.cpp), for setup passes and tests.
std::vector<std::uint32_t> mirror_bonds(const Bonds& b);

// Eq 7 for one bond: extension e = |y_j − y_i| − |ξ| and Λ = n·ξ/|ξ| (the cosine between the deformed
// and the reference bond). dy = y_j − y_i, dxi = ξ = x_j − x_i, r = |ξ|. One division serves
// 1/|y_j − y_i|, 1/(|y_j − y_i| |ξ|) and Λ (divisions and square roots bound the bond passes).
// Returns false for a collapsed bond (coincident particles: no direction, so no force, no plastic
// flow, no break).
struct BondGeometry {
  double extension;         // e, m
  double cosine;            // Λ
  double inverse_length;    // 1/|y_j − y_i|, 1/m
  double inverse_length_r;  // 1/(|y_j − y_i| |ξ|), 1/m²: with the isotropic weight ω = δ/|ξ|, the
                            // 1/|ξ| of both sides' ω comes in through this one factor
};
// Component form, branch-free so that it vectorizes: for a collapsed bond the outputs are not finite
// and the caller must mask them out with the returned flag.
inline bool bond_geometry(double dyx, double dyy, double dyz, double dxx, double dxy, double dxz, double r,
                          BondGeometry& g) {
  const double len = std::sqrt(dyx * dyx + dyy * dyy + dyz * dyz);
  const double inv_len_r = 1.0 / (len * r);
  g.inverse_length_r = inv_len_r;
  g.inverse_length = r * inv_len_r;
  g.extension = len - r;
  g.cosine = (dyx * dxx + dyy * dxy + dyz * dxz) * inv_len_r;
  return len > 0.0;
}
inline bool bond_geometry(const Vec3& dy, const Vec3& dxi, double r, BondGeometry& g) {
  return bond_geometry(dy.x(), dy.y(), dy.z(), dxi.x(), dxi.y(), dxi.z(), r, g);
}

// Scalar force state of one side of a bond, A = ω (Λ P + b4 (e − e^p)) (Eq 4 + Eq 12; Eq 8 with
// e^p = 0), with P = (a4 − b4 β) θ of that side's particle.
template <bool kPlastic>
inline double side_force_state(const BondGeometry& g, double weight, double plastic_extension, double p,
                               double b4) {
  const double e = kPlastic ? g.extension - plastic_extension : g.extension;
  return weight * (g.cosine * p + b4 * e);
}

// Paired force density of a bond, ½(A_ij + A_ji)/|y_j − y_i| · V_j (Eq 2–4, 8, 12 with the plastic
// extensions; elastic_force.cpp): multiplied by y_j − y_i it is the bond's force on particle i per
// unit V_i. The side weights come as force_weight forms them: anisotropic, ω_ij and ω_ji; isotropic,
// δ̃_i and δ̃_j (ramped_horizon), whose common 1/|ξ| enters with g.inverse_length_r (a multiplication,
// no division).
template <bool kAnisotropic>
inline double force_weight(double horizon, double inverse_length) {
  if constexpr (kAnisotropic) return horizon * inverse_length;
  else return horizon;
}
template <bool kAnisotropic, bool kPlastic>
inline double paired_force_density(const BondGeometry& g, double w_ij, double w_ji, double ep_ij, double ep_ji,
                                   double p_i, double b4_i, double p_j, double b4_j, double v_j) {
  const double a_ij = side_force_state<kPlastic>(g, w_ij, ep_ij, p_i, b4_i);
  const double a_ji = side_force_state<kPlastic>(g, w_ji, ep_ji, p_j, b4_j);
  return 0.5 * (a_ij + a_ji) * (kAnisotropic ? g.inverse_length : g.inverse_length_r) * v_j;
}

// Plasticity, Eq 11–16 with the consistent return of systems/README.md §3, for one side of a bond:
//   A_dev = k (e^d − e^p),  k = ω b4,  e^d = e − βθΛ                          (Eq 12, trial)
//   |A_dev| > A_c = √(2Ψ0):  e^p ← e^p + (A_dev − A_c sign A_dev)/k            (Eq 13–15)
//   e^p ← clamp(e^p, −γ, γ),  γ = cap                                           (Eq 16)
// Divided through by k: the bond yields when |e^d − e^p| exceeds the yield extension
// ε_y = A_c/k = A_c/(b4 ω) = Y ℓ with Y = A_c/(b4 δ) per particle, and then returns onto the yield
// surface, |e^d − e^p| = ε_y, by e^p ← e^p + (|e^d − e^p| − ε_y) sign(e^d − e^p) (no division per
// bond). ε_y = ∞ (Ψ0 = ∞) never yields; cap = 0 keeps e^p = 0 (plasticity off, Eq 16 as written).
inline double plastic_return(double deviatoric_extension, double plastic_extension, double yield_extension,
                             double cap) {
  const double elastic_part = deviatoric_extension - plastic_extension;
  // Written with max instead of a condition so that it compiles to a select: near the yield surface
  // a branch is taken at random, and the mispredictions dominated the bond pass. Inside the surface
  // the excess is exactly 0 and e^p is unchanged bit for bit (unloading is elastic).
  const double excess = std::max(std::abs(elastic_part) - yield_extension, 0.0);
  const double next = plastic_extension + std::copysign(excess, elastic_part);
  return std::min(std::max(next, -cap), cap);
}

// Fracture, Eq 18–19 as systems/README.md §5 reads them, for one side of a bond in tension (e > 0):
//   (e − e^p)/(|ξ| ω) > (1 + αφ) s_c   ⇔   e − e^p > B |ξ|/ℓ,   B = (1 + αφ) s_c δ
// (|ξ|/ℓ = 1 for the isotropic weight, so the test is (e − e^p)/δ > (1 + αφ) s_c). B is the
// particle's break extension, refreshed once per step from its damage; B = ∞ never breaks.
inline bool side_exceeds(double extension, double plastic_extension, double limit) {
  return extension - plastic_extension > limit;
}
template <bool kAnisotropic>
inline double break_limit(double break_extension, double r, double inverse_length) {
  if constexpr (kAnisotropic) return break_extension * (r * inverse_length);
  else return break_extension;
}

// Break extension of Eq 19 for a particle: (1 + α φ) s_c δ, ∞ for an unbreakable material.
// P_i = (a4_i − b4_i β_i) θ_i, the dilatational factor both ends of a bond need (dilatation.cpp). One
// expression, so a rank that receives θ over the network computes the same bits (engine/distributed).
inline double dilatation_coupling(const ParticleModel& md, std::size_t i, double theta) {
  return (md.a4[i] - md.b4[i] * md.beta[i]) * theta;
}

inline double break_extension(double critical_stretch, double damage_alpha, double damage, double horizon) {
  return std::isfinite(critical_stretch) ? (1.0 + damage_alpha * damage) * critical_stretch * horizon : kInfinity;
}

// The per-particle numbers one side of a bond needs for plasticity and fracture.
struct SideConstants {
  double beta_theta;       // β θ (e^d = e − βθΛ, Eq 12), m
  double yield_extension;  // Y (plastic_return), per unit weighted length
  double plastic_cap;      // γ/|ξ| (Eq 16)
  double horizon;          // δ, m
  double break_extension;  // B (side_exceeds), m
};
inline SideConstants side_constants(const ParticleModel& md, const ParticleState& s, std::size_t i) {
  return {md.beta[i] * s.dilatation[i], md.yield_extension[i], md.plastic_cap[i], md.horizon[i],
          s.break_extension[i]};
}
// The same numbers from the packed far-end copy (ParticleState::bond_end); bit-identical.
inline SideConstants side_constants(const BondEnd& e) {
  return {e.beta_theta, e.yield_extension, e.plastic_cap, e.horizon, e.break_extension};
}

// Plasticity of one side of bond k (this step's e, Λ; the side's weighted length ℓ and e^p): the new e^p.
inline double side_plastic_extension(const BondGeometry& g, double r, double length, double plastic_extension,
                                     const SideConstants& c) {
  return plastic_return(g.extension - c.beta_theta * g.cosine, plastic_extension, c.yield_extension * length,
                        c.plastic_cap * r);
}

// Fracture of one side of bond k with that side's 1/ℓ (SideLengths) and (new) e^p; `scale` is the
// bond's break multiplier (Bonds::break_scale: weak planes, 1 elsewhere, which leaves the limit
// unchanged bit for bit).
template <bool kAnisotropic>
inline bool side_breaks(const BondGeometry& g, double r, double inverse_length, double plastic_extension,
                        const SideConstants& c, double scale) {
  return side_exceeds(g.extension, plastic_extension,
                      break_limit<kAnisotropic>(c.break_extension, r, inverse_length) * scale);
}

// Lane-strided visit of a family's bonds [begin, end): chunks of kBondLanes consecutive bonds, bond
// begin + c·kBondLanes + l on lane l. The per-bond work of a chunk is independent across lanes, so
// the compiler runs a chunk as one SIMD pass (gathers for the neighbour data); sums over the family
// are kept per lane and added in lane order at the end (sum_lanes). That order is fixed by this code,
// not by the compiler or the thread count, so results stay bit-reproducible; the tail chunk runs the
// same lane function in scalar form. (An 8-lane SIMD chunk for a 16-lane tail of 8 or more was tried:
// GCC 12 called the lane function out of line in that loop, so it ran no faster; removed.)
//   lane(k, l, alive_k):  the bond's work; alive_k is its alive flag (0 or 1) as a 64-bit integer:
//                         byte-wide values in the SIMD loop would force 16+ lanes per vector.
//   finish(k, n):         after the chunk of n bonds starting at k (scalar; e.g. writes the flags).
//   gather(k, n):         before the chunk (for_each_gathered_bond_lane): moves the chunk's neighbour
//                         data into the kernel's lane arrays (bond_gather.hpp); n is kBondLanes or
//                         the tail's count.
//
// The lane count is the SIMD width the loop gets. GCC 12 picks the loop's vector size from its
// narrowest element (the 32-bit neighbour index, the float e^p): with 8 lanes that is 8 × 32 bits,
// so the doubles ran as two 256-bit halves even on CPUs with 512-bit registers, and the loop was
// never vectorized wider (asking with -mprefer-vector-width=512 changes nothing). With AVX-512, 16
// lanes make each double a 512-bit pair and each 32-bit stream one 512-bit vector: on the Zen 5 VM
// the bond pass at 3e5 particles took 343 → 265 ms, the anisotropic one 392 → 265, the held
// rotations 51 → 35 (bench/README.md, "16 lanes with AVX-512"). The lane count fixes the summation
// order, so a build with AVX-512 and one without round differently in the last bits; within one
// build the results are the same for any thread and rank count.
#if defined(__AVX512F__)
inline constexpr int kBondLanes = 16;
#else
inline constexpr int kBondLanes = 8;
#endif
// Dead chunks: a kernel whose broken bonds add exactly nothing (dilatation, force, bond pass, the
// alive-only family fits) passes DeadChunks::skip, and a chunk whose bonds are all broken is then
// neither gathered nor computed. The same bits as visiting it: such a lane adds a selected +0.0 (or a
// product with 0.0) to a per-lane sum that starts at +0.0, and x + (±0.0) = x for every x that is not
// −0.0, which a sum started at +0.0 never is (round to nearest gives −0.0 only for −0.0 + −0.0). Why:
// a shattered body keeps its broken bonds in the rows (the embedded mesh fits read them), and the
// families of fragments and of particles beside a crack lose whole Morton-ordered runs of neighbours.
// A kernel that reads broken bonds too (the all-bonds family fits) passes DeadChunks::visit.
enum class DeadChunks { visit, skip };
// True when the n flags at `alive` are all 0 (n ≤ kBondLanes).
inline bool all_broken(const std::uint8_t* alive, int n) {
  if (n == kBondLanes) {
    std::uint64_t words[kBondLanes / 8];
    std::memcpy(words, alive, kBondLanes);
    std::uint64_t any = 0;
    for (int w = 0; w < kBondLanes / 8; ++w) any |= words[w];
    return any == 0;
  }
  for (int l = 0; l < n; ++l)
    if (alive[l]) return false;
  return true;
}
// One full chunk [k, k + kBondLanes) as SIMD, lanes below first_lane given flag 0 (the overlapped tail
// below; 0 for an ordinary chunk).
template <class Lane>
[[gnu::always_inline]] inline void run_bond_chunk(std::size_t k, const std::uint8_t* alive, int first_lane, Lane& lane) {
#if defined(__AVX512F__)
  // The flags widened to one 64-bit word per lane before the loop: read as words[l >> 3] >> …
  // from two words, GCC 12 made the 16-lane loop load them with a hardware gather. Lanes below
  // first_lane are zeroed in the flag bytes before widening (scalar stores into the array would stall
  // the lane loop's vector loads of it; the widening's own zero mask made GCC 12 fail, an internal
  // compiler error).
  alignas(64) std::uint64_t flags[kBondLanes];
  for (int g = 0; g < kBondLanes; g += 8) {
    std::uint64_t bytes;
    std::memcpy(&bytes, alive + k + g, 8);
    const int below = first_lane - g;  // lanes of this group to zero
    if (below >= 8) bytes = 0;
    else if (below > 0) bytes &= ~std::uint64_t{0} << (8 * below);
    _mm512_store_si512(flags + g, _mm512_cvtepu8_epi64(_mm_cvtsi64_si128(static_cast<long long>(bytes))));
  }
#pragma omp simd
  for (int l = 0; l < kBondLanes; ++l) lane(k + static_cast<std::size_t>(l), l, flags[l]);
#else
  std::uint64_t words[(kBondLanes + 7) / 8] = {};
  std::memcpy(words, alive + k, kBondLanes);
  for (int w = 0; w < (kBondLanes + 7) / 8; ++w) {
    const int below = first_lane - 8 * w;  // lanes of this word to zero
    if (below >= 8) words[w] = 0;
    else if (below > 0) words[w] &= ~std::uint64_t{0} << (8 * below);
  }
#pragma omp simd
  for (int l = 0; l < kBondLanes; ++l)
    lane(k + static_cast<std::size_t>(l), l, (words[l >> 3] >> (8 * (l & 7))) & 0xffu);
#endif
}
// The tail of a family (its last end − begin mod kBondLanes bonds) with DeadChunks::skip, in a family
// of at least kBondLanes bonds, runs as one more SIMD chunk: the family's last kBondLanes bonds, the
// ones already visited given flag 0. That is exactly what a skip kernel does with a broken bond (adds
// nothing), and the tail's bonds come on lanes kBondLanes − tail … kBondLanes − 1. Why: a scalar tail
// runs each bond's divisions, square roots and loads alone; on the 3e5 bench body (152 bonds per family,
// a tail of 7.5 on average) the fused bond pass took 255 → 244 ms with this. The contract this adds for a skip
// kernel: for a lane with flag 0 it may write only what it read (the bond pass stores a bond's e^p
// back unchanged), since such a bond may be visited twice. A visit kernel (which reads every bond)
// keeps the scalar tail.
template <class Gather, class Lane, class Finish>
inline void for_each_gathered_bond_lane(std::size_t begin, std::size_t end, const std::uint8_t* alive, Gather gather,
                                        Lane lane, Finish finish, DeadChunks dead) {
  static_assert(std::endian::native == std::endian::little, "alive flags are unpacked from a little-endian word");
  // std::size_t indices: with 32-bit ones the compiler must allow for wrap-around and cannot treat
  // k + l as a plain address stream. `lane` is taken by value so its captures are locals.
  const bool skip_dead = dead == DeadChunks::skip;
  std::size_t k = begin;
  // One call site of the SIMD chunk for the full chunks and the overlapped tail: a second copy of the
  // lane loop grows the kernel past GCC's inlining limits (bench/README.md, "Tried and not kept").
  for (;; k += kBondLanes) {
    std::size_t first = k;
    int masked = 0;
    if (k + kBondLanes <= end) {
      if (skip_dead && all_broken(alive + k, kBondLanes)) continue;
    } else if (skip_dead && k > begin && k < end && !all_broken(alive + k, static_cast<int>(end - k))) {
      first = end - kBondLanes;  // overlapped tail
      masked = static_cast<int>(k - first);
    } else {
      break;
    }
    gather(first, kBondLanes);
    run_bond_chunk(first, alive, masked, lane);
    finish(first, kBondLanes);
    if (masked) return;
  }
  const int tail = static_cast<int>(end - k);
  if (tail == 0 || (skip_dead && all_broken(alive + k, tail))) return;
  gather(k, tail);
  for (int l = 0; l < tail; ++l) lane(k + static_cast<std::size_t>(l), l, std::uint64_t{alive[k + l]});
  finish(k, tail);
}
template <class Lane, class Finish>
inline void for_each_bond_lane(std::size_t begin, std::size_t end, const std::uint8_t* alive, Lane lane,
                               Finish finish, DeadChunks dead) {
  for_each_gathered_bond_lane(begin, end, alive, [](std::size_t, int) {}, lane, finish, dead);
}
template <class T>
inline T sum_lanes(const T (&lanes)[kBondLanes]) {
  T total = lanes[0];
  for (int l = 1; l < kBondLanes; ++l) total += lanes[l];
  return total;
}

// The bond arrays (components/bonds.hpp, CSR) and the per-particle numbers every bond kernel reads,
// as raw streams, unpacked here once for dilatation.cpp, elastic_force.cpp and bond_pass.cpp. Raw
// pointers, so that a kernel can copy them into its task's locals: a store through a uint8_t* (alive)
// may alias anything in memory (char aliasing), and pointers the compiler had to read from memory
// would be reloaded after every such store. kMutable gives writable e^p and alive streams (the bond
// pass). Shapes: offsets particles + 1; neighbor, alive, plastic, plastic_mirror, break_scale one
// entry per directed bond k (CSR: particle i owns [offsets[i], offsets[i+1]); plastic and
// break_scale null when the world has none); y and x 3 doubles per particle (current and reference
// positions, x y z); horizon, the anisotropy metric GᵀG and the packed reference point per particle.
template <bool kMutable>
struct BondStreams {
  using Plastic = std::conditional_t<kMutable, float, const float>;
  using Flag = std::conditional_t<kMutable, std::uint8_t, const std::uint8_t>;
  const std::uint32_t* offsets;
  const std::uint32_t* neighbor;
  Plastic* plastic;         // e^p_ij
  Plastic* plastic_mirror;  // e^p_ji (Bonds::plastic_extension_mirror)
  Flag* alive;
  const double* y;
  const double* x;
  const float* break_scale;  // Bonds::break_scale (null: 1 for every bond)
  const double* horizon;     // δ per particle
  const AnisotropyMetric* metric;  // GᵀG per particle (null in an isotropic world)
  const ReferencePoint* reference;  // x and V per particle, packed (ParticleModel::reference_point)

  // Particle i's end of its bonds, in component form. A lane then forms its bond's vectors as
  // dy = y[3j + c] − o.y_c and ξ = x[3j + c] − o.x_c in the kernel's own body: returned from a helper
  // (a struct or output references), the same arithmetic compiled the plastic bond pass with ~35 more
  // register moves per particle (GCC 12; the SIMD bond loop itself unchanged), so it stays written out.
  struct Origin {
    double yx, yy, yz, xx, xy, xz;
  };
  Origin origin(std::size_t i) const {
    return {y[3 * i], y[3 * i + 1], y[3 * i + 2], x[3 * i], x[3 * i + 1], x[3 * i + 2]};
  }
  // GᵀG of particle i's material (Eq 17). An isotropic world stores none; there the identity stands
  // in, which weighted_length<false> never reads. Chosen at compile time: a run-time choice would be a
  // masked gather, which kept GCC 12 from vectorizing the bond loop.
  template <bool kAnisotropic>
  const AnisotropyMetric& anisotropy(std::size_t i) const {
    static constexpr AnisotropyMetric kIdentity{1.0, 1.0, 1.0, 0.0, 0.0, 0.0};
    if constexpr (kAnisotropic) return metric[i];
    else return kIdentity;
  }
};
// From a world (writable streams) or a const world (read-only), with positions y.
template <class World>
inline BondStreams<!std::is_const_v<World>> bond_streams(World& w, const std::vector<Vec3>& y) {
  static_assert(std::is_same_v<std::remove_const_t<World>, WorldState>);
  auto& b = w.bonds;
  return {b.offsets.data(),
          b.neighbor.data(),
          b.plastic_extension.empty() ? nullptr : b.plastic_extension.data(),
          b.plastic_extension_mirror.empty() ? nullptr : b.plastic_extension_mirror.data(),
          b.alive.data(),
          y.data()->data(),
          w.particles.reference_position.data()->data(),
          b.break_scale.empty() ? nullptr : b.break_scale.data(),
          w.model.horizon.data(),
          w.model.anisotropy_metric.data(),
          w.model.reference_point.data()};
}

// Runtime model flags to template flags, written once for every bond kernel: calls
// kernel(std::bool_constant<f_1>{}, ..., std::bool_constant<f_n>{}) for the runtime values f_1..f_n
// (e.g. any_anisotropic, any_plastic, any_fracture), so each combination is its own instantiation
// with the branches on the flags compiled out. Returns what the kernel returns.
namespace detail {
template <bool... kSet, class Kernel>
inline decltype(auto) dispatch_flags(Kernel& kernel) {
  return kernel(std::bool_constant<kSet>{}...);
}
template <bool... kSet, class Kernel, class... Rest>
inline decltype(auto) dispatch_flags(Kernel& kernel, bool flag, Rest... rest) {
  if (flag) return dispatch_flags<kSet..., true>(kernel, rest...);
  return dispatch_flags<kSet..., false>(kernel, rest...);
}
}  // namespace detail
template <class Kernel, class... Flags>
inline decltype(auto) dispatch_flags(Kernel&& kernel, Flags... flags) {
  return detail::dispatch_flags<>(kernel, static_cast<bool>(flags)...);
}

// The form of particle i's row (ParticleModel::anisotropic_family) in an anisotropic world. An empty
// array (a world built by hand, never marked) takes the general anisotropic form, which is right for
// every row.
inline RowForm row_form(const std::vector<std::uint8_t>& anisotropic_family, std::size_t i) {
  return anisotropic_family.empty() ? RowForm::anisotropic : static_cast<RowForm>(anisotropic_family[i]);
}

// What dispatch_row hands a row: value is kAnisotropic (so decltype(form)::value reads as a flag), and
// shared_metric says every neighbour's metric is the particle's own (side_lengths' kSharedMetric).
template <bool kAnisotropic, bool kSharedMetric = false>
struct RowFormTag : std::bool_constant<kAnisotropic> {
  static constexpr bool shared_metric = kSharedMetric;
};

// Particle i's row of a bond kernel in the anisotropic form only where it is needed: calls row(tag)
// with a RowFormTag for i's RowForm in an anisotropic world, and the isotropic tag otherwise. For a
// particle of an isotropic body the two forms differ in rounding only (1/ℓ from ℓ_ij ℓ_ji instead of
// 1/|ξ|), and the isotropic one skips two weighted lengths and a division per bond: in fig01's walls,
// one of them anisotropic, the isotropic wall ran the anisotropic form. Every bond joins two
// particles of the same form family, so both of its ends use the same form (bond_rules.hpp's
// symmetry holds); a shared-metric row gives the same bits as the general anisotropic form.
// kReadsFarMetric false: the kernel reads no neighbour's metric (the dilatation, whose ℓ is i's own
// side only), so shared-metric rows take the general form's code and the row is instantiated twice,
// not three times.
template <bool kAnisotropicWorld, bool kReadsFarMetric = true, class Row>
inline void dispatch_row(const std::vector<std::uint8_t>& anisotropic_family, std::size_t i, Row&& row) {
  if constexpr (kAnisotropicWorld) {
    switch (row_form(anisotropic_family, i)) {
      case RowForm::shared_metric:
        if constexpr (kReadsFarMetric) {
          row(RowFormTag<true, true>{});
          return;
        }
        [[fallthrough]];
      case RowForm::anisotropic: row(RowFormTag<true>{}); return;
      case RowForm::isotropic: break;
    }
  }
  row(RowFormTag<false>{});
}

// Whether particle i's row takes an anisotropic form, as a run-time flag (scalar code off the bond
// kernels' hot path, e.g. fracture.cpp; the same choice as dispatch_row).
inline bool anisotropic_row(const WorldState& w, std::size_t i) {
  return w.any_anisotropic && row_form(w.model.anisotropic_family, i) != RowForm::isotropic;
}

// Eq 19's damage of a particle from its bond counts: φ = 1 − n/N, and broken = N − n.
inline void store_damage(double& damage, std::uint32_t& broken, std::uint32_t initial, std::uint32_t alive) {
  damage = initial ? 1.0 - double(alive) / double(initial) : 0.0;
  broken = initial - alive;
}

}  // namespace perifx::systems
