// Spatially varying strength (systems/README.md §12.4), a setup pass after the model constants and
// before the first fracture thresholds. For particle i of material m:
//   s_c,i ← s_c,i · Π_{regions of m holding x_i} factor · (1 + A·n(x_i/ℓ, seed)),
// n a 3D value noise in [−1, 1]: pseudo-random values at the integer lattice points (a hash of the
// point and the seed, so the same seed gives the same bits on any thread count and platform with
// IEEE doubles), blended with the quintic fade (value_noise.hpp). For every bond whose reference segment crosses a
// weak-plane polygon of either end's material, Bonds::break_scale = the smallest such factor (1
// elsewhere): the break test of both sides compares with that fraction of its limit (bond_rules.hpp
// side_breaks). Weak planes use the crossing test of initial cracks (planar_polygon.hpp).
// Reads:  particles (reference_position, material_id, body_id), bonds (offsets, neighbor, reverse),
//         scene materials' strength.
// Writes: model.critical_stretch (scaled), bonds.break_scale (allocated only when a weak plane exists).
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "bond_rules.hpp"
#include "parallel.hpp"
#include "planar_polygon.hpp"
#include "region.hpp"
#include "systems.hpp"
#include "value_noise.hpp"

namespace perifx::systems {

double strength_noise(const Vec3& x, double feature_size, std::uint64_t seed) {
  return value_noise(x / feature_size, seed);
}

void apply_strength_field(WorldState& w) {
  const auto& mats = w.settings.materials;
  const auto& p = w.particles;
  const std::size_t n = p.count();
  parallel_for_each(n, [&](std::size_t i) {
    const auto& st = mats[p.material_id[i]].strength;
    if (st.empty()) return;
    double f = 1.0;
    for (const auto& r : st.regions)
      if (region_contains(r.region, p.reference_position[i], p.body_id[i])) f *= r.factor;
    if (st.noise_amplitude > 0.0 && st.noise_feature_size > 0.0)
      f *= 1.0 + st.noise_amplitude * strength_noise(p.reference_position[i], st.noise_feature_size, st.noise_seed);
    w.model.critical_stretch[i] *= f;
  });

  Bonds& b = w.bonds;
  b.break_scale.clear();  // empty: 1 for every bond (the bond pass then reads no per-bond factor)
  if (!w.any_fracture) return;
  // Prepared polygons per material (most materials have none).
  std::vector<std::vector<std::pair<PlanarPolygon, double>>> planes(mats.size());
  bool any = false;
  for (std::size_t m = 0; m < mats.size(); ++m)
    for (const auto& wp : mats[m].strength.weak_planes) {
      planes[m].emplace_back(prepare_polygon(wp.polygon), wp.factor);
      any = true;
    }
  if (!any) return;
  b.break_scale.assign(b.count(), 1.0f);
  const auto& x = p.reference_position;
  parallel_for_each(n, [&](std::size_t i) {  // each pair decided by its lower index, written to both slots
    for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k) {
      const std::uint32_t j = b.neighbor[k];
      if (j < i) continue;
      double factor = 1.0;
      for (const std::uint16_t m : {p.material_id[i], p.material_id[j]})
        for (const auto& [poly, f] : planes[m])
          if (f < factor && crosses(poly, x[i], x[j])) factor = f;
      if (factor < 1.0) b.break_scale[k] = b.break_scale[mirror_bond(b, i, k)] = static_cast<float>(factor);
    }
  });
}

}  // namespace perifx::systems
