// Domain decomposition plan (decomposition.hpp has the rules).
#include "distributed/decomposition.hpp"

#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <stdexcept>
#include <string>

#include "systems/spatial_grid.hpp"

namespace perifx::distributed {

namespace {

// Contiguous ranges of equal work, with work_before(i) = Σ work of particles [0, i).
template <class WorkBefore>
std::vector<Domain> split(std::size_t n, int ranks, WorkBefore&& work_before) {
  if (ranks < 1 || static_cast<std::size_t>(ranks) > n)
    throw std::invalid_argument("expects 1 to the particle count (" + std::to_string(n) + "), got " +
                                std::to_string(ranks));
  const std::uint64_t total = work_before(n);
  const auto r_count = static_cast<std::size_t>(ranks);
  std::vector<Domain> domains(r_count);
  std::size_t first = 0;
  for (std::size_t r = 0; r < r_count; ++r) {
    // The first particle whose work starts at or after the (r+1)-th share; every rank keeps at least
    // one particle and leaves one for each rank after it.
    std::size_t last = n;
    if (r + 1 < r_count) {
      const std::uint64_t target = total * (r + 1) / r_count;
      std::size_t lo = first + 1, hi = n - (r_count - r - 1);
      while (lo < hi) {  // smallest last in [first+1, hi] with work_before(last) ≥ target
        const std::size_t mid = lo + (hi - lo) / 2;
        if (work_before(mid) >= target) hi = mid;
        else lo = mid + 1;
      }
      last = lo;
    }
    Domain& d = domains[r];
    d.first = static_cast<std::uint32_t>(first);
    d.last = static_cast<std::uint32_t>(last);
    d.work = work_before(last) - work_before(first);
    first = last;
  }
  return domains;
}

// FEM mode (components/fem.hpp): the particles are the mesh vertices and have no bonds; a vertex's
// force is the sum of its tets' corner forces, so its links are its tet corners.
bool fem_mode(const WorldState& w) { return w.settings.solver != scene::Solver::peridynamics; }

// Per particle, where its links start (CSR offsets): listed bonds, or in FEM mode tet corners.
const std::vector<std::uint32_t>& link_offsets(const WorldState& w) {
  return fem_mode(w) ? w.fem.vertex_offsets : w.bonds.offsets;
}

}  // namespace

std::vector<Domain> split_by_work(const WorldState& w, int ranks) {
  const auto& offsets = link_offsets(w);
  auto domains = split(w.particles.count(), ranks,
                       [&](std::size_t i) { return std::uint64_t{offsets[i]} + kParticleWork * i; });
  for (Domain& d : domains) d.bonds = std::uint64_t{offsets[d.last]} - offsets[d.first];
  return domains;
}

std::vector<Domain> split_by_work(const std::vector<std::uint32_t>& work, int ranks) {
  std::vector<std::uint64_t> before(work.size() + 1, 0);
  for (std::size_t i = 0; i < work.size(); ++i) before[i + 1] = before[i] + work[i];
  return split(work.size(), ranks, [&](std::size_t i) { return before[i]; });
}

std::vector<std::uint32_t> current_work(const WorldState& w, std::uint32_t first, std::uint32_t count) {
  std::vector<std::uint32_t> work(count);
  if (fem_mode(w)) {  // the tet corners: the same work for the whole run
    const auto& offsets = w.fem.vertex_offsets;
    for (std::uint32_t m = 0; m < count; ++m)
      work[m] = offsets[first + m + 1] - offsets[first + m] + static_cast<std::uint32_t>(kParticleWork);
    return work;
  }
  const auto& b = w.bonds;
  const auto& pr = w.contact.pairs;
  const bool contact = w.contact.enabled && pr.valid;
  const auto& tracked = w.embedded.held_tracked;
  for (std::uint32_t m = 0; m < count; ++m) {
    const std::uint32_t i = first + m;
    std::uint32_t alive = 0;
    for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k) alive += b.alive[k] != 0;
    const std::uint32_t held = !tracked.empty() && tracked[i] ? alive / kHeldRotationDivisor : 0u;
    work[m] = alive + static_cast<std::uint32_t>(kParticleWork) + held +
              (contact ? pr.length[i] : 0u);
  }
  return work;
}

