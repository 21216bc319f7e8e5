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

}  // namespace perifx
