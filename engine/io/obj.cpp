// Wavefront OBJ: embedded-mesh surfaces with crack groups and their MTL (write), and surfaces with
// optional crack groups (read). Writers: write_atomic, locale-free number text (std::to_chars).
#include "io/obj.hpp"

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <string_view>

#include "io/atomic.hpp"
#include "io/text.hpp"
#include "io/write_checks.hpp"

namespace perifx::io {

namespace fs = std::filesystem;

namespace {

using detail::TokenLines;

void append_number(std::string& s, double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, 9);
  s.append(buf, r.ptr);
}
void append_number(std::string& s, std::uint64_t v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  s.append(buf, r.ptr);
}

// "o piece_<id>" and "g piece_<id>": Blender's importers split objects on `o`, Houdini groups on `g`.
void append_piece_header(std::string& text, std::uint32_t piece) {
  text += "o piece_";
  append_number(text, std::uint64_t{piece});
  text += "\ng piece_";
  append_number(text, std::uint64_t{piece});
  text += '\n';
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c);
  return s;
}

// Splits a polygon into a fan of triangles around its first corner.
void add_fan(TriangleSurface& s, const std::vector<std::uint32_t>& polygon, bool crack) {
  for (std::size_t i = 1; i + 1 < polygon.size(); ++i) {
    s.triangles.push_back({polygon[0], polygon[i], polygon[i + 1]});
    s.crack.push_back(crack ? 1 : 0);
  }
}

}  // namespace

void write_obj_surface(const fs::path& target, const SurfaceMesh& surface, const std::string& mtl_file) {
  detail::check_surface(target, surface);
  std::string text;
  text.reserve(40 * surface.vertices.size() + 30 * surface.triangles.size() + 128);
  text += "# perifx embedded mesh surface\nmtllib " + mtl_file + "\n";
  for (const Vec3& v : surface.vertices) {
    text += "v ";
    append_number(text, v.x());
    text += ' ';
    append_number(text, v.y());
    text += ' ';
    append_number(text, v.z());
    text += '\n';
  }
  // One object/group per piece, in increasing id order; inside it the outside faces, then the crack
  // faces, each under its material. Faces keep their relative order.
  std::vector<std::size_t> order(surface.triangles.size());
  for (std::size_t f = 0; f < order.size(); ++f) order[f] = f;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return surface.fragment[a] != surface.fragment[b] ? surface.fragment[a] < surface.fragment[b]
                                                       : surface.crack[a] < surface.crack[b];
  });
  for (std::size_t q = 0; q < order.size(); ++q) {
    const std::size_t f = order[q];
    const bool new_piece = q == 0 || surface.fragment[order[q - 1]] != surface.fragment[f];
    if (new_piece) append_piece_header(text, surface.fragment[f]);
    if (new_piece || surface.crack[order[q - 1]] != surface.crack[f])
      text += surface.crack[f] ? "usemtl crack\n" : "usemtl surface\n";
    text += 'f';
    for (auto v : surface.triangles[f]) {
      text += ' ';
      append_number(text, std::uint64_t{v} + 1);
    }
    text += '\n';
  }
  write_atomic(target, [&](std::ostream& os) { os.write(text.data(), static_cast<std::streamsize>(text.size())); });
}

void write_obj_cache(const fs::path& target, const SurfaceMesh& surface, const std::vector<float>& positions,
                     const std::vector<std::array<std::array<double, 2>, 3>>& uv, const std::string& mtl_file) {
  detail::check_surface(target, surface);
  if (positions.size() != 3 * surface.vertices.size() || uv.size() != surface.triangles.size())
    detail::fail_write(target, std::to_string(positions.size()) + " coordinates and " + std::to_string(uv.size()) +
                                   " UV triangles for " + std::to_string(surface.vertices.size()) + " vertices and " +
                                   std::to_string(surface.triangles.size()) + " triangles");
  detail::check_finite(target, positions.data(), positions.size(), "vertex");
  std::string text;
  text.reserve(40 * surface.vertices.size() + 60 * surface.triangles.size() + 128);
  text += "# perifx point-cache surface (positions per frame: animation.pc2)\nmtllib " + mtl_file + "\n";
  for (std::size_t v = 0; v < surface.vertices.size(); ++v) {
    text += "v";
    for (int d = 0; d < 3; ++d) text += ' ', append_number(text, double{positions[3 * v + d]});
    text += '\n';
  }
  for (std::size_t f = 0; f < surface.triangles.size(); ++f) {
    if (!surface.crack[f]) continue;
    for (int k = 0; k < 3; ++k) {
      text += "vt ";
      append_number(text, uv[f][k][0]);
      text += ' ';
      append_number(text, uv[f][k][1]);
      text += '\n';
    }
  }
  std::uint64_t next_uv = 1;
  for (std::size_t f = 0; f < surface.triangles.size(); ++f) {
    const bool new_piece = f == 0 || surface.fragment[f - 1] != surface.fragment[f];
    if (new_piece) append_piece_header(text, surface.fragment[f]);
    if (new_piece || surface.crack[f - 1] != surface.crack[f]) text += surface.crack[f] ? "usemtl crack\n" : "usemtl surface\n";
    text += 'f';
    for (auto v : surface.triangles[f]) {
      text += ' ';
      append_number(text, std::uint64_t{v} + 1);
      if (surface.crack[f]) text += '/', append_number(text, next_uv++);
    }
    text += '\n';
  }
  write_atomic(target, [&](std::ostream& os) { os.write(text.data(), static_cast<std::streamsize>(text.size())); });
}

void write_surface_mtl(const fs::path& target) {
  static constexpr std::string_view kMtl =
      "# perifx surface materials\n"
      "newmtl surface\nKa 0 0 0\nKd 0.7 0.7 0.72\nKs 0.1 0.1 0.1\nNs 20\nd 1\nillum 2\n\n"
      "newmtl crack\nKa 0 0 0\nKd 0.9 0.45 0.1\nKs 0.05 0.05 0.05\nNs 10\nd 1\nillum 2\n";
  write_atomic(target, [&](std::ostream& os) { os.write(kMtl.data(), static_cast<std::streamsize>(kMtl.size())); });
}

TriangleSurface read_obj(const fs::path& file) {
  TokenLines in(file, "OBJ surface", '#');
  TriangleSurface s;
  bool in_crack = false, grouped = false;  // faces under a group/object/material named *crack*
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
      add_fan(s, polygon, in_crack);
      triangle_line.resize(s.triangles.size(), in.line());
    } else if (tok[0] == "g" || tok[0] == "o" || tok[0] == "usemtl") {
      std::string names;
      for (std::size_t i = 1; i < tok.size(); ++i) names += lower(std::string(tok[i])) + " ";
      in_crack = names.find("crack") != std::string::npos;
      grouped = true;
    }
    // vt, vn, vp, s, l, p, mtllib, ...: not geometry of the solid.
  }
  for (std::size_t t = 0; t < s.triangles.size(); ++t) {
    for (std::uint32_t v : s.triangles[t]) {
      if (v >= s.vertices.size()) {
        throw ReadError(file.string() + ":" + std::to_string(triangle_line[t]) + ": vertex index " +
                            std::to_string(v + 1) + " is out of range (the file has " +
                            std::to_string(s.vertices.size()) + " vertices)");
      }
    }
  }
  if (!grouped) s.crack.clear();
  return s;
}

}  // namespace perifx::io
