// Spatial hash grid, the data: which points lie in which cell of a hashed uniform grid. One grid type
// serves the family build and the contact pair list; the algorithms (allocate, build, the
// neighbourhood visit) are in systems/spatial_grid.hpp, which explains the hashing.
//
// Array shapes (n = points, table = mask + 1):
//   cell_of, bucket             n      per point: packed cell key (3 × 21 bits), bucket
//   start                       table+1  bucket b holds sorted slots [start[b], start[b+1])
//   cursor                      table  scatter cursor of the counting sort
//   sorted, sorted_key,         n      per sorted slot q: the point index, its cell key and its
//   sorted_position                    position at the build (the visit reads them as streams)
#pragma once
#include <cstdint>
#include <vector>

#include "components/math.hpp"

namespace perifx {

struct SpatialGrid {
  double cell = 0.0;                      // cell edge, m: every pair closer than this is visited
  std::uint32_t mask = 0;                 // table − 1
  std::vector<std::uint64_t> cell_of;
  std::vector<std::uint32_t> bucket;
  std::vector<std::uint32_t> start;
  std::vector<std::uint32_t> cursor;
  std::vector<std::uint32_t> sorted;
  std::vector<std::uint64_t> sorted_key;
  std::vector<Vec3> sorted_position;
};

}  // namespace perifx
