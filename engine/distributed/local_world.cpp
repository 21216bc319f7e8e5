// A rank's local world (local_world.hpp has the rules).
#include "distributed/local_world.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace perifx::distributed {
namespace {

// Owned-and-ghost local order of rank r: ghosts below, the owned range, ghosts above.
std::vector<std::uint32_t> local_order(const Domain& d, const std::vector<std::uint32_t>& ghosts) {
  std::vector<std::uint32_t> order;
  order.reserve(ghosts.size() + (d.last - d.first));
  const auto split = std::lower_bound(ghosts.begin(), ghosts.end(), d.first);
  order.insert(order.end(), ghosts.begin(), split);
  for (std::uint32_t g = d.first; g < d.last; ++g) order.push_back(g);
  order.insert(order.end(), split, ghosts.end());
  return order;
}

// Local index of global g in an increasing order (g must be present).
std::uint32_t local_of(const std::vector<std::uint32_t>& order, std::uint32_t g) {
  return static_cast<std::uint32_t>(std::lower_bound(order.begin(), order.end(), g) - order.begin());
}

// An owned global index list (sorted) restricted to [first, last) and shifted to local indices.
std::vector<std::uint32_t> owned_part(const std::vector<std::uint32_t>& list, const Domain& d, std::uint32_t shift) {
  std::vector<std::uint32_t> out;
  for (std::uint32_t g : list)
    if (g >= d.first && g < d.last) out.push_back(g - d.first + shift);
  return out;
}

// Local CSR offsets of rows kept per global particle (bonds, surface patches): owned rows keep their
// lengths, in order, and ghost rows are empty.
std::vector<std::uint32_t> owned_row_offsets(const std::vector<std::uint32_t>& global_offsets, const LocalLayout& l) {
  std::vector<std::uint32_t> offsets(l.global_of.size() + 1, 0);
  for (std::size_t q = 0; q < l.global_of.size(); ++q) {
    const bool owned = q >= l.owned_begin && q < l.owned_begin + l.owned_count;
    const std::uint32_t g = l.global_of[q];
    offsets[q + 1] = offsets[q] + (owned ? global_offsets[g + 1] - global_offsets[g] : 0);
  }
  return offsets;
}

}  // namespace

LocalLayout make_layout(const WorldState& full, const std::vector<Domain>& domains, int rank) {
  const auto ghosts = bond_ghosts(full, domains);
  LocalLayout l;
  l.rank = rank;
  l.ranks = static_cast<int>(domains.size());
  l.domains = domains;
  const Domain& d = domains[static_cast<std::size_t>(rank)];
  const auto& mine = ghosts[static_cast<std::size_t>(rank)];
  l.global_of = local_order(d, mine);
  l.owned_begin = local_of(l.global_of, d.first);
  l.owned_count = d.last - d.first;
  l.bond_begin = full.bonds.offsets[d.first];
  // Receives: my ghosts grouped by owner, in increasing global order within each group.
  for (int q = 0; q < l.ranks; ++q) {
    HaloLink in{q, {}};
    const Domain& dq = domains[static_cast<std::size_t>(q)];
    for (std::uint32_t g : mine)
      if (g >= dq.first && g < dq.last) in.local.push_back(local_of(l.global_of, g));
    if (!in.local.empty()) l.receives.push_back(std::move(in));
  }
  // Sends: for every other rank, the ghosts it holds that I own, in the same order it expects them.
  for (int q = 0; q < l.ranks; ++q) {
    if (q == rank) continue;
    HaloLink out{q, {}};
    for (std::uint32_t g : ghosts[static_cast<std::size_t>(q)])
      if (g >= d.first && g < d.last) out.local.push_back(g - d.first + l.owned_begin);
    if (!out.local.empty()) l.sends.push_back(std::move(out));
  }
  return l;
}

