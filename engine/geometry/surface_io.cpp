// Closed-surface file input: OBJ, PLY (ASCII and binary), STL (ASCII and binary) and OFF. The readers
// only parse; check_closed_surface (surface_mesh.cpp) decides whether the surface bounds a solid.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "geometry/mesh_text.hpp"

namespace perifx::geometry {

namespace {

using detail::TokenLines;
using Triangle = std::array<std::uint32_t, 3>;

bool ends_with(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c);
  return s;
}

// Splits a polygon into a fan of triangles around its first corner.
void add_fan(SurfaceMesh& s, const std::vector<std::uint32_t>& polygon) {
  for (std::size_t i = 1; i + 1 < polygon.size(); ++i) s.triangles.push_back({polygon[0], polygon[i], polygon[i + 1]});
}

void require_triangles(const SurfaceMesh& s, const std::filesystem::path& file) {
  if (s.triangles.empty()) throw GeometryError(file.string() + ": no faces in the file");
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
SurfaceMesh weld(const std::vector<Vec3>& corners) {
  SurfaceMesh s;
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
// PLY
// ---------------------------------------------------------------------------------------------

enum class Scalar { i8, u8, i16, u16, i32, u32, f32, f64 };

bool scalar_of(std::string_view name, Scalar& out) {
  static const std::pair<std::string_view, Scalar> kNames[] = {
      {"char", Scalar::i8},    {"int8", Scalar::i8},     {"uchar", Scalar::u8},   {"uint8", Scalar::u8},
      {"short", Scalar::i16},  {"int16", Scalar::i16},   {"ushort", Scalar::u16}, {"uint16", Scalar::u16},
      {"int", Scalar::i32},    {"int32", Scalar::i32},   {"uint", Scalar::u32},   {"uint32", Scalar::u32},
      {"float", Scalar::f32},  {"float32", Scalar::f32}, {"double", Scalar::f64}, {"float64", Scalar::f64}};
  for (const auto& [n, s] : kNames) {
    if (n == name) {
      out = s;
      return true;
    }
  }
  return false;
}

std::size_t size_of(Scalar s) {
  switch (s) {
    case Scalar::i8: case Scalar::u8: return 1;
    case Scalar::i16: case Scalar::u16: return 2;
    case Scalar::i32: case Scalar::u32: case Scalar::f32: return 4;
    case Scalar::f64: return 8;
  }
  return 1;
}

struct PlyProperty {
  std::string name;
  bool list = false;
  Scalar count = Scalar::u8;  // list length type
  Scalar value = Scalar::f32;
};
struct PlyElement {
  std::string name;
  long long count = 0;
  std::vector<PlyProperty> properties;
};

// Sequential reader of a binary PLY body.
class BinaryCursor {
 public:
  BinaryCursor(const std::string& data, std::size_t pos, bool big_endian, std::string name)
      : data_(data), pos_(pos), big_(big_endian), name_(std::move(name)) {}

  double read(Scalar s, const std::string& what) {
    const std::size_t n = size_of(s);
    if (pos_ + n > data_.size()) {
      throw GeometryError(name_ + ": file is truncated: binary data ends at byte " + std::to_string(data_.size()) +
                          " while reading " + what);
    }
    unsigned char b[8];
    std::memcpy(b, data_.data() + pos_, n);
    pos_ += n;
    if (big_) std::reverse(b, b + n);
    switch (s) {
      case Scalar::i8: { std::int8_t v; std::memcpy(&v, b, 1); return v; }
      case Scalar::u8: return b[0];
      case Scalar::i16: { std::int16_t v; std::memcpy(&v, b, 2); return v; }
      case Scalar::u16: { std::uint16_t v; std::memcpy(&v, b, 2); return v; }
      case Scalar::i32: { std::int32_t v; std::memcpy(&v, b, 4); return v; }
      case Scalar::u32: { std::uint32_t v; std::memcpy(&v, b, 4); return v; }
      case Scalar::f32: { float v; std::memcpy(&v, b, 4); return static_cast<double>(v); }
      case Scalar::f64: { double v; std::memcpy(&v, b, 8); return v; }
    }
    return 0.0;
  }

 private:
  const std::string& data_;
  std::size_t pos_;
  bool big_;
  std::string name_;
};

// ---------------------------------------------------------------------------------------------
// STL (ASCII)
// ---------------------------------------------------------------------------------------------

SurfaceMesh read_stl_ascii(const std::filesystem::path& file, std::string text) {
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

SurfaceMesh read_obj(const std::filesystem::path& file) {
  TokenLines in(file, "OBJ surface", '#');
  SurfaceMesh s;
  std::vector<std::string_view> tok;
  std::vector<long long> polygon_raw;
  std::vector<std::uint32_t> polygon;
  std::vector<std::size_t> triangle_line;  // for index range errors, checked at the end
  while (in.next(tok)) {
    if (tok[0] == "v") {
      if (tok.size() < 4) in.fail("a vertex line needs 'v x y z', found " + std::to_string(tok.size()) + " fields");
      s.vertices.emplace_back(in.real(tok[1], "x coordinate"), in.real(tok[2], "y coordinate"), in.real(tok[3], "z coordinate"));
    } else if (tok[0] == "f") {
      if (tok.size() < 4) in.fail("a face needs at least 3 vertices, found " + std::to_string(tok.size() - 1));
      polygon.clear();
      for (std::size_t i = 1; i < tok.size(); ++i) {
        // "v", "v/vt", "v//vn" or "v/vt/vn": only v matters.
        const std::string_view ref = tok[i].substr(0, tok[i].find('/'));
        const long long v = in.integer(ref, "vertex index");
        const long long nv = static_cast<long long>(s.vertices.size());
        long long index = 0;
        if (v > 0) {
          index = v - 1;  // may refer to a vertex defined later: range-checked at the end
        } else if (v < 0) {
          index = nv + v;  // relative to the vertices read so far
          if (index < 0) in.fail("vertex index " + std::to_string(v) + " reaches before the first vertex (" + std::to_string(nv) + " read so far)");
        } else {
          in.fail("vertex index 0 (OBJ indices start at 1)");
        }
        if (index > static_cast<long long>(UINT32_MAX) - 1) in.fail("vertex index " + std::to_string(v) + " is out of range");
        polygon.push_back(static_cast<std::uint32_t>(index));
      }
      const std::size_t before = s.triangles.size();
      add_fan(s, polygon);
      triangle_line.resize(s.triangles.size(), in.line());
      (void)before;
    }
    // vt, vn, vp, g, o, s, l, p, usemtl, mtllib, ...: not geometry of the solid.
  }
  for (std::size_t t = 0; t < s.triangles.size(); ++t) {
    for (std::uint32_t v : s.triangles[t]) {
      if (v >= s.vertices.size()) {
        throw GeometryError(file.string() + ":" + std::to_string(triangle_line[t]) + ": vertex index " +
                            std::to_string(v + 1) + " is out of range (the file has " +
                            std::to_string(s.vertices.size()) + " vertices)");
      }
    }
  }
  require_triangles(s, file);
  return s;
}

SurfaceMesh read_off(const std::filesystem::path& file) {
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
  SurfaceMesh s;
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
  require_triangles(s, file);
  return s;
}

SurfaceMesh read_ply(const std::filesystem::path& file) {
  const std::string name = file.string();
  const std::string data = detail::read_whole_file(file, "PLY surface");
  // The header is text up to and including the "end_header" line.
  const std::size_t end = data.find("end_header");
  if (data.compare(0, 3, "ply") != 0) throw GeometryError(name + ":1: not a PLY file (it must start with 'ply')");
  if (end == std::string::npos) throw GeometryError(name + ": PLY header has no 'end_header'");
  std::size_t body = data.find('\n', end);
  body = body == std::string::npos ? data.size() : body + 1;

  TokenLines header(name, data.substr(0, body), 0, 0, '\0');
  std::vector<std::string_view> tok;
  std::vector<PlyElement> elements;
  std::string format;
  while (header.next(tok)) {
    if (tok[0] == "ply" || tok[0] == "comment" || tok[0] == "obj_info") continue;
    if (tok[0] == "end_header") break;
    if (tok[0] == "format") {
      if (tok.size() < 2) header.fail("'format' needs a value");
      format = std::string(tok[1]);
      if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian") {
        header.fail("unknown PLY format '" + format + "'");
      }
    } else if (tok[0] == "element") {
      if (tok.size() < 3) header.fail("'element' needs a name and a count");
      PlyElement e;
      e.name = std::string(tok[1]);
      e.count = header.integer(tok[2], "element count");
      if (e.count < 0) header.fail("negative element count");
      elements.push_back(e);
    } else if (tok[0] == "property") {
      if (elements.empty()) header.fail("'property' before any 'element'");
      PlyProperty p;
      if (tok.size() >= 5 && tok[1] == "list") {
        p.list = true;
        if (!scalar_of(tok[2], p.count) || !scalar_of(tok[3], p.value)) header.fail("unknown property type in '" + std::string(tok[2]) + " " + std::string(tok[3]) + "'");
        p.name = std::string(tok[4]);
      } else if (tok.size() >= 3) {
        if (!scalar_of(tok[1], p.value)) header.fail("unknown property type '" + std::string(tok[1]) + "'");
        p.name = std::string(tok[2]);
      } else {
        header.fail("'property' needs a type and a name");
      }
      elements.back().properties.push_back(p);
    } else {
      header.fail("unexpected '" + std::string(tok[0]) + "' in the PLY header");
    }
  }
  if (format.empty()) throw GeometryError(name + ": PLY header has no 'format' line");

  SurfaceMesh s;
  long long nv = -1;
  // Per element: which property is x, y, z (vertex) or the index list (face).
  auto find = [](const PlyElement& e, std::initializer_list<std::string_view> names) {
    for (std::string_view n : names) {
      for (std::size_t i = 0; i < e.properties.size(); ++i) {
        if (e.properties[i].name == n) return static_cast<int>(i);
      }
    }
    return -1;
  };

  const bool ascii = format == "ascii";
  TokenLines lines(name, ascii ? data : std::string(), ascii ? body : 0, header.line(), '\0');
  BinaryCursor bin(data, body, format == "binary_big_endian", name);
  std::vector<std::uint32_t> polygon;
  for (const PlyElement& e : elements) {
    const bool is_vertex = e.name == "vertex", is_face = e.name == "face";
    int px = -1, py = -1, pz = -1, pf = -1;
    if (is_vertex) {
      px = find(e, {"x"}), py = find(e, {"y"}), pz = find(e, {"z"});
      if (px < 0 || py < 0 || pz < 0) throw GeometryError(name + ": PLY 'vertex' element has no x, y and z properties");
      nv = e.count;
      s.vertices.resize(static_cast<std::size_t>(e.count), Vec3::Zero());
    }
    if (is_face) {
      pf = find(e, {"vertex_indices", "vertex_index"});
      if (pf < 0 || !e.properties[static_cast<std::size_t>(pf)].list) {
        throw GeometryError(name + ": PLY 'face' element has no 'vertex_indices' list");
      }
    }
    for (long long k = 0; k < e.count; ++k) {
      const std::string what = e.name + " " + std::to_string(k);
      std::size_t next_token = 0;
      if (ascii && !lines.next(tok)) lines.fail_truncated("expected " + std::to_string(e.count) + " " + e.name + " lines, found " + std::to_string(k));
      auto value = [&](Scalar sc, const char* field) -> double {
        if (!ascii) return bin.read(sc, what);
        if (next_token >= tok.size()) lines.fail(what + ": too few values on the line");
        const std::string_view t = tok[next_token++];
        return (sc == Scalar::f32 || sc == Scalar::f64) ? lines.real(t, field) : static_cast<double>(lines.integer(t, field));
      };
      for (std::size_t pi = 0; pi < e.properties.size(); ++pi) {
        const PlyProperty& p = e.properties[pi];
        const int ip = static_cast<int>(pi);
        if (!p.list) {
          const double x = value(p.value, "value");
          if (ip == px) s.vertices[static_cast<std::size_t>(k)].x() = x;
          if (ip == py) s.vertices[static_cast<std::size_t>(k)].y() = x;
          if (ip == pz) s.vertices[static_cast<std::size_t>(k)].z() = x;
          continue;
        }
        const double n = value(p.count, "list length");
        if (!(n >= 0 && n <= 1e6)) throw GeometryError(name + ": " + what + ": bad list length " + std::to_string(n));
        polygon.clear();
        for (long long i = 0; i < static_cast<long long>(n); ++i) {
          const double v = value(p.value, "vertex index");
          if (ip != pf) continue;
          if (!(v >= 0 && v < static_cast<double>(nv)) || v != std::floor(v)) {
            const std::string msg = what + ": vertex index " + std::to_string(static_cast<long long>(v)) +
                                    " is out of range (the file has " + std::to_string(std::max(nv, 0LL)) + " vertices)";
            if (ascii) lines.fail(msg);
            throw GeometryError(name + ": " + msg);
          }
          polygon.push_back(static_cast<std::uint32_t>(v));
        }
        if (ip == pf) {
          if (polygon.size() < 3) {
            const std::string msg = what + " has " + std::to_string(polygon.size()) + " vertices (at least 3 needed)";
            if (ascii) lines.fail(msg);
            throw GeometryError(name + ": " + msg);
          }
          add_fan(s, polygon);
        }
      }
      if (is_vertex && !s.vertices[static_cast<std::size_t>(k)].allFinite()) {
        throw GeometryError(name + ": vertex " + std::to_string(k) + " has a non-finite coordinate");
      }
    }
  }
  if (nv < 0) throw GeometryError(name + ": PLY file has no 'vertex' element");
  require_triangles(s, file);
  return s;
}

SurfaceMesh read_stl(const std::filesystem::path& file) {
  const std::string name = file.string();
  std::string data = detail::read_whole_file(file, "STL surface");
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
          if (!v.allFinite()) throw GeometryError(name + ": triangle " + std::to_string(t) + " has a non-finite coordinate");
          corners.push_back(v);
        }
      }
      SurfaceMesh s = weld(corners);
      require_triangles(s, file);
      return s;
    }
  }
  std::size_t first = data.find_first_not_of(" \t\r\n");
  if (first == std::string::npos || lower(data.substr(first, 5)) != "solid") {
    throw GeometryError(name + ": not an STL file (binary size does not match its triangle count, and it does not "
                        "start with 'solid')");
  }
  SurfaceMesh s = read_stl_ascii(file, std::move(data));
  require_triangles(s, file);
  return s;
}

SurfaceMesh read_surface(const std::filesystem::path& file) {
  const std::string ext = lower(file.extension().string());
  if (ext == ".obj") return read_obj(file);
  if (ext == ".ply") return read_ply(file);
  if (ext == ".stl") return read_stl(file);
  if (ext == ".off") return read_off(file);
  throw GeometryError(file.string() + ": unknown surface format '" + ext + "' (expected .obj, .ply, .stl or .off)");
}

}  // namespace perifx::geometry
