// Boundary-condition regions: each condition's particles, found once on the reference positions
// (after the body transforms), so the step only walks index lists.
#include <algorithm>

#include "setup/world_setup.hpp"
#include "systems/region.hpp"

namespace perifx::setup {

void resolve_boundary_conditions(const std::vector<scene::BoundaryCondition>& conditions, WorldState& w) {
  const auto& p = w.particles;
  // Boundary condition regions, resolved once on reference positions.
  w.boundary.conditions = conditions;
  w.boundary.particles.resize(conditions.size());
  for (std::size_t c = 0; c < conditions.size(); ++c) {
    for (std::size_t i = 0; i < p.count(); ++i)
      if (systems::region_contains(conditions[c].region, p.reference_position[i], p.body_id[i]))
        w.boundary.particles[c].push_back(static_cast<std::uint32_t>(i));
    w.boundary.constrained.insert(w.boundary.constrained.end(), w.boundary.particles[c].begin(),
                                  w.boundary.particles[c].end());
  }
  std::sort(w.boundary.constrained.begin(), w.boundary.constrained.end());
  w.boundary.constrained.erase(std::unique(w.boundary.constrained.begin(), w.boundary.constrained.end()),
                               w.boundary.constrained.end());

}

}  // namespace perifx::setup
