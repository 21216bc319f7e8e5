// Largest stable velocity-Verlet step of a world's elastic model at its reference configuration:
// dt_max = 2/ω_max, ω_max² the largest eigenvalue of M⁻¹K (K: the linearized internal force).
//
// The eigenvalue comes from Spectra (Debian libspectra-dev; implicitly restarted Lanczos) on the
// symmetric A = M^-1/2 K M^-1/2, which has the same eigenvalues as M⁻¹K. K is never assembled: A q is
// probed as the force change at a displacement small enough to stay linear, through the same force
// kernels the step uses (PD: dilatation + internal force; FEM: the FEM force). Every product is
// deterministic (fixed-order sums), and so is the start vector, so the estimate is the same for
// any thread count. Memory: kKrylov vectors of 3n doubles.
#include <Spectra/SymEigsSolver.h>

#include <cmath>
#include <type_traits>

#include "setup/world_setup.hpp"
#include "systems/bond_rules.hpp"
#include "systems/parallel.hpp"
#include "systems/systems.hpp"

namespace perifx::setup {
namespace {

constexpr Eigen::Index kKrylov = 8;  // Lanczos basis size per restart (Spectra's ncv)
constexpr double kRitzTolerance = 1e-2;
constexpr double kRitzMargin = 1.01;  // ω_max² taken 1 % above the Ritz value (see below)

// y = A x for A = M^-1/2 K M^-1/2, on flat arrays of 3n doubles (the interface Spectra calls).
class StiffnessOperator {
 public:
  using Scalar = double;
  explicit StiffnessOperator(const WorldState& w) : w_(w), n_(w.particles.count()), y_(n_), force_(n_), theta_(n_), coupling_(n_) {
    const auto& x = w.particles.reference_position;
    spacing_ = kInfinity;
    {  // the shortest bond (min is exact in any order, so per-particle minima then their min)
      const auto& b = w.bonds;
      std::vector<double> shortest(n_, kInfinity);
      parallel_for_each(n_, [&](std::size_t i) {
        for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k)
          shortest[i] = std::min(shortest[i], systems::reference_length(x[b.neighbor[k]] - x[i]));
      }, 1024);
      for (double r : shortest) spacing_ = std::min(spacing_, r);
    }
    if (w.settings.solver != scene::Solver::peridynamics)
      for (const auto& t : w.mesh.tets)
        for (int a = 0; a < 4; ++a)
          for (int b = a + 1; b < 4; ++b) spacing_ = std::min(spacing_, (x[t[a]] - x[t[b]]).norm());
  }
  Eigen::Index rows() const { return Eigen::Index(3 * n_); }
  Eigen::Index cols() const { return Eigen::Index(3 * n_); }

  void perform_op(const double* in, double* out) const {
    const auto& x = w_.particles.reference_position;
    const auto& mass = w_.particles.mass;
    auto q = [&](std::size_t i) { return Vec3(in[3 * i], in[3 * i + 1], in[3 * i + 2]); };
    // Probe amplitude: the largest particle displacement stays ~1e-7 of the smallest spacing.
    const double rms = std::sqrt(deterministic_sum(n_, 0.0, [&](std::size_t i) { return q(i).squaredNorm() / mass[i]; }) / double(n_));
    const double eps = 1e-7 * spacing_ / std::max(rms, 1e-300);
    parallel_for_each(n_, [&](std::size_t i) { y_[i] = x[i] + (eps / std::sqrt(mass[i])) * q(i); });
    if (w_.settings.solver != scene::Solver::peridynamics) {
      systems::compute_fem_force(w_, y_, corner_scratch_, force_);
    } else {
      systems::compute_dilatation(w_, y_, theta_, coupling_);
      systems::compute_internal_force(w_, y_, coupling_, force_);
    }
    parallel_for_each(n_, [&](std::size_t i) {
      const Vec3 a = -force_[i] / (eps * std::sqrt(mass[i]));
      out[3 * i] = a.x(), out[3 * i + 1] = a.y(), out[3 * i + 2] = a.z();
    });
  }

