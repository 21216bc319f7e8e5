// Held rotations system (systems/README.md §6.5): the step state behind VertexMotion::deformation's
// fallback. A particle whose alive family cannot give a deformation gradient (fewer than 4 alive
// bonds, or the shape tensor K ill-conditioned; family_fits below) moves its vertices rigidly with a
// held rotation R_p, and R_p must follow the particle as it steps, not only when the mesh is read:
// otherwise the surface would depend on how often it is read.
// Per particle p, in steps as below, only for "tracked" particles (a fallback family, or at least one broken
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
// where its broken-bond count changed; otherwise it refreshes S_p only every kRefreshSteps steps
// (staggered by index: p ≡ step mod kRefreshSteps), and a poor one with no alive bond keeps S_p (a lone
// particle keeps its rotation). A fitting family's S_p serves only as R_old at the step its family
// stops fitting. A poor family's S_p is the rendered rotation and its own next prior: refreshed every
// kRefreshSteps steps it lags the piece by at most kRefreshSteps − 1 steps (7 µs at the glass walls'
// step: 7e-3 rad for a fragment spinning at 1e3 rad/s), and the prior's weight
// (μ = 1e-3 tr K) makes the fit depend on that lag only through μ. Still the same for any read rate
// and thread count. In shattered glass most particles are tracked, and evaluating every tracked one
// every step took 30–45 % of the step; poor families turning every step were still 61 % of the
// evaluations in the glass-wall preview.
// S_p (EmbeddedMesh::held_deformation) is part of the state (checkpointed); the per-frame vertex pass
// (mesh_vertices.cpp) reads it for the fallback particles and is otherwise a pure function of the state.
// Cost per step: bonds of the tracked particles with new breaks, and of 1/kRefreshSteps of the other
// tracked ones (two outer products each); nothing for intact ones.
// Parallel over particles, each writes its own S_p: deterministic for any thread count.
// Reads:  position, bond_alive, damage (broken_bonds), mesh.   Writes: mesh (held_deformation, held_tracked).
#include <algorithm>

#include <Eigen/Eigenvalues>

#include "bond_gather.hpp"
#include "bond_rules.hpp"
#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {

bool family_fits(const Mat3& K, std::uint32_t alive) {
  // K's scale is Σ ω V |ξ|²; the condition test is scale-free (‖K‖²‖K⁻¹‖² ≤ 1e8 with ‖I‖² = 3).
  return alive >= 4 && K.determinant() > 0.0 && K.squaredNorm() * K.inverse().squaredNorm() <= 1e8;
}

