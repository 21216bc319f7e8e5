// The one test of "is this point in a scene region" (scene::Region: all, box, sphere, halfspace,
// optionally one body), used on reference positions by boundary conditions and loads (setup) and by
// strength regions (strength_field.cpp). Header-only so both layers share it.
#pragma once
#include "perifx/scene.hpp"

namespace perifx::systems {

// True when reference point x of a particle of body `body` lies in `region` (boundaries included).
inline bool region_contains(const scene::Region& region, const Vec3& x, int body) {
  if (region.body >= 0 && region.body != body) return false;
  switch (region.kind) {
    case scene::Region::Kind::all: return true;
    case scene::Region::Kind::box:
      return (x.array() >= region.min.array()).all() && (x.array() <= region.max.array()).all();
    case scene::Region::Kind::sphere: return (x - region.center).squaredNorm() <= region.radius * region.radius;
    case scene::Region::Kind::halfspace: return (x - region.point).dot(region.normal) >= 0.0;
  }
  return false;
}

}  // namespace perifx::systems
