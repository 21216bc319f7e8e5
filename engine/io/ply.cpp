// PLY writing (particle frames, embedded-mesh surfaces) and reading (see ply.hpp). Writers follow
// the rules of every perifx output: write_atomic, no timestamps, so a frame's bytes depend only on
// its data.
#include "io/ply.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string_view>
#include <unordered_set>

#include "io/atomic.hpp"
#include "io/render_surface.hpp"
#include "io/text.hpp"
#include "io/write_checks.hpp"

namespace perifx::io {

namespace fs = std::filesystem;

namespace {

using detail::TokenLines;

const char* ply_type_name(FieldType t) {
  switch (t) {
    case FieldType::f64: return "double";
    case FieldType::f32: return "float";
    case FieldType::u32: return "uint";
    case FieldType::u16: return "ushort";
    case FieldType::u8: return "uchar";
  }
  return nullptr;
}

// PLY property names are whitespace-separated tokens; anything else would corrupt the header.
bool valid_ply_name(const std::string& name) {
  return !name.empty() && std::none_of(name.begin(), name.end(), [](char c) {
    const auto u = static_cast<unsigned char>(c);
    return u <= 0x20 || u == 0x7f;
  });
}


void append_number(std::string& s, std::uint64_t v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  s.append(buf, r.ptr);
}

// Splits a polygon into a fan of triangles around its first corner.
void add_fan(TriangleSurface& s, const std::vector<std::uint32_t>& polygon, bool crack) {
  for (std::size_t i = 1; i + 1 < polygon.size(); ++i) {
    s.triangles.push_back({polygon[0], polygon[i], polygon[i + 1]});
    s.crack.push_back(crack ? 1 : 0);
  }
}

// ---- Reading ----

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
      throw ReadError(name_ + ": file is truncated: binary data ends at byte " + std::to_string(data_.size()) +
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

}  // namespace

void write_ply_points(const fs::path& target, const std::vector<Vec3>& points,
                      const std::vector<FieldView>& fields) {
  const std::size_t n = points.size();
  detail::check_particle_fields(target, fields, n);

  std::string header;
  header += "ply\nformat binary_little_endian 1.0\ncomment perifx\nelement vertex " + std::to_string(n) + "\n";
  // x y z first and as float: Blender's importer looks for exactly these.
  header += "property float x\nproperty float y\nproperty float z\n";

  std::unordered_set<std::string> props{"x", "y", "z"};
  auto add_property = [&](const FieldView& f, const std::string& name) {
    if (!valid_ply_name(name)) detail::fail_write(target, "PLY property name '" + name + "' is not a single token");
    if (!props.insert(name).second) detail::fail_write(target, "PLY property '" + name + "' appears twice");
    header += "property ";
    header += ply_type_name(f.type);
    header += " " + name + "\n";
  };

  // Layout of one interleaved vertex record: 3 floats, then each field's tuple in order.
  std::size_t record = 3 * sizeof(float);
  std::vector<std::size_t> field_offset;
  field_offset.reserve(fields.size());
  for (const FieldView& f : fields) {
    if (f.components == 1) {
      add_property(f, f.name);
    } else if (f.components == 3) {
      for (const char* axis : {"_x", "_y", "_z"}) add_property(f, f.name + axis);
    } else {
      // Not a scalar or a 3-vector (e.g. a tensor): number the components rather than refuse.
      for (int c = 0; c < f.components; ++c) add_property(f, f.name + "_" + std::to_string(c));
    }
    field_offset.push_back(record);
    record += static_cast<std::size_t>(f.components) * field_type_size(f.type);
  }
  header += "end_header\n";

  write_atomic(target, [&](std::ostream& os) {
    os.write(header.data(), static_cast<std::streamsize>(header.size()));

    // Records are assembled in chunks and each chunk written in one call: per-value stream writes
    // are an order of magnitude slower, and a whole-frame buffer would double the frame's memory.
    constexpr std::size_t kChunk = 1 << 15;
    std::vector<char> buf(std::min(n, kChunk) * record);
    for (std::size_t begin = 0; begin < n; begin += kChunk) {
      const std::size_t count = std::min(kChunk, n - begin);
      for (std::size_t i = 0; i < count; ++i) {
        const Vec3& p = points[begin + i];
        const float xyz[3] = {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())};
        std::memcpy(buf.data() + i * record, xyz, sizeof xyz);
      }
      // Field by field rather than record by record: each source array is then read sequentially.
      for (std::size_t k = 0; k < fields.size(); ++k) {
        const FieldView& f = fields[k];
        const std::size_t tuple = static_cast<std::size_t>(f.components) * field_type_size(f.type);
        const char* src = static_cast<const char*>(f.data) + begin * tuple;
        char* dst = buf.data() + field_offset[k];
        for (std::size_t i = 0; i < count; ++i) std::memcpy(dst + i * record, src + i * tuple, tuple);
      }
      os.write(buf.data(), static_cast<std::streamsize>(count * record));
    }
  });
}

void write_ply_surface(const fs::path& target, const SurfaceMesh& surface) {
  detail::check_surface(target, surface);
  const RenderSurface r = render_surface(surface);
  const bool has_tet = surface.tet.size() == surface.triangles.size();
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment perifx embedded mesh surface\nelement vertex ";
  append_number(header, std::uint64_t{r.position.size()});
  header += "\nproperty float x\nproperty float y\nproperty float z"
            "\nproperty float nx\nproperty float ny\nproperty float nz"
            "\nproperty float vx\nproperty float vy\nproperty float vz"
            "\nproperty float rx\nproperty float ry\nproperty float rz"
            "\nproperty uint source\nproperty uint piece\nelement face ";
  append_number(header, std::uint64_t{surface.triangles.size()});
  header += "\nproperty list uchar int vertex_indices\nproperty uchar crack\nproperty uint fragment\nproperty uint tet\nend_header\n";
  // Vertex record: 12 floats + 2 uints = 56 bytes; face record: 1 + 12 + 1 + 4 + 4 = 22 bytes, packed.
  const std::vector<std::uint32_t> piece = vertex_pieces(r, surface);
  std::string body;
  body.resize(56 * r.position.size() + 22 * surface.triangles.size());
  char* out = body.data();
  auto put3 = [&](const Vec3& v) {
    const float xyz[3] = {static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z())};
    std::memcpy(out, xyz, sizeof xyz);
    out += sizeof xyz;
  };
  for (std::size_t v = 0; v < r.position.size(); ++v) {
    put3(r.position[v]);
    put3(r.normal[v]);
    put3(r.velocity[v]);
    put3(r.reference[v]);
    std::memcpy(out, &r.source[v], 4);
    out += 4;
    std::memcpy(out, &piece[v], 4);
    out += 4;
  }
  for (std::size_t f = 0; f < surface.triangles.size(); ++f) {
    *out++ = 3;
    for (auto v : r.triangles[f]) {
      const auto i = static_cast<std::int32_t>(v);
      std::memcpy(out, &i, 4);
      out += 4;
    }
    *out++ = static_cast<char>(surface.crack[f]);
    std::memcpy(out, &surface.fragment[f], 4);
    out += 4;
    const std::uint32_t tet = has_tet ? surface.tet[f] : 0u;
    std::memcpy(out, &tet, 4);
    out += 4;
  }
  write_atomic(target, [&](std::ostream& os) {
    os.write(header.data(), static_cast<std::streamsize>(header.size()));
    os.write(body.data(), static_cast<std::streamsize>(body.size()));
  });
}