Vec3 angular_velocity(const Mat3& inertia, const Vec3& momentum) {
  Eigen::SelfAdjointEigenSolver<Mat3> eig(inertia);
  const Vec3 lambda = eig.eigenvalues();
  const double largest = lambda.cwiseAbs().maxCoeff();
  if (!(largest > 0.0)) return Vec3::Zero();
  Vec3 w = Vec3::Zero();
  for (int k = 0; k < 3; ++k)
    if (lambda[k] > 1e-9 * largest) {
      const Vec3 e = eig.eigenvectors().col(k);
      w += e * (e.dot(momentum) / lambda[k]);
    }
  return w;
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

namespace {

// The family sums of particle p, lane-strided (bond_rules.hpp: for_each_bond_lane) so that they run as
// SIMD; as scalar Eigen loops the vertex pass took 4.1× and the held rotations 2.4–3.3× as long at 3e5
// particles (bench/README.md, "The family sums as SIMD"):
//   K  = Σ ω V_j ξ⊗ξ,  N = Σ ω V_j η⊗ξ (η = y_j − y_p; kN),  Ṅ = Σ ω V_j (v_j − v_p)⊗ξ (kRate),
// and with Ṅ the first moments Σ ω V_j, Σ ω V_j ξ, Σ ω V_j η, Σ ω V_j (v_j − v_p) (FamilyMoments),
// ω = δ̃_p/ℓ with the influence ramp (bond_rules.hpp: bond_weight's weight), over p's alive bonds or all.
// A bond left out is multiplied by 0.0, not selected away: a select around the gathers kept GCC 12 from
// vectorizing the loop. Its terms are finite (V_j/ℓ > 0, positions finite), so the sums have the same
// bits as if it were skipped. Per-lane sums added in lane order: the same bits for any thread count.
// kRobust (with kN): each bond's weight times s²|ξ|² / (s²|ξ|² + |η − c − F ξ|²), (c, F) = `prior`,
// s = robust_residual_scale.
template <bool kAnisotropic, bool kN, bool kRate, bool kRobust = false>
std::uint32_t family_tensors(const WorldState& w, std::size_t p, bool alive_only, Mat3& K, Mat3* N, Mat3* Nd,
                             FamilyMoments* moments, const FamilyFit* prior = nullptr) {
  static_assert(kN || !kRobust);
  const auto bs = bond_streams(w, w.particles.position);
  const double* const v = w.particles.velocity.data()->data();
  const auto o = bs.origin(p);
  const double vx = kRate ? v[3 * p] : 0.0, vy = kRate ? v[3 * p + 1] : 0.0, vz = kRate ? v[3 * p + 2] : 0.0;
  const AnisotropyMetric& g_p = bs.template anisotropy<kAnisotropic>(p);
  const double delta = w.model.horizon[p];
  const InfluenceRamp ramp = influence_ramp(w);
  const std::uint64_t keep_dead = alive_only ? 0 : 1;
  // K symmetric (6), N and Ṅ (9 each), row-major: n[3a + b] = Σ ω V η_a ξ_b.
  double k6[6][kBondLanes] = {}, n9[9][kBondLanes] = {}, r9[9][kBondLanes] = {}, count[kBondLanes] = {};
  // First moments (kRate): Σ ω V, then Σ ω V ξ, η, v_j − v_p by component.
  double m10[10][kBondLanes] = {};
  double pc[3] = {}, pf[9] = {};  // the prior fit (kRobust), F row-major
  if constexpr (kRobust)
    for (int a = 0; a < 3; ++a) {
      pc[a] = prior->offset[a];
      for (int b = 0; b < 3; ++b) pf[3 * a + b] = prior->gradient(a, b);
    }
  constexpr double s2 = robust_residual_scale * robust_residual_scale;
  // The chunk's far ends in lane order (bond_gather.hpp: positions by load + transpose).
  ChunkPositions cp;
  alignas(64) double cv[3][kBondLanes];
  auto gather = [&](std::size_t k, int n) {
    gather_positions(bs.y, bs.reference, bs.neighbor + k, n, cp);
    if constexpr (kRate)
      for (int l = 0; l < n; ++l) {
        const std::size_t j = 3 * std::size_t(bs.neighbor[k + static_cast<std::size_t>(l)]);
        cv[0][l] = v[j], cv[1][l] = v[j + 1], cv[2][l] = v[j + 2];
      }
  };
  // Always inlined: grown by the moments and the residual weight, GCC 12 stopped inlining it, and the
  // lane loop then ran scalar (the per-frame vertex pass took 4× as long).
  auto lane = [=, &k6, &n9, &r9, &m10, &count, &g_p, &cp, &cv, &pc, &pf](
                  std::size_t, int l, std::uint64_t is_alive) __attribute__((always_inline)) {
    const double dx[3] = {cp.xx[l] - o.xx, cp.xy[l] - o.xy, cp.xz[l] - o.xz};
    const double r = reference_length(dx[0], dx[1], dx[2]);
    const double use = static_cast<double>((is_alive | keep_dead) != 0);
    [[maybe_unused]] const double dy[3] = {cp.yx[l] - o.yx, cp.yy[l] - o.yy, cp.yz[l] - o.yz};  // η (kN)
    double weight =
        cp.v[l] * ramped_horizon(delta, r, ramp) / weighted_length<kAnisotropic>(g_p, r, dx[0], dx[1], dx[2]) * use;
    if constexpr (kRobust) {
      double res2 = 0.0;
      for (int a = 0; a < 3; ++a) {
        const double res = dy[a] - pc[a] - (pf[3 * a] * dx[0] + pf[3 * a + 1] * dx[1] + pf[3 * a + 2] * dx[2]);
        res2 += res * res;
      }
      const double scaled = s2 * (dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2]);
      weight *= scaled / (scaled + res2);
    }
    const double wx[3] = {weight * dx[0], weight * dx[1], weight * dx[2]};
    k6[0][l] += wx[0] * dx[0], k6[1][l] += wx[1] * dx[1], k6[2][l] += wx[2] * dx[2];
    k6[3][l] += wx[0] * dx[1], k6[4][l] += wx[0] * dx[2], k6[5][l] += wx[1] * dx[2];
    if constexpr (kN) {
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) n9[3 * a + b][l] += dy[a] * wx[b];
    }
    if constexpr (kRate) {
      const double dv[3] = {cv[0][l] - vx, cv[1][l] - vy, cv[2][l] - vz};
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) r9[3 * a + b][l] += dv[a] * wx[b];
      m10[0][l] += weight;
      for (int a = 0; a < 3; ++a) {
        m10[1 + a][l] += wx[a];
        m10[4 + a][l] += weight * dy[a];
        m10[7 + a][l] += weight * dv[a];
      }
    }
    count[l] += use;
  };
  for_each_gathered_bond_lane(bs.offsets[p], bs.offsets[p + 1], bs.alive, gather, lane, [](std::size_t, int) {},
                              alive_only ? DeadChunks::skip : DeadChunks::visit);
  const double kxx = sum_lanes(k6[0]), kyy = sum_lanes(k6[1]), kzz = sum_lanes(k6[2]), kxy = sum_lanes(k6[3]),
               kxz = sum_lanes(k6[4]), kyz = sum_lanes(k6[5]);
  K << kxx, kxy, kxz, kxy, kyy, kyz, kxz, kyz, kzz;
  if constexpr (kN)
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) (*N)(a, b) = sum_lanes(n9[3 * a + b]);
  if constexpr (kRate) {
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) (*Nd)(a, b) = sum_lanes(r9[3 * a + b]);
    if (moments) {
      moments->weight = sum_lanes(m10[0]);
      for (int a = 0; a < 3; ++a) {
        moments->xi[a] = sum_lanes(m10[1 + a]);
        moments->eta[a] = sum_lanes(m10[4 + a]);
        moments->velocity[a] = sum_lanes(m10[7 + a]);
      }
    }
  }
  return static_cast<std::uint32_t>(sum_lanes(count));  // exact: integers far below 2^53
}

}  // namespace

