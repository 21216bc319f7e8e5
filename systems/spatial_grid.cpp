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

void build_grid(SpatialGrid& g, const std::vector<Vec3>& points) {
  auto& [cell, mask, cell_of, bucket, start, cursor, sorted, sorted_key, sorted_position] = g;
  const std::size_t n = sorted.size();
  const double inv_cell = 1.0 / cell;
  // 1. Cells and buckets (parallel), 2. counting sort (serial, stable, O(n + table)).
  parallel_for_each(n, [&](std::size_t i) {
    const Cell c = cell_at(points[i], inv_cell);
    cell_of[i] = key(c);
    bucket[i] = hash(c, mask);
  }, 4096);
  std::fill(start.begin(), start.end(), 0u);
  for (std::size_t i = 0; i < n; ++i) ++start[bucket[i] + 1];
  for (std::size_t k = 1; k < start.size(); ++k) start[k] += start[k - 1];
  std::copy(start.begin(), start.end() - 1, cursor.begin());
  for (std::size_t i = 0; i < n; ++i) sorted[cursor[bucket[i]]++] = static_cast<std::uint32_t>(i);
  parallel_for_each(n, [&](std::size_t q) {
    sorted_key[q] = cell_of[sorted[q]];
    sorted_position[q] = points[sorted[q]];
  }, 4096);
}

void build_grid_of(SpatialGrid& g, const std::vector<Vec3>& points, const std::vector<std::uint32_t>& subset) {
  auto& [cell, mask, cell_of, bucket, start, cursor, sorted, sorted_key, sorted_position] = g;
  const std::size_t n = subset.size(), room = start.size() - 1;
  std::uint32_t table = 1024;
  while (table < 2 * n && table < room) table <<= 1;
  mask = table - 1;
  const double inv_cell = 1.0 / cell;
  // As build_grid, over the subset's entries a (point subset[a]); the sort moves entry numbers, which
  // the last pass turns into point indices.
  parallel_for_each(n, [&](std::size_t a) {
    const Cell c = cell_at(points[subset[a]], inv_cell);
    cell_of[a] = key(c);
    bucket[a] = hash(c, mask);
  }, 4096);
  std::fill(start.begin(), start.begin() + table + 1, 0u);
  for (std::size_t a = 0; a < n; ++a) ++start[bucket[a] + 1];
  for (std::size_t k = 1; k <= table; ++k) start[k] += start[k - 1];
  std::copy(start.begin(), start.begin() + table, cursor.begin());
  for (std::size_t a = 0; a < n; ++a) sorted[cursor[bucket[a]]++] = static_cast<std::uint32_t>(a);
  parallel_for_each(n, [&](std::size_t q) {
    const std::uint32_t a = sorted[q];
    sorted_key[q] = cell_of[a];
    sorted_position[q] = points[subset[a]];
    sorted[q] = subset[a];
  }, 4096);
}

}  // namespace perifx::systems
