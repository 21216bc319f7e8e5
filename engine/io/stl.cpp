// STL input, ASCII and binary. STL stores each triangle's corners separately, so coincident corners
// are welded into shared vertices here.
#include "io/stl.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <unordered_map>
#include <vector>

#include "io/atomic.hpp"
#include "io/text.hpp"

namespace perifx::io {

namespace fs = std::filesystem;

namespace {

using detail::TokenLines;
using Triangle = std::array<std::uint32_t, 3>;

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c);
  return s;
}

// ---------------------------------------------------------------------------------------------
// Welding (STL stores each triangle's corners separately)
// ---------------------------------------------------------------------------------------------

struct CellKey {
  std::int64_t x, y, z;
  bool operator==(const CellKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct CellHash {
  std::size_t operator()(const CellKey& k) const {
    const auto h = static_cast<std::uint64_t>(k.x) * 0x9E3779B97F4A7C15ULL ^
                   static_cast<std::uint64_t>(k.y) * 0xC2B2AE3D27D4EB4FULL ^
                   static_cast<std::uint64_t>(k.z) * 0x165667B19E3779F9ULL;
    return static_cast<std::size_t>(h ^ (h >> 29));
  }
};

// Merges corners closer than 1e-6 of the bounding-box diagonal (on a hash grid of that cell size,
// searching the 27 cells around each point) and drops triangles that collapse to a line or point.
TriangleSurface weld(const std::vector<Vec3>& corners) {
  TriangleSurface s;
  if (corners.empty()) return s;
  Vec3 lo = corners[0], hi = corners[0];
  for (const Vec3& p : corners) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double diag = (hi - lo).norm();
  const double tol = diag > 0.0 ? 1e-6 * diag : 1.0;
  auto cell = [&](const Vec3& p) {
    return CellKey{static_cast<std::int64_t>(std::floor((p.x() - lo.x()) / tol)),
                   static_cast<std::int64_t>(std::floor((p.y() - lo.y()) / tol)),
                   static_cast<std::int64_t>(std::floor((p.z() - lo.z()) / tol))};
  };
  std::unordered_map<CellKey, std::vector<std::uint32_t>, CellHash> grid;
  std::vector<std::uint32_t> index(corners.size());
  for (std::size_t i = 0; i < corners.size(); ++i) {
    const Vec3& p = corners[i];
    const CellKey c = cell(p);
    std::uint32_t found = UINT32_MAX;
    for (std::int64_t dx = -1; dx <= 1 && found == UINT32_MAX; ++dx) {
      for (std::int64_t dy = -1; dy <= 1 && found == UINT32_MAX; ++dy) {
        for (std::int64_t dz = -1; dz <= 1 && found == UINT32_MAX; ++dz) {
          const auto it = grid.find(CellKey{c.x + dx, c.y + dy, c.z + dz});
          if (it == grid.end()) continue;
          for (std::uint32_t v : it->second) {
            if ((s.vertices[v] - p).norm() <= tol) {
              found = v;
              break;
            }
          }
        }
      }
    }
    if (found == UINT32_MAX) {
      found = static_cast<std::uint32_t>(s.vertices.size());
      s.vertices.push_back(p);
      grid[c].push_back(found);
    }
    index[i] = found;
  }
  for (std::size_t t = 0; t + 2 < corners.size(); t += 3) {
    const Triangle tri = {index[t], index[t + 1], index[t + 2]};
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) continue;
    s.triangles.push_back(tri);
  }
  return s;
}

// ---------------------------------------------------------------------------------------------
// ASCII
// ---------------------------------------------------------------------------------------------

TriangleSurface read_stl_ascii(const fs::path& file, std::string text) {
  TokenLines in(file.string(), std::move(text), 0, 0, '\0');
  std::vector<std::string_view> tok;
  std::vector<Vec3> corners, loop;
  bool in_loop = false;
  while (in.next(tok)) {
    const std::string k = lower(std::string(tok[0]));
    if (k == "vertex") {
      if (!in_loop) in.fail("'vertex' outside an 'outer loop'");
      if (tok.size() < 4) in.fail("a vertex line needs 'vertex x y z'");
      loop.emplace_back(in.real(tok[1], "x coordinate"), in.real(tok[2], "y coordinate"), in.real(tok[3], "z coordinate"));
    } else if (k == "outer") {
      in_loop = true;
      loop.clear();
    } else if (k == "endloop") {
      if (!in_loop) in.fail("'endloop' without 'outer loop'");
      if (loop.size() < 3) in.fail("a facet needs at least 3 vertices, found " + std::to_string(loop.size()));
      for (std::size_t i = 1; i + 1 < loop.size(); ++i) {
        corners.push_back(loop[0]);
        corners.push_back(loop[i]);
        corners.push_back(loop[i + 1]);
      }
      in_loop = false;
    } else if (k != "solid" && k != "endsolid" && k != "facet" && k != "endfacet") {
      in.fail("unexpected '" + std::string(tok[0]) + "' in an ASCII STL file");
    }
  }
  if (in_loop) in.fail_truncated("the last 'outer loop' has no 'endloop'");
  return weld(corners);
}

}  // namespace

TriangleSurface read_stl(const fs::path& file) {
  const std::string name = file.string();
  std::string data = read_file(file, "STL surface");
  // Binary: 80-byte header, uint32 count, 50 bytes per triangle. Some binary files start with "solid"
  // too, so the size decides first.
  if (data.size() >= 84) {
    std::uint32_t n = 0;
    std::memcpy(&n, data.data() + 80, 4);
    if (data.size() == 84 + 50 * static_cast<std::uint64_t>(n)) {
      std::vector<Vec3> corners;
      corners.reserve(3 * static_cast<std::size_t>(n));
      for (std::uint32_t t = 0; t < n; ++t) {
        const char* p = data.data() + 84 + 50 * static_cast<std::size_t>(t) + 12;  // skip the normal
        for (int c = 0; c < 3; ++c) {
          float xyz[3];
          std::memcpy(xyz, p + 12 * c, 12);
          const Vec3 v(xyz[0], xyz[1], xyz[2]);
          if (!v.allFinite()) throw ReadError(name + ": triangle " + std::to_string(t) + " has a non-finite coordinate");
          corners.push_back(v);
        }
      }
      return weld(corners);
    }
  }
  std::size_t first = data.find_first_not_of(" \t\r\n");
  if (first == std::string::npos || lower(data.substr(first, 5)) != "solid") {
    throw ReadError(name + ": not an STL file (binary size does not match its triangle count, and it does not "
                        "start with 'solid')");
  }
  return read_stl_ascii(file, std::move(data));
}

}  // namespace perifx::io
