// perifx public API: the small math vocabulary every other header uses (Eigen types, SI units).
// Positions and everything that enters a bond extension are double precision: the rigid-motion and
// momentum tests need extensions exact to ~1e-13 of a bond length, which float (1e-7) cannot give.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <limits>

namespace perifx {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

inline constexpr double kInfinity = std::numeric_limits<double>::infinity();
inline constexpr double kPi = 3.14159265358979323846;

// Isotropic linear elasticity: the two pairs a material may be given in (bulk κ and shear μ, Pa;
// Young's E, Pa, and Poisson's ν), each from the other. The loader, `perifx info` and the yield law
// convert through these alone.
inline constexpr double youngs_modulus(double bulk, double shear) { return 9.0 * bulk * shear / (3.0 * bulk + shear); }
inline constexpr double poisson_ratio(double bulk, double shear) {
  return (3.0 * bulk - 2.0 * shear) / (2.0 * (3.0 * bulk + shear));
}
inline constexpr double bulk_modulus(double youngs, double poisson) { return youngs / (3.0 * (1.0 - 2.0 * poisson)); }
inline constexpr double shear_modulus(double youngs, double poisson) { return youngs / (2.0 * (1.0 + poisson)); }

}  // namespace perifx