PlyContent read_ply(const fs::path& file) {
  const std::string name = file.string();
  const std::string data = read_file(file, "PLY");
  // The header is text up to and including the "end_header" line.
  const std::size_t end = data.find("end_header");
  if (data.compare(0, 3, "ply") != 0) throw ReadError(name + ":1: not a PLY file (it must start with 'ply')");
  if (end == std::string::npos) throw ReadError(name + ": PLY header has no 'end_header'");
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
  if (format.empty()) throw ReadError(name + ": PLY header has no 'format' line");
  // Every count is checked against the bytes that follow the header before anything is allocated: a
  // property takes at least one byte (binary char, or an ASCII digit and its separator).
  for (const PlyElement& e : elements) {
    const double least = double(e.count) * double(std::max<std::size_t>(1, e.properties.size()));
    if (least > double(data.size() - body))
      throw ReadError(name + ": PLY element '" + e.name.substr(0, 40) + "' count " + std::to_string(e.count) +
                      " is more than the file can hold (got " + std::to_string(data.size() - body) +
                      " bytes after the header; expected at least one per property and element)");
  }

  PlyContent content;
  TriangleSurface& s = content.surface;
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
  bool crack_flags = false;  // some face element has a crack property
  for (const PlyElement& e : elements) {
    const bool is_vertex = e.name == "vertex", is_face = e.name == "face";
    int px = -1, py = -1, pz = -1, pf = -1, pc = -1;
    std::vector<std::vector<double>*> vertex_property(e.properties.size(), nullptr);
    std::vector<std::vector<double>*> face_property(e.properties.size(), nullptr);
    std::vector<double> face_values(e.properties.size(), 0.0);
    if (is_vertex) {
      px = find(e, {"x"}), py = find(e, {"y"}), pz = find(e, {"z"});
      if (px < 0 || py < 0 || pz < 0) throw ReadError(name + ": PLY 'vertex' element has no x, y and z properties");
      nv = e.count;
      s.vertices.resize(static_cast<std::size_t>(e.count), Vec3::Zero());
      for (std::size_t pi = 0; pi < e.properties.size(); ++pi) {
        if (e.properties[pi].list) continue;
        auto& values = content.vertex_properties[e.properties[pi].name];
        values.resize(static_cast<std::size_t>(e.count));
        vertex_property[pi] = &values;
      }
    }
    if (is_face) {
      pf = find(e, {"vertex_indices", "vertex_index"});
      if (pf < 0 || !e.properties[static_cast<std::size_t>(pf)].list) {
        throw ReadError(name + ": PLY 'face' element has no 'vertex_indices' list");
      }
      pc = find(e, {"crack", "is_crack", "crack_face"});
      crack_flags = crack_flags || pc >= 0;
      for (std::size_t pi = 0; pi < e.properties.size(); ++pi)
        if (!e.properties[pi].list) face_property[pi] = &content.face_properties[e.properties[pi].name];
    }
    for (long long k = 0; k < e.count; ++k) {
      const std::string what = e.name + " " + std::to_string(k);
      std::size_t next_token = 0;
      bool crack = false;
      bool face_read = false;
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
          if (vertex_property[pi]) (*vertex_property[pi])[static_cast<std::size_t>(k)] = x;
          if (ip == pc) crack = x != 0.0;
          face_values[pi] = x;
          continue;
        }
        const double n = value(p.count, "list length");
        if (!(n >= 0 && n <= 1e6)) throw ReadError(name + ": " + what + ": bad list length " + std::to_string(n));
        polygon.clear();
        for (long long i = 0; i < static_cast<long long>(n); ++i) {
          const double v = value(p.value, "vertex index");
          if (ip != pf) continue;
          if (!(v >= 0 && v < static_cast<double>(nv)) || v != std::floor(v)) {
            const std::string msg = what + ": vertex index " + std::to_string(static_cast<long long>(v)) +
                                    " is out of range (the file has " + std::to_string(std::max(nv, 0LL)) + " vertices)";
            if (ascii) lines.fail(msg);
            throw ReadError(name + ": " + msg);
          }
          polygon.push_back(static_cast<std::uint32_t>(v));
        }
        if (ip == pf) {
          if (polygon.size() < 3) {
            const std::string msg = what + " has " + std::to_string(polygon.size()) + " vertices (at least 3 needed)";
            if (ascii) lines.fail(msg);
            throw ReadError(name + ": " + msg);
          }
          face_read = true;
        }
      }
      // After the whole record: a face's crack flag may follow its index list.
      if (face_read) {
        add_fan(s, polygon, crack);
        for (std::size_t pi = 0; pi < e.properties.size(); ++pi)
          if (face_property[pi]) face_property[pi]->resize(s.triangles.size(), face_values[pi]);
      }
      if (is_vertex && !s.vertices[static_cast<std::size_t>(k)].allFinite()) {
        throw ReadError(name + ": vertex " + std::to_string(k) + " has a non-finite coordinate");
      }
    }
  }
  if (nv < 0) throw ReadError(name + ": PLY file has no 'vertex' element");
  if (!crack_flags) s.crack.clear();
  return content;
}

}  // namespace perifx::io