std::uint32_t family_sums(const WorldState& w, std::size_t p, bool alive_only, Mat3& K, Mat3& N, Mat3* rate,
                          FamilyMoments* moments, const FamilyFit* prior) {
  if (rate && prior)
    return w.any_anisotropic ? family_tensors<true, true, true, true>(w, p, alive_only, K, &N, rate, moments, prior)
                             : family_tensors<false, true, true, true>(w, p, alive_only, K, &N, rate, moments, prior);
  if (rate)
    return w.any_anisotropic ? family_tensors<true, true, true>(w, p, alive_only, K, &N, rate, moments)
                             : family_tensors<false, true, true>(w, p, alive_only, K, &N, rate, moments);
  return w.any_anisotropic ? family_tensors<true, true, false>(w, p, alive_only, K, &N, nullptr, nullptr)
                           : family_tensors<false, true, false>(w, p, alive_only, K, &N, nullptr, nullptr);
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
      Mat3 K;  // K alone (as a scalar loop it was 9 % of a 9e5-particle set-up's CPU)
      const std::uint32_t alive = family_tensors<kAnisotropic, false, false>(w, p, true, K, nullptr, nullptr, nullptr);
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
      if (!e.held_fits[p] && broken[p] >= initial[p]) return;     // no alive bond: keeps its rotation
      // Refreshed in turn, by whole-world index (a distributed run's local index differs).
      const std::size_t turn = w.global_index.empty() ? p : w.global_index[p];
      if (turn % kRefreshSteps != phase) return;
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