 private:
  const WorldState& w_;
  std::size_t n_;
  double spacing_;
  mutable std::vector<Vec3> y_, force_, corner_scratch_;
  mutable std::vector<double> theta_, coupling_;
};

}  // namespace

// A lower bound on the stable step of the peridynamic model, from an upper bound on ω_max² that needs one
// pass over the bonds (systems/README.md §7). The linearized elastic energy is
//   ½ uᵀKu = Σ_i V_i [k_i θ_i² + b_i Σ_j ω_ij V_j d_ij²],  d_ij = n_ij·(u_j − u_i),  θ_i = c_i Σ_j ω_ij V_j d_ij,
// with k_i = (a_i − b_i β_i)/c_i (elastic_energy in systems/elastic_force.cpp). Cauchy–Schwarz gives
// θ_i² ≤ c_i² S_i Σ_j ω_ij V_j d_ij² (S_i = Σ_j ω_ij V_j), and d_ij² ≤ 2|u_i|² + 2|u_j|², so
//   uᵀKu ≤ Σ_p G_p |u_p|²,  G_p = Σ_j (g_pj + g_jp),  g_ij = 4 V_i V_j ω_ij (max(k_i, 0) c_i² S_i + b_i),
// and ω_max² = max uᵀKu/uᵀMu ≤ max_p G_p/m_p. Deterministic (per-particle sums in family order, then a
// max, which is exact in any order).
double stable_time_step_bound(const WorldState& w) {
  const std::size_t n = w.particles.count();
  if (n == 0 || w.bonds.count() == 0 || w.settings.solver != scene::Solver::peridynamics) return 0.0;
  const auto& b = w.bonds;
  const auto& x = w.particles.reference_position;
  const auto& vol = w.particles.volume;
  const auto& md = w.model;
  // Per particle: q_i = 4 V_i (max(k_i, 0) c_i² S_i + b_i), so g_ij = q_i ω_ij V_j.
  // Σ_j g_ij = q_i s_i + V_i Σ_j q_j ω_ji with s_i = Σ_j ω_ij V_j: one weight per bond in each pass.
  std::vector<double> q(n, 0.0), s(n, 0.0), bound(n, 0.0);
  auto finish_q = [&](std::size_t i, double s_i) {
    const double c = md.dilatation_scale[i], bb = 0.25 * md.b4[i];
    const double kk = c > 0.0 ? (0.25 * md.a4[i] - bb * md.beta[i]) / c : 0.0;
    q[i] = 4.0 * vol[i] * (std::max(kk, 0.0) * c * c * s_i + bb);
    s[i] = s_i;
  };
  if (!w.any_anisotropic) {
    // Isotropic: ω_ij = δ̃_i(|ξ|)/|ξ| (δ̃ = δ without the `corrected` model's influence ramp,
    // bond_rules.hpp), so s_i = Σ_j δ̃_i V_j/|ξ| and Σ_j q_j ω_ji = Σ_j q_j δ̃_j/|ξ|, each a lane-strided
    // pass (SIMD square roots and divisions; bond_rules.hpp's for_each_bond_lane, sums in a fixed lane
    // order). This bound was 0.5 s of a 9e5-particle set-up as a scalar loop. The ramp is taken in:
    // with δ/|ξ| instead it stays a bound but looser, enough to send a scene whose dt sits near the
    // limit to the eigenvalue estimate (`perifx check` of glass_wall_5m ran for over 17 minutes).
    const auto bs = systems::bond_streams(w, x);
    const systems::InfluenceRamp ramp = systems::influence_ramp(w);
    // Σ_j value[j] δ̃/|ξ_ij| over i's bonds, δ̃ of i's horizon (far false) or of j's (far true). `far` is
    // a compile-time constant: a run-time select around the gather of δ_j keeps GCC 12 from
    // vectorizing the loop (mesh_rotations.cpp saw the same).
    auto over_length = [&](std::size_t i, const double* value, auto far) {
      const auto o = bs.origin(i);
      const double delta_i = bs.horizon[i];
      double lanes[systems::kBondLanes] = {};
      auto lane = [=, &lanes](std::size_t k, int l, std::uint64_t) {
        const std::size_t j = bs.neighbor[k];
        const double r = systems::reference_length(bs.x[3 * j] - o.xx, bs.x[3 * j + 1] - o.xy, bs.x[3 * j + 2] - o.xz);
        double horizon = delta_i;
        if constexpr (decltype(far)::value) horizon = bs.horizon[j];
        lanes[l] += value[j] * systems::ramped_horizon(horizon, r, ramp) / r;
      };
      systems::for_each_bond_lane(bs.offsets[i], bs.offsets[i + 1], bs.alive, lane, [](std::size_t, int) {});
      return systems::sum_lanes(lanes);
    };
    parallel_for_each(n, [&](std::size_t i) { finish_q(i, over_length(i, vol.data(), std::false_type{})); }, 256);
    parallel_for_each(n, [&](std::size_t i) {
      bound[i] = (q[i] * s[i] + over_length(i, q.data(), std::true_type{}) * vol[i]) / w.particles.mass[i];
    }, 256);
  } else {
    parallel_for_each(n, [&](std::size_t i) {
      double s_i = 0.0;
      for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k) {
        const std::uint32_t j = b.neighbor[k];
        s_i += systems::bond_weight(w, i, x[j] - x[i]) * vol[j];
      }
      finish_q(i, s_i);
    }, 256);
    parallel_for_each(n, [&](std::size_t i) {
      double g = 0.0;
      for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k) {
        const std::uint32_t j = b.neighbor[k];
        g += q[j] * systems::bond_weight(w, j, x[i] - x[j]);
      }
      bound[i] = (q[i] * s[i] + g * vol[i]) / w.particles.mass[i];
    }, 256);
  }
  double omega2 = 0.0;
  for (double v : bound) omega2 = std::max(omega2, v);
  return omega2 > 0.0 ? 2.0 / std::sqrt(omega2) : kInfinity;
}

