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

#if defined(__AVX512F__) && defined(__AVX512VL__)
#include <immintrin.h>
#endif

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
// Which slots of a row's bucket range are in the row's cells: keys of the row (y, z), x in
// [x_lo, x_hi], and, in the searching point's own cell of a forward search (after_self), only points
// with index > self.
struct RowFilter {
  std::uint64_t row_key, x_lo, x_hi;
  bool after_self;
  std::uint64_t own_key;
  std::uint32_t self;
};
inline bool in_row(const SpatialGrid& g, const RowFilter& f, std::uint32_t q) {
  const std::uint64_t k = g.sorted_key[q], xk = k & kXMask;
  const bool after = (k != f.own_key) | (g.sorted[q] > f.self);
  return ((k & ~kXMask) == f.row_key) & (xk >= f.x_lo) & (xk <= f.x_hi) & (!f.after_self | after);
}

// Visits, in slot order, the slots q of [from, to) that pass the row filter and whose point lies within
// squared distance radius2 of y (!(d² ≥ radius2): a NaN distance passes, as the callers' own tests let
// it; radius2 = ∞ keeps every slot of the cells). The tests of a chunk of 64 slots are evaluated
// without branches and the passing slots appended to a small buffer, then visited: the branches of a
// per-slot test are mispredicted about half the time, and they were most of a contact search's cost.
// With AVX-512 the tests run on 8 slots at once (three 512-bit loads and two permutes give 8 slots' x,
// y and z; the passing slot numbers are compress-stored in order). The distance is the same IEEE
// expression as Eigen's (d_x² + d_y²) + d_z² of the scalar loop, so both paths pass the same slots.
template <class Visit>
inline void scan_range(const SpatialGrid& g, std::uint32_t from, std::uint32_t to, const Vec3& y, double radius2,
                       const RowFilter& f, Visit&& visit) {
  constexpr std::uint32_t kChunk = 64;
  alignas(64) std::uint32_t hits[kChunk];
  for (std::uint32_t base = from; base < to; base += kChunk) {
    const std::uint32_t end = std::min(to, base + kChunk);
    std::uint32_t count = 0;
    std::uint32_t q = base;
#if defined(__AVX512F__) && defined(__AVX512VL__)
    const double* const pos = g.sorted_position.data()->data();
    const __m512d yx = _mm512_set1_pd(y.x()), yy = _mm512_set1_pd(y.y()), yz = _mm512_set1_pd(y.z());
    const __m512d r2 = _mm512_set1_pd(radius2);
    const __m512i row_key = _mm512_set1_epi64(static_cast<long long>(f.row_key));
    const __m512i x_mask = _mm512_set1_epi64(static_cast<long long>(kXMask));
    const __m512i x_lo = _mm512_set1_epi64(static_cast<long long>(f.x_lo));
    const __m512i x_hi = _mm512_set1_epi64(static_cast<long long>(f.x_hi));
    const __m512i own_key = _mm512_set1_epi64(static_cast<long long>(f.own_key));
    const __m256i self = _mm256_set1_epi32(static_cast<int>(f.self));
    // Slot j's x, y, z sit at doubles 3j, 3j + 1, 3j + 2 of the three loaded vectors (0–7, 8–15,
    // 16–23): the first permute takes the lanes that lie in the first two (x: lanes 0–5, y and z:
    // 0–4), the second keeps those and takes the rest from the third (index 8 + position there).
    const __m512i x_01 = _mm512_set_epi64(0, 0, 15, 12, 9, 6, 3, 0), x_2 = _mm512_set_epi64(13, 10, 5, 4, 3, 2, 1, 0);
    const __m512i y_01 = _mm512_set_epi64(0, 0, 0, 13, 10, 7, 4, 1), y_2 = _mm512_set_epi64(14, 11, 8, 4, 3, 2, 1, 0);
    const __m512i z_01 = _mm512_set_epi64(0, 0, 0, 14, 11, 8, 5, 2), z_2 = _mm512_set_epi64(15, 12, 9, 4, 3, 2, 1, 0);
    const __m256i lane = _mm256_set_epi32(7, 6, 5, 4, 3, 2, 1, 0);
    for (; q + 8 <= end; q += 8) {
      const double* p = pos + 3 * std::size_t(q);
      const __m512d v0 = _mm512_loadu_pd(p), v1 = _mm512_loadu_pd(p + 8), v2 = _mm512_loadu_pd(p + 16);
      const __m512d px = _mm512_permutex2var_pd(_mm512_permutex2var_pd(v0, x_01, v1), x_2, v2);
      const __m512d py = _mm512_permutex2var_pd(_mm512_permutex2var_pd(v0, y_01, v1), y_2, v2);
      const __m512d pz = _mm512_permutex2var_pd(_mm512_permutex2var_pd(v0, z_01, v1), z_2, v2);
      const __m512d dx = _mm512_sub_pd(px, yx), dy = _mm512_sub_pd(py, yy), dz = _mm512_sub_pd(pz, yz);
      const __m512d d2 = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(dx, dx), _mm512_mul_pd(dy, dy)), _mm512_mul_pd(dz, dz));
      __mmask8 m = _mm512_cmp_pd_mask(d2, r2, _CMP_NGE_UQ);
      const __m512i k = _mm512_loadu_si512(g.sorted_key.data() + q);
      const __m512i xk = _mm512_and_si512(k, x_mask);
      m &= _mm512_cmpeq_epu64_mask(_mm512_andnot_si512(x_mask, k), row_key);
      m &= _mm512_cmpge_epu64_mask(xk, x_lo) & _mm512_cmple_epu64_mask(xk, x_hi);
      if (f.after_self) {
        const __m256i idx = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(g.sorted.data() + q));
        m &= _mm512_cmpneq_epu64_mask(k, own_key) | _mm256_cmpgt_epu32_mask(idx, self);
      }
      _mm256_mask_compressstoreu_epi32(hits + count, m, _mm256_add_epi32(lane, _mm256_set1_epi32(static_cast<int>(q))));
      count += static_cast<std::uint32_t>(__builtin_popcount(m));
    }
