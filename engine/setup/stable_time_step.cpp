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

#include "setup/world_setup.hpp"
#include "systems/bond_rules.hpp"
#include "systems/parallel.hpp"
#include "systems/systems.hpp"

namespace perifx::setup {
namespace {

constexpr Eigen::Index kKrylov = 8;  // Lanczos basis size per restart (Spectra's ncv)

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
  // 1e-4 relative accuracy on ω_max² is ample for a step limit that scenes use with a margin. A
  // larger basis is tried if the small one does not converge (clustered top of the spectrum).
  for (Eigen::Index basis = kKrylov; basis <= 4 * kKrylov; basis *= 2) {
    const Eigen::Index ncv = std::min<Eigen::Index>(basis, op.rows());
    if (ncv < 2) break;
    Spectra::SymEigsSolver<StiffnessOperator> eigs(op, 1, ncv);
    eigs.init(start.data());
    eigs.compute(Spectra::SortRule::LargestAlge, 500, 1e-4);
    if (eigs.info() == Spectra::CompInfo::Successful) {
      const double lambda = eigs.eigenvalues()[0];
      return lambda > 0.0 ? 2.0 / std::sqrt(lambda) : kInfinity;
    }
  }
  throw std::runtime_error("stable time step: the largest eigenvalue estimate did not converge");
}

}  // namespace perifx::setup
