// Spatial hash grid: setup sizing and the build (spatial_grid.hpp explains the layout).
#include "spatial_grid.hpp"

#include "parallel.hpp"

namespace perifx::systems {

void allocate_grid(SpatialGrid& g, std::size_t n, double cell_edge) {
  auto& [cell, mask, cell_of, bucket, start, cursor, sorted, sorted_key, sorted_position] = g;
  cell = cell_edge;
  std::uint32_t table = 1024;
  while (table < 2 * n) table <<= 1;
  mask = table - 1;
  cell_of.resize(n);
  bucket.resize(n);
  sorted.resize(n);
  sorted_key.resize(n);
  sorted_position.assign(n, Vec3::Zero());  // Eigen leaves a resized Vec3 unset (checkpoints save it)
  start.assign(table + 1, 0);
  cursor.assign(table, 0);
}

namespace {

// The build of both entry points: entries a = 0..n−1 are the points point_of(a), sorted into a table of
// `table` buckets (≤ as allocated). 1. Cells and buckets (parallel), 2. counting sort (serial, stable,
// O(n + table)) of the entry numbers, 3. each slot's key, position and point index (parallel).
template <class PointOf>
void sort_into_grid(SpatialGrid& g, const std::vector<Vec3>& points, std::size_t n, std::uint32_t table,
                    PointOf point_of) {
  auto& [cell, mask, cell_of, bucket, start, cursor, sorted, sorted_key, sorted_position] = g;
  mask = table - 1;
  const double inv_cell = 1.0 / cell;
  parallel_for_each(n, [&](std::size_t a) {
    const Cell c = cell_at(points[point_of(a)], inv_cell);
    cell_of[a] = key(c);
    bucket[a] = hash(c, mask);
  }, 4096);
  std::fill(start.begin(), start.begin() + table + 1, 0u);
  for (std::size_t a = 0; a < n; ++a) ++start[bucket[a] + 1];
  for (std::size_t k = 1; k <= table; ++k) start[k] += start[k - 1];
  std::copy(start.begin(), start.begin() + table, cursor.begin());
  for (std::size_t a = 0; a < n; ++a) sorted[cursor[bucket[a]]++] = static_cast<std::uint32_t>(a);
  parallel_for_each(n, [&](std::size_t q) {
    const std::uint32_t a = sorted[q], i = point_of(a);
    sorted_key[q] = cell_of[a];
    sorted_position[q] = points[i];
    sorted[q] = i;
  }, 4096);
}

}  // namespace

void build_grid(SpatialGrid& g, const std::vector<Vec3>& points) {
  sort_into_grid(g, points, g.sorted.size(), static_cast<std::uint32_t>(g.start.size() - 1),
                 [](std::size_t a) { return static_cast<std::uint32_t>(a); });
}

void build_grid_of(SpatialGrid& g, const std::vector<Vec3>& points, const std::vector<std::uint32_t>& subset) {
  const std::size_t n = subset.size(), room = g.start.size() - 1;
  std::uint32_t table = 1024;
  while (table < 2 * n && table < room) table <<= 1;
  sort_into_grid(g, points, n, table, [&subset](std::size_t a) { return subset[a]; });
}

}  // namespace perifx::systems
