// Initial cracks (paper Fig. 17, systems/README.md §6.3): a bond whose reference segment
// x_i → x_j crosses a crack polygon is not created. Runs once at setup, right after the family
// build and before the model constants, so N_i (Eq 19), the dilatation scale and the discrete
// normalization all see only the bonds that exist.
// Crossing test per polygon (planar, Newell normal n, point p0 on it): signed distances
// d_a = (x_a − p0)·n, d_b = (x_b − p0)·n of the segment ends; it crosses when they have opposite
// signs or one is zero (a segment lying in the plane does not cross), and the intersection point,
// projected onto the polygon's dominant plane, lies inside the polygon (even–odd rule, so
// non-convex polygons work). The test is evaluated for the pair (lower, higher index), so a bond
// and its mirror are always removed together.
// Reads/writes: bonds (all arrays rebuilt in CSR order: offsets, neighbor, alive,
// plastic_extension(_mirror), initial_count).
#include <cmath>

#include "bond_rules.hpp"
#include "planar_polygon.hpp"
#include "systems.hpp"

namespace perifx::systems {

std::size_t remove_cracked_bonds(WorldState& w, const std::vector<scene::Crack>& cracks) {
  Bonds& b = w.bonds;
  if (cracks.empty() || b.count() == 0) return 0;
  std::vector<PlanarPolygon> polys;
  for (const auto& c : cracks) polys.push_back(prepare_polygon(c.polygon));
  const auto& x = w.particles.reference_position;
  const std::size_t n = b.particle_count();
  std::vector<std::uint8_t> keep(b.count(), 1);
  for (std::uint32_t i = 0; i < n; ++i)
    for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k) {
      const std::uint32_t j = b.neighbor[k];
      if (j < i) continue;  // decided with the lower index first, copied to the mirror below
      for (const auto& poly : polys)
        if (crosses(poly, x[i], x[j])) {
          keep[k] = keep[mirror_bond(b, i, k)] = 0;
          break;
        }
    }
  const bool plastic = !b.plastic_extension.empty();
  Bonds out;
  out.offsets.assign(n + 1, 0);
  out.initial_count.assign(n, 0);
  for (std::uint32_t i = 0; i < n; ++i) {
    for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k) {
      if (!keep[k]) continue;
      out.neighbor.push_back(b.neighbor[k]);
      out.alive.push_back(b.alive[k]);
      if (!plastic) continue;
      out.plastic_extension.push_back(b.plastic_extension[k]);
      out.plastic_extension_mirror.push_back(b.plastic_extension_mirror[k]);
    }
    out.offsets[i + 1] = static_cast<std::uint32_t>(out.neighbor.size());
    out.initial_count[i] = out.offsets[i + 1] - out.offsets[i];
  }
  out.break_scale = {};  // weak planes are applied after the cracks (systems.hpp order)
  const std::size_t removed = b.count() - out.count();
  b = std::move(out);
  return removed;
}

}  // namespace perifx::systems
