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
#include <limits>
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


namespace grid_detail {
// Visits, in slot order, the slots q of [from, to) whose key passes `in_cells(key, q)` and whose point
// lies within squared distance radius2 of y (!(d² ≥ radius2): a NaN distance passes, as the callers'
// own tests let it; radius2 = ∞ keeps every slot of the cells). The tests of a chunk of 64 slots are
// evaluated without branches and the passing slots appended to a small buffer, then visited: the
// branches of a per-slot test are mispredicted about half the time, and they were most of a contact
// search's cost.
template <class InCells, class Visit>
inline void scan_range(const SpatialGrid& g, std::uint32_t from, std::uint32_t to, const Vec3& y, double radius2,
                       InCells&& in_cells, Visit&& visit) {
  constexpr std::uint32_t kChunk = 64;
  std::uint32_t hits[kChunk];
  for (std::uint32_t base = from; base < to; base += kChunk) {
    const std::uint32_t end = std::min(to, base + kChunk);
    std::uint32_t count = 0;
    for (std::uint32_t q = base; q < end; ++q) {
      const Vec3 d = g.sorted_position[q] - y;
      const bool near = !(d.squaredNorm() >= radius2);
      hits[count] = q;
      count += static_cast<std::uint32_t>(near & in_cells(g.sorted_key[q], q));
    }
    for (std::uint32_t h = 0; h < count; ++h) visit(hits[h]);
  }
}

// Cells [x_first, x_first + cells) of the row (dy, dz) around cell ci: scan_range over the (one or,
// where the row wraps around the end of the table, several) bucket ranges that hold them.
template <class InCells, class Visit>
inline void scan_row(const SpatialGrid& g, const Cell& ci, std::int32_t dx_first, std::int32_t cells, std::int32_t dy,
                     std::int32_t dz, const Vec3& y, double radius2, InCells&& in_row, Visit&& visit) {
  const Cell first = {ci.x + dx_first, ci.y + dy, ci.z + dz};
  const std::uint64_t row_key = key(first) & ~kXMask;
  const std::uint64_t x_lo = key(first) & kXMask, x_hi = x_lo + std::uint64_t(cells - 1);
  auto in_cells = [&](std::uint64_t k, std::uint32_t q) {
    const std::uint64_t xk = k & kXMask;
    return ((k & ~kXMask) == row_key) & (xk >= x_lo) & (xk <= x_hi) & in_row(k, q);
  };
  const std::uint32_t b0 = hash(first, g.mask);
  if (b0 + std::uint32_t(cells) - 1 <= g.mask) {
    scan_range(g, g.start[b0], g.start[b0 + std::uint32_t(cells)], y, radius2, in_cells, visit);
  } else {  // the row wraps around the end of the table
    for (std::uint32_t t = 0; t < std::uint32_t(cells); ++t) {
      const std::uint32_t bk = (b0 + t) & g.mask;
      scan_range(g, g.start[bk], g.start[bk + 1], y, radius2, in_cells, visit);
    }
  }
}
}  // namespace grid_detail

// Calls visit(q) for every sorted slot q whose point lies in one of the 27 cells around y's cell and
// within squared distance radius2 of y, in a fixed order (9 rows (z, then y, from −1 to +1) of 3 cells;
// by slot inside a row). The point is sorted[q], at sorted_position[q]; y's own point is visited too.
template <class Visit>
void for_each_within(const SpatialGrid& g, const Vec3& y, double radius2, Visit&& visit) {
  const Cell ci = cell_at(y, 1.0 / g.cell);
  auto any = [](std::uint64_t, std::uint32_t) { return true; };
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy) grid_detail::scan_row(g, ci, -1, 3, dy, dz, y, radius2, any, visit);
}

// Every slot of the 27 cells around y's cell (for_each_within without the distance filter); the caller
// applies its own tests.
template <class Visit>
void for_each_near(const SpatialGrid& g, const Vec3& y, Visit&& visit) {
  for_each_within(g, y, std::numeric_limits<double>::infinity(), visit);
}

// The forward half of the 27 cells, for a search that must find each pair once: the nine cells of the
// row layer above (dz = +1), the three of the next row (dz = 0, dy = +1), the next cell of y's own row
// (dx = +1), and in y's own cell only the points with index > self. For any two cells, exactly one
// lies in the other's forward half (the offsets o and −o are never both in it), so a pair within one
// cell's reach is visited from exactly one of its ends. Fixed order, as for_each_within.
template <class Visit>
void for_each_within_forward(const SpatialGrid& g, const Vec3& y, std::uint32_t self, double radius2, Visit&& visit) {
  const Cell ci = cell_at(y, 1.0 / g.cell);
  const std::uint64_t own_key = key(ci);
  auto after_self = [&](std::uint64_t k, std::uint32_t q) { return (k != own_key) | (g.sorted[q] > self); };
  auto any = [](std::uint64_t, std::uint32_t) { return true; };
  grid_detail::scan_row(g, ci, 0, 2, 0, 0, y, radius2, after_self, visit);  // own cell (index > self), next
  grid_detail::scan_row(g, ci, -1, 3, 1, 0, y, radius2, any, visit);
  for (std::int32_t dy = -1; dy <= 1; ++dy) grid_detail::scan_row(g, ci, -1, 3, dy, 1, y, radius2, any, visit);
}

template <class Visit>
void for_each_near_forward(const SpatialGrid& g, const Vec3& y, std::uint32_t self, Visit&& visit) {
  for_each_within_forward(g, y, self, std::numeric_limits<double>::infinity(), visit);
}

// Setup: sizes every buffer for n points and the given cell edge (allocates).
void allocate_grid(SpatialGrid& grid, std::size_t n, double cell_edge);
// Sorts the n points (n as allocated) into the grid; parallel cells, serial counting sort. No allocation.
void build_grid(SpatialGrid& grid, const std::vector<Vec3>& points);

}  // namespace perifx::systems
