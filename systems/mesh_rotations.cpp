// Held rotations system (systems/README.md §6.5): the step state behind VertexMotion::deformation's
// fallback. A particle whose alive family cannot give a deformation gradient (fewer than 4 alive
// bonds, or the shape tensor K ill-conditioned; family_fits below) moves its vertices rigidly with a
// held rotation R_p, and R_p must follow the particle every step, not only when the mesh is read:
// otherwise the surface would depend on how often it is read.
// Per particle p, every step, only for "tracked" particles (a fallback family, or at least one broken
// bond: the only ones that are or may become fallback; intact particles with a good family are skipped
// at the cost of one byte and one counter test):
//   K = Σ ω ξ⊗ξ V_j,  N = Σ ω η⊗ξ V_j over the alive bonds (as mesh_vertices.cpp);
//   family fits     → S_p ← N K⁻¹, or its rotation if badly stretched or inverted (the frame pass's F_p);
//   family too poor → S_p ← rotation of N + μ R_old, μ = 1e-3 tr K, R_old = rotation of S_p of the
//                     last step (R_old itself when p has no alive bond): regularized Kabsch.
// A particle tracked for the first time was intact at the previous step, so its R_old is the rotation
// of F over its whole original family at the current positions.
// Whether a family fits depends only on its alive set (K is built from reference quantities), which
// changes only when one of its bonds breaks. So a tracked particle is evaluated in full only in a step
// where its broken-bond count changed; otherwise a fitting one refreshes S_p only every
// kRefreshSteps steps (staggered by index: p ≡ step mod kRefreshSteps), since S_p serves only as R_old
// at the step its family stops fitting, and a poor one with no alive bond keeps S_p (a lone particle
// keeps its rotation). Only poor families with alive bonds turn every step. In shattered glass most
// particles are tracked and fit, and evaluating all of them every step took 30–45 % of the step.
// S_p (EmbeddedMesh::held_deformation) is part of the state (checkpointed); the per-frame vertex pass
// (mesh_vertices.cpp) reads it for the fallback particles and is otherwise a pure function of the state.
// Cost per step: bonds of the tracked particles with new breaks or a poor family, and of 1/kRefreshSteps
// of the other tracked ones (two outer products each); nothing for intact ones.
// Parallel over particles, each writes its own S_p: deterministic for any thread count.
// Reads:  position, bond_alive, damage (broken_bonds), mesh.   Writes: mesh (held_deformation, held_tracked).
#include <algorithm>

#include "bond_rules.hpp"
#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {

bool family_fits(const Mat3& K, std::uint32_t alive) {
  // K's scale is Σ ω V |ξ|²; the condition test is scale-free (‖K‖²‖K⁻¹‖² ≤ 1e8 with ‖I‖² = 3).
  return alive >= 4 && K.determinant() > 0.0 && K.squaredNorm() * K.inverse().squaredNorm() <= 1e8;
}

bool deformation_conditioned(const Mat3& F) {
  const double det = F.determinant();
  if (!(det > 0.0)) return false;
  return F.squaredNorm() <= 12.0 && F.inverse().squaredNorm() <= 12.0;
}

bool fitted_deformation(const Mat3& K, const Mat3& N, std::uint32_t alive, Mat3& F) {
  if (!family_fits(K, alive)) return false;
  const Mat3 fit = N * K.inverse();
  F = deformation_conditioned(fit) ? fit : polar_rotation(fit);
  return true;
}

std::uint32_t family_sums(const WorldState& w, std::size_t p, bool alive_only, Mat3& K, Mat3& N) {
  const Bonds& b = w.bonds;
  const auto& x = w.particles.reference_position;
  const auto& y = w.particles.position;
  const auto& vol = w.particles.volume;
  K.setZero();
  N.setZero();
  std::uint32_t n = 0;
  for (std::uint32_t k = b.offsets[p], end = b.offsets[p + 1]; k < end; ++k) {
    if (alive_only && !b.alive[k]) continue;
    const std::uint32_t j = b.neighbor[k];
    const Vec3 xi = x[j] - x[p];
    const Vec3 wxi = (bond_weight(w, p, xi) * vol[j]) * xi;
    K += wxi * xi.transpose();
    N += (y[j] - y[p]) * wxi.transpose();
    ++n;
  }
  return n;
}