#endif
    for (; q < end; ++q) {
      const Vec3 d = g.sorted_position[q] - y;
      const bool near = !(d.squaredNorm() >= radius2);
      hits[count] = q;
      count += static_cast<std::uint32_t>(near & in_row(g, f, q));
    }
    for (std::uint32_t h = 0; h < count; ++h) visit(hits[h]);
  }
}

// Cells [x_first, x_first + cells) of the row (dy, dz) around cell ci: scan_range over the (one or,
// where the row wraps around the end of the table, several) bucket ranges that hold them. after_self:
// in ci itself only the points with index > self (RowFilter).
template <class Visit>
inline void scan_row(const SpatialGrid& g, const Cell& ci, std::int32_t dx_first, std::int32_t cells, std::int32_t dy,
                     std::int32_t dz, const Vec3& y, double radius2, bool after_self, std::uint32_t self,
                     Visit&& visit) {
  const Cell first = {ci.x + dx_first, ci.y + dy, ci.z + dz};
  const std::uint64_t x_lo = key(first) & kXMask;
  const RowFilter f{key(first) & ~kXMask, x_lo, x_lo + std::uint64_t(cells - 1), after_self, key(ci), self};
  const std::uint32_t b0 = hash(first, g.mask);
  if (b0 + std::uint32_t(cells) - 1 <= g.mask) {
    scan_range(g, g.start[b0], g.start[b0 + std::uint32_t(cells)], y, radius2, f, visit);
  } else {  // the row wraps around the end of the table
    for (std::uint32_t t = 0; t < std::uint32_t(cells); ++t) {
      const std::uint32_t bk = (b0 + t) & g.mask;
      scan_range(g, g.start[bk], g.start[bk + 1], y, radius2, f, visit);
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
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy) grid_detail::scan_row(g, ci, -1, 3, dy, dz, y, radius2, false, 0, visit);
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
  grid_detail::scan_row(g, ci, 0, 2, 0, 0, y, radius2, true, self, visit);  // own cell (index > self), next
  grid_detail::scan_row(g, ci, -1, 3, 1, 0, y, radius2, false, self, visit);
  for (std::int32_t dy = -1; dy <= 1; ++dy) grid_detail::scan_row(g, ci, -1, 3, dy, 1, y, radius2, false, self, visit);
}

template <class Visit>
void for_each_near_forward(const SpatialGrid& g, const Vec3& y, std::uint32_t self, Visit&& visit) {
  for_each_within_forward(g, y, self, std::numeric_limits<double>::infinity(), visit);
}

// Setup: sizes every buffer for n points and the given cell edge (allocates).
void allocate_grid(SpatialGrid& grid, std::size_t n, double cell_edge);
// Sorts the n points (n as allocated) into the grid; parallel cells, serial counting sort. No allocation.
void build_grid(SpatialGrid& grid, const std::vector<Vec3>& points);
// Sorts the points subset[0..) (at most as many as allocated) into the grid, which then names them by
// their index in `points` (sorted[q] = subset[a]). The table is sized for the subset (≥ 2 entries per
// point, ≥ 1024, at most as allocated), so a small subset in a large allocation clears a small table.
// Stable: slots of a bucket in subset order. No allocation.
void build_grid_of(SpatialGrid& grid, const std::vector<Vec3>& points, const std::vector<std::uint32_t>& subset);

}  // namespace perifx::systems
