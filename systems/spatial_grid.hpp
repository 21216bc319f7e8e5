// Spatial hash grid: "which points lie near y?", written once for the family build (family_build.cpp,
// reference positions, once at setup) and the contact pair list (contact.cpp, current positions,
// rebuilt when particles have moved); ContactState::grid is one. The grid's data is components/spatial_grid.hpp.
//
// A hashed uniform grid of cell edge `cell`: point p lies in cell floor(p / cell) (coordinates clamped
// to ±kCellLimit, so a point flung far away shares a far cell instead of overflowing the key; the
// caller's distance test still rejects it). Cells hash into a power-of-two table of ≥ 2·points buckets
// as bucket = (x + h(y, z)) mod table, so the cells x−1, x, x+1 of a row are three consecutive buckets
// and one range of the sorted array holds all three. A counting sort groups the points by bucket,
// stable (increasing point index inside a bucket), so the visit order is fixed by the input alone:
// results do not depend on the thread count.
//
// allocate_grid() sizes every buffer once; build_grid() then never allocates, so contact can rebuild
// inside a step. for_each_near() is an inline template: it is the inner loop of the contact list build.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "components/spatial_grid.hpp"

namespace perifx::systems {

// Cell coordinates fit 21 bits with their ±1 neighbours.
inline constexpr std::int32_t kCellLimit = (1 << 20) - 2;
inline constexpr std::uint64_t kXMask = (1u << 21) - 1;  // the x field of a packed key

struct Cell {
  std::int32_t x, y, z;
};
inline Cell cell_at(const Vec3& p, double inv_cell) {
  auto axis = [&](double v) {
    return static_cast<std::int32_t>(std::clamp(std::floor(v * inv_cell), double(-kCellLimit), double(kCellLimit)));
  };
  return {axis(p.x()), axis(p.y()), axis(p.z())};
}
inline std::uint64_t key(const Cell& c) {
  constexpr std::uint64_t mask = (1u << 21) - 1, bias = 1u << 20;
  return ((static_cast<std::uint64_t>(c.x + bias) & mask)) | ((static_cast<std::uint64_t>(c.y + bias) & mask) << 21) |
         ((static_cast<std::uint64_t>(c.z + bias) & mask) << 42);
}
// x plus a scrambled hash of the row (y, z).
inline std::uint32_t hash(const Cell& c, std::uint32_t table_mask) {
  const std::uint32_t row = (static_cast<std::uint32_t>(c.y) * 73856093u) ^ (static_cast<std::uint32_t>(c.z) * 19349663u);
  return (static_cast<std::uint32_t>(c.x) + row) & table_mask;
}


// Calls visit(q) for every sorted slot q whose point lies in one of the 27 cells around y's cell,
// in a fixed order (9 rows (z, then y, from −1 to +1) of 3 cells; by slot inside a row). The point is
// sorted[q], at sorted_position[q]; the caller applies its own distance test (and skips y's own point).
template <class Visit>
void for_each_near(const SpatialGrid& g, const Vec3& y, Visit&& visit) {
const auto& sorted_key = g.sorted_key;
const auto& start = g.start;
const std::uint32_t mask = g.mask;
  const Cell ci = cell_at(y, 1.0 / g.cell);
  const std::uint64_t xi_key = key(ci) & kXMask;
  auto scan = [&](std::uint32_t first, std::uint32_t last, std::uint64_t row_key) {
    for (std::uint32_t q = first; q < last; ++q) {
      const std::uint64_t k = sorted_key[q];
      // Same row, and x within one cell (other rows hashed to these buckets are skipped).
      if ((k & ~kXMask) != row_key) continue;
      const std::uint64_t xk = k & kXMask;
      if (xk + 1 < xi_key || xk > xi_key + 1) continue;
      visit(q);
    }
  };
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy) {
      const Cell left = {ci.x - 1, ci.y + dy, ci.z + dz};
      const std::uint64_t row_key = key(left) & ~kXMask;
      const std::uint32_t b0 = hash(left, mask);
      if (b0 + 2 <= mask) {
        scan(start[b0], start[b0 + 3], row_key);
      } else {  // the row wraps around the end of the table
        for (std::uint32_t t = 0; t < 3; ++t) {
          const std::uint32_t bk = (b0 + t) & mask;
          scan(start[bk], start[bk + 1], row_key);
        }
      }
    }
}

// Setup: sizes every buffer for n points and the given cell edge (allocates).
// The forward half of for_each_near's 27 cells, for a search that must find each pair once: the nine
// cells of the row layer above (dz = +1), the three of the next row (dz = 0, dy = +1), the next cell of
// y's own row (dx = +1), and in y's own cell only the points with index > self. For any two cells,
// exactly one lies in the other's forward half (the offsets o and −o are never both in it), so a pair
// within one cell's reach is visited from exactly one of its ends. Fixed order, as for_each_near.
template <class Visit>
void for_each_near_forward(const SpatialGrid& g, const Vec3& y, std::uint32_t self, Visit&& visit) {
  const auto& sorted_key = g.sorted_key;
  const auto& start = g.start;
  const std::uint32_t mask = g.mask;
  const Cell ci = cell_at(y, 1.0 / g.cell);
  const std::uint64_t own_key = key(ci);
  // Cells [x_first, x_first + cells) of the row (dy, dz) around y's cell.
  auto row = [&](std::int32_t dx_first, std::int32_t cells, std::int32_t dy, std::int32_t dz) {
    const Cell first = {ci.x + dx_first, ci.y + dy, ci.z + dz};
    const std::uint64_t row_key = key(first) & ~kXMask;
    const std::uint64_t x_lo = key(first) & kXMask, x_hi = x_lo + std::uint64_t(cells - 1);
    auto scan = [&](std::uint32_t from, std::uint32_t to) {
      for (std::uint32_t q = from; q < to; ++q) {
        const std::uint64_t k = sorted_key[q];
        if ((k & ~kXMask) != row_key) continue;
        const std::uint64_t xk = k & kXMask;
        if (xk < x_lo || xk > x_hi) continue;
        if (k == own_key && g.sorted[q] <= self) continue;
        visit(q);
      }
    };
    const std::uint32_t b0 = hash(first, mask);
    if (b0 + std::uint32_t(cells) - 1 <= mask) {
      scan(start[b0], start[b0 + std::uint32_t(cells)]);
    } else {  // the row wraps around the end of the table
      for (std::uint32_t t = 0; t < std::uint32_t(cells); ++t) {
        const std::uint32_t bk = (b0 + t) & mask;
        scan(start[bk], start[bk + 1]);
      }
    }
  };
  row(0, 2, 0, 0);  // y's own cell (index > self) and the next one
  row(-1, 3, 1, 0);
  for (std::int32_t dy = -1; dy <= 1; ++dy) row(-1, 3, dy, 1);
}

void allocate_grid(SpatialGrid& grid, std::size_t n, double cell_edge);
// Sorts the n points (n as allocated) into the grid; parallel cells, serial counting sort. No allocation.
void build_grid(SpatialGrid& grid, const std::vector<Vec3>& points);

}  // namespace perifx::systems