namespace {

constexpr std::uint64_t kRefreshSteps = 8;

void step_particle(WorldState& w, std::size_t p) {
  EmbeddedMesh& e = w.embedded;
  Mat3 K, N;
  const std::uint32_t alive = family_sums(w, p, true, K, N);
  Mat3& S = e.held_deformation[p];
  e.held_broken_seen[p] = w.state.broken_bonds.empty() ? 0 : w.state.broken_bonds[p];
  if (fitted_deformation(K, N, alive, S)) {
    e.held_tracked[p] = 1;
    e.held_fits[p] = 1;
    return;
  }
  e.held_fits[p] = 0;
  Mat3 held;
  if (e.held_tracked[p]) {
    held = polar_rotation(S);
  } else {  // intact (with a good family) until this step: the whole original family's rotation
    Mat3 Ka, Na;
    const std::uint32_t all = family_sums(w, p, false, Ka, Na);
    held = family_fits(Ka, all) ? polar_rotation(Na * Ka.inverse()) : Mat3::Identity();
  }
  const double mu = 1e-3 * std::max(K.trace(), 0.0);
  S = alive > 0 && mu > 0.0 ? polar_rotation(N + mu * held) : held;
  e.held_tracked[p] = 1;
}

// K = Σ ω V ξξᵀ over p's alive bonds and their count, for set-up's fit test: lane-strided
// (bond_rules.hpp) so that it runs as SIMD; as a scalar Eigen loop it was 9 % of a 9e5-particle set-up's
// CPU. The summation order differs from family_sums, so K can differ in its last bits; it only decides
// whether a family fits (a condition number against 1e4), never a position.
template <bool kAnisotropic>
std::uint32_t alive_shape_tensor(const WorldState& w, std::size_t p, Mat3& K) {
  const auto bs = bond_streams(w, w.particles.reference_position);
  const double* const volume = w.particles.volume.data();
  const auto o = bs.origin(p);
  const AnisotropyMetric& g_p = bs.template anisotropy<kAnisotropic>(p);
  double xx[kBondLanes] = {}, yy[kBondLanes] = {}, zz[kBondLanes] = {}, xy[kBondLanes] = {}, xz[kBondLanes] = {},
         yz[kBondLanes] = {};
  double count[kBondLanes] = {};  // exact: integers far below 2^53
  // ω = δ̃_p/ℓ with the influence ramp (bond_rules.hpp), the weight family_sums uses through bond_weight,
  // so the test judges the K the fit will use.
  const double delta = w.model.horizon[p];
  const InfluenceRamp ramp = influence_ramp(w);
  // A dead bond's weight is multiplied by 0.0, not selected away: a select around the gather of V_j
  // kept GCC 12 from vectorizing the loop (it ran scalar, 7 % of a 9e5-particle set-up's CPU). V_j/ℓ is
  // finite and positive, so the product is +0.0 and K has the same bits.
  auto lane = [=, &xx, &yy, &zz, &xy, &xz, &yz, &count, &g_p](std::size_t k, int l, std::uint64_t is_alive) {
    const std::size_t j = bs.neighbor[k];
    const double dxx = bs.x[3 * j] - o.xx, dxy = bs.x[3 * j + 1] - o.xy, dxz = bs.x[3 * j + 2] - o.xz;
    const double r = reference_length(dxx, dxy, dxz);
    const double alive = static_cast<double>(is_alive != 0);
    const double weight =
        volume[j] * ramped_horizon(delta, r, ramp) / weighted_length<kAnisotropic>(g_p, r, dxx, dxy, dxz) * alive;
    xx[l] += weight * dxx * dxx, yy[l] += weight * dxy * dxy, zz[l] += weight * dxz * dxz;
    xy[l] += weight * dxx * dxy, xz[l] += weight * dxx * dxz, yz[l] += weight * dxy * dxz;
    count[l] += alive;
  };
  for_each_bond_lane(bs.offsets[p], bs.offsets[p + 1], bs.alive, lane, [](std::size_t, int) {});
  K << sum_lanes(xx), sum_lanes(xy), sum_lanes(xz), sum_lanes(xy), sum_lanes(yy), sum_lanes(yz), sum_lanes(xz),
      sum_lanes(yz), sum_lanes(zz);
  return static_cast<std::uint32_t>(sum_lanes(count));
}

}  // namespace

void init_held_rotations(WorldState& w) {
  EmbeddedMesh& e = w.embedded;
  const std::size_t np = w.particles.count();
  e.held_deformation.assign(np, Mat3::Identity());
  e.held_tracked.assign(np, 0);
  e.held_fits.assign(np, 0);                   // unknown: the first evaluation is a full one
  e.held_broken_seen.assign(np, ~std::uint32_t{0});
  // Particles whose family does not fit from the start (thin sheets, lone particles) or that already
  // have a dead bond (initial cracks) are tracked from the start, holding the identity (the reference
  // configuration). So an untracked particle always had every listed bond alive at the last step.
  dispatch_flags([&](auto aniso) {
    constexpr bool kAnisotropic = decltype(aniso)::value;
    parallel_for_each(np, [&](std::size_t p) {
      Mat3 K;
      const std::uint32_t alive = alive_shape_tensor<kAnisotropic>(w, p, K);
      const std::uint32_t listed = w.bonds.offsets[p + 1] - w.bonds.offsets[p];
      if (alive < listed || !family_fits(K, alive)) e.held_tracked[p] = 1;
    }, 256);
  }, w.any_anisotropic);
}

void update_held_rotations(WorldState& w) {
  EmbeddedMesh& e = w.embedded;
  // A distributed run's local world has no tets but steps the held rotations of its particles.
  if (e.motion != VertexMotion::deformation || (e.tets.empty() && e.held_deformation.empty())) return;
  const std::size_t np = w.particles.count();
  if (e.held_deformation.size() != np) init_held_rotations(w);
  const auto& broken = w.state.broken_bonds;
  const auto& initial = w.bonds.initial_count;
  const bool counted = broken.size() == np && initial.size() == np;
  const std::uint64_t phase = w.clock.step % kRefreshSteps;
  parallel_for_each(np, [&](std::size_t p) {
    if (!w.owns(p)) return;  // a distributed run's ghost: its owner steps it
    if (!e.held_tracked[p] && !(counted && broken[p] > 0)) return;  // intact, family fits
    if (counted && broken[p] == e.held_broken_seen[p]) {  // alive set unchanged since the last evaluation
      // S_p is only R_old: refreshed in turn, by whole-world index (a distributed run's local index differs)
      const std::size_t turn = w.global_index.empty() ? p : w.global_index[p];
      if (e.held_fits[p] && turn % kRefreshSteps != phase) return;
      if (!e.held_fits[p] && broken[p] >= initial[p]) return;     // no alive bond: keeps its rotation
    }
    step_particle(w, p);
  }, 256);
}

SystemDecl mesh_rotation_system(WorldState& w) {
  return {"mesh_rotations",
          {Component::position, Component::bond_alive, Component::damage, Component::mesh},
          {Component::mesh},
          [&w] { update_held_rotations(w); }};
}

}  // namespace perifx::systems
