// OFF input (also COFF/NOFF): counts, vertex lines, then polygons (split into fans).
#include "io/off.hpp"

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "io/text.hpp"

namespace perifx::io {

namespace fs = std::filesystem;

namespace {

using detail::TokenLines;

bool ends_with(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

void add_fan(TriangleSurface& s, const std::vector<std::uint32_t>& polygon) {
  for (std::size_t i = 1; i + 1 < polygon.size(); ++i) s.triangles.push_back({polygon[0], polygon[i], polygon[i + 1]});
}

}  // namespace

TriangleSurface read_off(const fs::path& file) {
  TokenLines in(file, "OFF surface", '#');
  std::vector<std::string_view> tok;
  if (!in.next(tok)) in.fail_truncated("empty file");
  std::size_t first = 0;
  if (ends_with(tok[0], "OFF")) {
    if (tok[0].find('4') != std::string_view::npos || tok[0].find('n') != std::string_view::npos) {
      in.fail("'" + std::string(tok[0]) + "' is not a 3-D OFF file");
    }
    first = 1;
  }
  if (tok.size() <= first) {  // counts on their own line
    if (!in.next(tok)) in.fail_truncated("missing '<vertices> <faces> <edges>'");
    first = 0;
  }
  if (tok.size() < first + 2) in.fail("expected '<vertices> <faces> [<edges>]'");
  const long long nv = in.integer(tok[first], "vertex count");
  const long long nf = in.integer(tok[first + 1], "face count");
  if (nv < 0 || nv > static_cast<long long>(UINT32_MAX) || nf < 0) in.fail("vertex or face count out of range");
  TriangleSurface s;
  in.check_fits(nv + nf, 6, "vertex and face count");  // "x y z\n", "3 a b c\n"
  s.vertices.reserve(static_cast<std::size_t>(nv));
  for (long long k = 0; k < nv; ++k) {
    if (!in.next(tok)) in.fail_truncated("expected " + std::to_string(nv) + " vertices, found " + std::to_string(k));
    if (tok.size() < 3) in.fail("a vertex line needs 'x y z', found " + std::to_string(tok.size()) + " fields");
    s.vertices.emplace_back(in.real(tok[0], "x coordinate"), in.real(tok[1], "y coordinate"), in.real(tok[2], "z coordinate"));
  }
  std::vector<std::uint32_t> polygon;
  for (long long k = 0; k < nf; ++k) {
    if (!in.next(tok)) in.fail_truncated("expected " + std::to_string(nf) + " faces, found " + std::to_string(k));
    const long long n = in.integer(tok[0], "corner count");
    if (n < 3) in.fail("a face needs at least 3 vertices, found " + std::to_string(n));
    if (static_cast<long long>(tok.size()) < 1 + n) in.fail("face has " + std::to_string(tok.size() - 1) + " indices, expected " + std::to_string(n));
    polygon.clear();
    for (long long i = 0; i < n; ++i) {
      const long long v = in.integer(tok[static_cast<std::size_t>(1 + i)], "vertex index");
      if (v < 0 || v >= nv) in.fail("vertex index " + std::to_string(v) + " is out of range (vertices are 0.." + std::to_string(nv - 1) + ")");
      polygon.push_back(static_cast<std::uint32_t>(v));
    }
    add_fan(s, polygon);
  }
  return s;
}

}  // namespace perifx::io