std::unique_ptr<WorldState> make_local_world(const WorldState& full, const LocalLayout& layout) {
  if (full.contact.enabled)
    throw std::invalid_argument("/contact/enabled: particle contact is not distributed yet (got true; it is on by "
                                "default when a material can break or there are two bodies): set \"contact\": "
                                "{\"enabled\": false}, or run this scene in one process");
  if (!full.projectiles.bodies.empty())
    throw std::invalid_argument("/projectiles: projectiles are not distributed yet (got " +
                                std::to_string(full.projectiles.bodies.size()) +
                                "): run this scene in one process");
  const Domain& d = layout.domains[static_cast<std::size_t>(layout.rank)];
  const auto& order = layout.global_of;
  const std::size_t n_full = full.particles.count(), n = order.size();
  const std::uint32_t shift = layout.owned_begin;

  auto w = std::make_unique<WorldState>();
  w->settings = full.settings;
  w->clock = full.clock;
  w->any_plastic = full.any_plastic;
  w->any_anisotropic = full.any_anisotropic;
  w->any_fracture = full.any_fracture;
  w->bodies = full.bodies;  // names and measures only; nothing in the step reads their ranges
  w->contact.enabled = false;

  // Per-particle arrays: every array for_each_array lists as a particle array of full length is
  // gathered through the local order (bonds.offsets, one longer, is rebuilt below). Both visits list
  // the arrays in the same order, so the k-th particle array of one is the k-th of the other.
  std::vector<const void*> sources;
  for_each_array(full, [&](ArrayKind kind, const char*, const auto& array) {
    if (kind == ArrayKind::particle) sources.push_back(&array);
  });
  std::size_t k = 0;
  for_each_array(*w, [&](ArrayKind kind, const char*, auto& array) {
    if (kind != ArrayKind::particle) return;
    const auto& src = *static_cast<const std::remove_reference_t<decltype(array)>*>(sources[k++]);
    if (src.size() != n_full) return;  // empty (unused) arrays and bonds.offsets
    array.resize(n);
    for (std::size_t l = 0; l < n; ++l) array[l] = src[order[l]];
  });
  // Ghosts: integration and colliders leave them alone (the halo brings their motion).
  for (std::size_t l = 0; l < n; ++l)
    if (l < shift || l >= shift + layout.owned_count) w->particles.flags[l] |= kPrescribed;

  // Bonds: owned rows as they are (neighbours mapped to local), ghost rows empty.
  const Bonds& fb = full.bonds;
  Bonds& b = w->bonds;
  const std::uint32_t bond_first = fb.offsets[d.first], bond_last = fb.offsets[d.last];
  b.offsets = owned_row_offsets(fb.offsets, layout);
  auto slice = [&](const auto& src, auto& dst) {
    if (src.empty()) return dst.clear();
    dst.assign(src.begin() + bond_first, src.begin() + bond_last);
  };
  slice(fb.alive, b.alive);
  slice(fb.plastic_extension, b.plastic_extension);
  slice(fb.plastic_extension_mirror, b.plastic_extension_mirror);
  slice(fb.break_scale, b.break_scale);
  b.neighbor.resize(bond_last - bond_first);
  for (std::uint32_t q = bond_first; q < bond_last; ++q) b.neighbor[q - bond_first] = local_of(order, fb.neighbor[q]);

  // Boundary conditions: each list restricted to the owned particles.
  w->boundary.conditions = full.boundary.conditions;
  for (const auto& list : full.boundary.particles) w->boundary.particles.push_back(owned_part(list, d, shift));
  w->boundary.constrained = owned_part(full.boundary.constrained, d, shift);

  // Surface patches (CSR by particle): owned rows keep their patches, in order, so a global patch
  // index p of an owned particle is local patch p − offsets[first].
  const SurfacePatches& fs = full.surface;
  SurfacePatches& s = w->surface;
  std::uint32_t patch_first = 0;
  if (!fs.offsets.empty()) {
    patch_first = fs.offsets[d.first];
    const std::uint32_t patch_last = fs.offsets[d.last];
    s.offsets = owned_row_offsets(fs.offsets, layout);
    s.area.assign(fs.area.begin() + patch_first, fs.area.begin() + patch_last);
    s.normal.assign(fs.normal.begin() + patch_first, fs.normal.begin() + patch_last);
    s.offset.assign(fs.offset.begin() + patch_first, fs.offset.begin() + patch_last);
  }

  // Loads: particle lists restricted to the owned particles, with their patch rows.
  const LoadSet& fl = full.loads;
  LoadSet& ld = w->loads;
  ld.loads = fl.loads;
  for (std::size_t q = 0; q < fl.loads.size(); ++q) {
    const auto& list = fl.particles[q];
    const bool has_patches = q < fl.patch_offsets.size() && !fl.patch_offsets[q].empty();
    std::vector<std::uint32_t> particles, patch_offsets, patches;
    if (has_patches) patch_offsets.push_back(0);
    for (std::size_t m = 0; m < list.size(); ++m) {
      const std::uint32_t g = list[m];
      if (g < d.first || g >= d.last) continue;
      particles.push_back(g - d.first + shift);
      if (has_patches) {
        for (std::uint32_t e = fl.patch_offsets[q][m]; e < fl.patch_offsets[q][m + 1]; ++e)
          patches.push_back(fl.patches[q][e] - patch_first);
        patch_offsets.push_back(static_cast<std::uint32_t>(patches.size()));
      }
    }
    ld.particles.push_back(std::move(particles));
    ld.patch_offsets.push_back(std::move(patch_offsets));
    ld.patches.push_back(std::move(patches));
  }
  return w;
}

}  // namespace perifx::distributed
