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

#include <Eigen/Eigenvalues>

#include <array>
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

// A lower bound on the stable step of the peridynamic model, from an upper bound on ω_max² that needs two
// passes over the bonds (systems/README.md §7). The linearized elastic energy is
//   ½ uᵀKu = Σ_i V_i [k_i θ_i² + b_i Σ_j a_ij d_ij²],  d_ij = n_ij·(u_j − u_i),  θ_i = c_i Σ_j a_ij d_ij,
// with a_ij = ω_ij V_j, n_ij = ξ/|ξ| and k_i = (a_i − b_i β_i)/c_i (elastic_energy in
// systems/elastic_force.cpp). Every term is bounded by a quadratic form of single particles' u_p:
//   deviatoric: d² ≤ 2 (n·u_i)² + 2 (n·u_j)²;
//   dilatation: θ_i = c_i (A_i − g_i·u_i) with A_i = Σ_j a_ij n_ij·u_j and g_i = Σ_j a_ij n_ij (≈ 0 inside a
//   body), so θ_i² ≤ c_i² [(1 + t_i) A_i² + (1 + 1/t_i) (g_i·u_i)²] for any t_i > 0 (t_i = |g_i|/S_i here),
//   and A_i² ≤ S_i Σ_j a_ij (n_ij·u_j)² (Cauchy–Schwarz, S_i = Σ_j a_ij).
// So uᵀKu ≤ Σ_p u_pᵀ H_p u_p with the 3 × 3 matrix
//   H_p = 4 V_p b_p T_p + 2 V_p k⁺_p c_p² (1 + 1/t_p) g_p g_pᵀ + V_p Σ_j R_j ω_jp n n ᵀ,
//   T_p = Σ_j a_pj n nᵀ,  R_j = 4 V_j b_j + 2 V_j k⁺_j c_j² (1 + t_j) S_j  (k⁺ = max(k, 0)),
// and ω_max² = max uᵀKu/uᵀMu ≤ max_p λ_max(H_p)/m_p. Keeping the bond directions (n nᵀ, whose trace is 1
// and whose sum over a complete family has its largest eigenvalue near ⅓ of its trace) instead of |u_p|²
// alone, and not spreading the dilatation's own-particle term over every bond, makes this 1.4–2.5× tighter
// in dt than the bound it replaced (0.30–0.55 of the estimate on the nine cases of
// tests/engine/test_world.cpp, now 0.69–0.84). Deterministic:
// per-particle sums in a fixed lane order, then a max, which is exact in any order.
double stable_time_step_bound(const WorldState& w) {
  const std::size_t n = w.particles.count();
  if (n == 0 || w.bonds.count() == 0 || w.settings.solver != scene::Solver::peridynamics) return 0.0;
  const auto& x = w.particles.reference_position;
  const auto& vol = w.particles.volume;
  const auto& md = w.model;
  const auto bs = systems::bond_streams(w, x);
  const systems::InfluenceRamp ramp = systems::influence_ramp(w);
  // Row sums over every bond listed in i's row, broken ones too (the flag is not read: at set-up only
  // initial cracks have broken bonds, and counting them makes the bound stiffer, so the step smaller,
  // which is safe), of value[j] ω n nᵀ (six: xx yy zz xy xz yz), and with kOwn also of
  // value[j] ω (S) and value[j] ω n (g). ω is i's weight (δ̃_i/ℓ_i, kOwn) or j's (δ̃_j/ℓ_j). Lane-strided
  // like the bond kernels (for_each_bond_lane: SIMD for isotropic worlds, fixed summation order).
  struct RowSums {
    double s = 0.0, g[3] = {}, t[6] = {};
  };
  auto row_sums = [&](std::size_t i, const double* value, auto own, auto anisotropic) {
    constexpr bool kOwn = decltype(own)::value, kAnisotropic = decltype(anisotropic)::value;
    const auto o = bs.origin(i);
    double lanes[10][systems::kBondLanes] = {};
    auto lane = [&, o](std::size_t k, int l, std::uint64_t) {
      const std::size_t j = bs.neighbor[k];
      const double dx = bs.x[3 * j] - o.xx, dy = bs.x[3 * j + 1] - o.xy, dz = bs.x[3 * j + 2] - o.xz;
      const double r = systems::reference_length(dx, dy, dz), inv_r = 1.0 / r;  // one division per bond
      double omega;
      if constexpr (kAnisotropic)
        omega = kOwn ? systems::bond_weight(w, i, Vec3(dx, dy, dz)) : systems::bond_weight(w, j, Vec3(-dx, -dy, -dz));
      else
        omega = systems::ramped_horizon(kOwn ? bs.horizon[i] : bs.horizon[j], r, ramp) * inv_r;
      const double a = value[j] * omega, an = a * inv_r * inv_r;  // a n nᵀ = an ξ ξᵀ
      if constexpr (kOwn) {
        const double ar = a * inv_r;
        lanes[0][l] += a;
        lanes[1][l] += ar * dx, lanes[2][l] += ar * dy, lanes[3][l] += ar * dz;
      }
      lanes[4][l] += an * dx * dx, lanes[5][l] += an * dy * dy, lanes[6][l] += an * dz * dz;
      lanes[7][l] += an * dx * dy, lanes[8][l] += an * dx * dz, lanes[9][l] += an * dy * dz;
    };
    systems::for_each_bond_lane(bs.offsets[i], bs.offsets[i + 1], bs.alive, lane, [](std::size_t, int) {},
                                systems::DeadChunks::visit);
    RowSums out;
    if constexpr (kOwn) {
      out.s = systems::sum_lanes(lanes[0]);
      for (int c = 0; c < 3; ++c) out.g[c] = systems::sum_lanes(lanes[1 + c]);
    }
    for (int c = 0; c < 6; ++c) out.t[c] = systems::sum_lanes(lanes[4 + c]);
    return out;
  };
  auto sym = [](const auto& t) {
    Mat3 m;
    m << t[0], t[3], t[4], t[3], t[1], t[5], t[4], t[5], t[2];
    return m;
  };
  // Per particle: the own-row part of H_p (6 numbers, as RowSums::t), R_j, and λ_max(H_p)/m_p.
  std::vector<std::array<double, 6>> own(n);
  std::vector<double> reach(n, 0.0), bound(n, 0.0);
  // Each row in its body's form (dispatch_row, as the bond kernels): an isotropic body's rows take the
  // SIMD isotropic weights in an anisotropic world too; a bond joins two rows of the same form.
  auto passes = [&](auto anisotropic_world) {
    constexpr bool kAnisotropicWorld = decltype(anisotropic_world)::value;
    auto sums = [&](std::size_t i, const double* value, auto own_row) {
      RowSums r;
      systems::dispatch_row<kAnisotropicWorld, false>(md.anisotropic_family, i, [&](auto form) {
        r = row_sums(i, value, own_row, std::bool_constant<decltype(form)::value>{});
      });
      return r;
    };
    parallel_for_each(n, [&](std::size_t i) {
      const RowSums r = sums(i, vol.data(), std::true_type{});
      const double c = md.dilatation_scale[i], bb = 0.25 * md.b4[i];
      const double kk = c > 0.0 ? std::max(systems::bulk_energy_coefficient(md, i), 0.0) * c * c : 0.0;  // k⁺ c²
      const Vec3 g(r.g[0], r.g[1], r.g[2]);
      const double t = r.s > 0.0 ? g.norm() / r.s : 0.0;
      const double dil = t > 0.0 ? 2.0 * vol[i] * kk * (1.0 + 1.0 / t) : 0.0;
      const Vec3 gg[2] = {g.cwiseProduct(g), Vec3(g.x() * g.y(), g.x() * g.z(), g.y() * g.z())};
      for (int e = 0; e < 6; ++e) own[i][e] = 4.0 * vol[i] * bb * r.t[e] + dil * gg[e / 3][e % 3];
      reach[i] = 4.0 * vol[i] * bb + 2.0 * vol[i] * kk * (1.0 + t) * r.s;
    }, 256);
    parallel_for_each(n, [&](std::size_t p) {
      const Mat3 h = sym(own[p]) + vol[p] * sym(sums(p, reach.data(), std::false_type{}).t);
      // Closed-form eigenvalues of a symmetric 3 × 3 (deterministic); the 1e-9 covers their rounding.
      const double lambda = Eigen::SelfAdjointEigenSolver<Mat3>().computeDirect(h, Eigen::EigenvaluesOnly).eigenvalues().maxCoeff();
      bound[p] = (1.0 + 1e-9) * std::max(lambda, 0.0) / w.particles.mass[p];
    }, 256);
  };
  if (w.any_anisotropic)
    passes(std::true_type{});
  else
    passes(std::false_type{});
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
