// Components share the public math vocabulary (Vec3, Mat3, kInfinity) so that a host sees the same
// types the systems use: see engine/include/perifx/math.hpp.
#pragma once
#include "perifx/math.hpp"
