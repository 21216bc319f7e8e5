// Boundary-condition regions: each condition's particles, found once on the reference positions
// (after the body transforms), so the step only walks index lists.
#include <algorithm>

#include "setup/world_setup.hpp"

namespace perifx::setup {

bool in_region(const scene::Region& region, const Vec3& x, int body) {
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

void resolve_boundary_conditions(const std::vector<scene::BoundaryCondition>& conditions, WorldState& w) {
  const auto& p = w.particles;
  // Boundary condition regions, resolved once on reference positions.
  w.boundary.conditions = conditions;
  w.boundary.particles.resize(conditions.size());
  for (std::size_t c = 0; c < conditions.size(); ++c) {
    for (std::size_t i = 0; i < p.count(); ++i)
      if (in_region(conditions[c].region, p.reference_position[i], p.body_id[i]))
        w.boundary.particles[c].push_back(static_cast<std::uint32_t>(i));
    w.boundary.constrained.insert(w.boundary.constrained.end(), w.boundary.particles[c].begin(),
                                  w.boundary.particles[c].end());
  }
  std::sort(w.boundary.constrained.begin(), w.boundary.constrained.end());
  w.boundary.constrained.erase(std::unique(w.boundary.constrained.begin(), w.boundary.constrained.end()),
                               w.boundary.constrained.end());

}

}  // namespace perifx::setup