std::vector<std::vector<std::uint32_t>> bond_ghosts(const WorldState& w, const std::vector<Domain>& domains) {
  const auto& b = w.bonds;
  const auto& f = w.fem;
  const bool fem = fem_mode(w);
  std::vector<std::vector<std::uint32_t>> ghosts(domains.size());
  tbb::parallel_for(std::size_t{0}, domains.size(), [&](std::size_t r) {
    const Domain& d = domains[r];
    auto& list = ghosts[r];
    auto add = [&](std::uint32_t j) {
      if (j < d.first || j >= d.last) list.push_back(j);
    };
    for (std::uint32_t i = d.first; i < d.last; ++i) {
      if (fem) {  // the other vertices of the tets at vertex i
        for (std::uint32_t k = f.vertex_offsets[i]; k < f.vertex_offsets[i + 1]; ++k)
          for (std::uint32_t v : w.mesh.tets[f.vertex_corners[k] / 4]) add(v);
      } else {
        for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k) add(b.neighbor[k]);
      }
    }
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  });
  return ghosts;
}

void find_ghosts(const WorldState& w, std::vector<Domain>& domains) {
  const std::size_t n = w.particles.count();
  const auto& y = w.particles.position;
  const double reach = w.contact.enabled ? w.contact.largest_distance + w.contact.pairs.skin : 0.0;
  SpatialGrid grid;
  if (reach > 0.0) {
    systems::allocate_grid(grid, n, reach);
    systems::build_grid(grid, y);
  }
  // Owner of every particle, for the neighbour ranks.
  std::vector<std::uint32_t> owner(n);
  for (std::size_t r = 0; r < domains.size(); ++r)
    std::fill(owner.begin() + domains[r].first, owner.begin() + domains[r].last, static_cast<std::uint32_t>(r));
  const auto far_ends = bond_ghosts(w, domains);
  tbb::parallel_for(std::size_t{0}, domains.size(), [&](std::size_t r) {
    Domain& d = domains[r];
    // 1 = bond ghost, 2 = contact ghost only.
    std::vector<std::uint8_t> kind(n, 0);
    for (std::uint32_t j : far_ends[r]) kind[j] = 1;
    if (reach > 0.0) {
      const double reach2 = reach * reach;
      for (std::uint32_t i = d.first; i < d.last; ++i)
        systems::for_each_near(grid, y[i], [&](std::uint32_t q) {
          const std::uint32_t j = grid.sorted[q];
          if ((j >= d.first && j < d.last) || kind[j] != 0) return;
          if ((grid.sorted_position[q] - y[i]).squaredNorm() < reach2) kind[j] = 2;
        });
    }
    d.ghosts.clear();
    d.bond_ghosts = d.contact_ghosts = 0;
    std::vector<std::uint8_t> neighbor(domains.size(), 0);
    for (std::size_t j = 0; j < n; ++j) {
      if (kind[j] == 0) continue;
      d.ghosts.push_back(static_cast<std::uint32_t>(j));
      ++(kind[j] == 1 ? d.bond_ghosts : d.contact_ghosts);
      neighbor[owner[j]] = 1;
    }
    d.neighbor_ranks.clear();
    for (std::size_t s = 0; s < domains.size(); ++s)
      if (neighbor[s]) d.neighbor_ranks.push_back(static_cast<std::uint32_t>(s));
    d.halo_bytes_per_step = std::uint64_t{d.ghosts.size()} * (fem_mode(w) ? kFemGhostBytesPerStep : kGhostBytesPerStep);
  });
}

std::vector<Domain> decompose(const WorldState& w, int ranks) {
  auto domains = split_by_work(w, ranks);
  find_ghosts(w, domains);
  return domains;
}

}  // namespace perifx::distributed