double estimate_stable_time_step(const WorldState& w) {
  const std::size_t n = w.particles.count();
  const bool fem = w.settings.solver != scene::Solver::peridynamics;
  if (n == 0 || (!fem && w.bonds.count() == 0)) return kInfinity;
  StiffnessOperator op(w);
  // Deterministic pseudo-random start vector: rich in the high-frequency modes we look for.
  Eigen::VectorXd start(op.rows());
  std::uint64_t seed = 0x9E3779B97F4A7C15ull;
  for (Eigen::Index k = 0; k < start.size(); ++k) {
    seed ^= seed << 13, seed ^= seed >> 7, seed ^= seed << 17;
    start[k] = static_cast<double>(seed >> 11) * 0x1.0p-53 - 0.5;
  }
  // The Ritz residual tolerance is 1e-2: the Ritz value converges much faster than its vector (its error
  // goes as the residual squared over the spectral gap), and is always ≤ ω_max². Measured on the paper
  // previews: within 0.7 % of the value at tolerance 1e-4, in 17–29 operator applications instead of
  // 53–201 (ncv 8). kRitzMargin makes up for the remaining under-estimate, so the limit errs on the
  // safe side. A larger basis is tried if the small one does not converge (clustered top of the spectrum).
  for (Eigen::Index basis = kKrylov; basis <= 4 * kKrylov; basis *= 2) {
    const Eigen::Index ncv = std::min<Eigen::Index>(basis, op.rows());
    if (ncv < 2) break;
    Spectra::SymEigsSolver<StiffnessOperator> eigs(op, 1, ncv);
    eigs.init(start.data());
    eigs.compute(Spectra::SortRule::LargestAlge, 500, kRitzTolerance);
    if (eigs.info() == Spectra::CompInfo::Successful) {
      const double lambda = kRitzMargin * eigs.eigenvalues()[0];
      return lambda > 0.0 ? 2.0 / std::sqrt(lambda) : kInfinity;
    }
  }
  throw std::runtime_error("stable time step: the largest eigenvalue estimate did not converge");
}

}  // namespace perifx::setup
