// Run-directory readers for the renderer (see run_data.hpp). The formats are the ones engine/io
// writes (VTU with raw appended data and UInt64 or UInt32 block headers, binary little-endian PLY)
// plus ASCII PLY and OBJ for surfaces, so meshes from other tools render too.
#include "render/run_data.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <regex>
#include <sstream>

namespace perifx::render {

namespace fs = std::filesystem;

namespace {

static_assert(std::endian::native == std::endian::little, "the readers assume a little-endian host");

[[noreturn]] void fail(const fs::path& file, const std::string& why) {
  throw RunDataError("cannot read '" + file.string() + "': " + why);
}

std::string slurp(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) fail(file, "cannot open");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Scalar types shared by VTK and PLY, converted to double on read.
enum class Scalar { f64, f32, i64, u64, i32, u32, i16, u16, i8, u8, none };

Scalar vtk_scalar(const std::string& t) {
  if (t == "Float64") return Scalar::f64;
  if (t == "Float32") return Scalar::f32;
  if (t == "Int64") return Scalar::i64;
  if (t == "UInt64") return Scalar::u64;
  if (t == "Int32") return Scalar::i32;
  if (t == "UInt32") return Scalar::u32;
  if (t == "Int16") return Scalar::i16;
  if (t == "UInt16") return Scalar::u16;
  if (t == "Int8") return Scalar::i8;
  if (t == "UInt8") return Scalar::u8;
  return Scalar::none;
}

Scalar ply_scalar(const std::string& t) {
  if (t == "double" || t == "float64") return Scalar::f64;
  if (t == "float" || t == "float32") return Scalar::f32;
  if (t == "int" || t == "int32") return Scalar::i32;
  if (t == "uint" || t == "uint32") return Scalar::u32;
  if (t == "short" || t == "int16") return Scalar::i16;
  if (t == "ushort" || t == "uint16") return Scalar::u16;
  if (t == "char" || t == "int8") return Scalar::i8;
  if (t == "uchar" || t == "uint8") return Scalar::u8;
  return Scalar::none;
}

std::size_t scalar_size(Scalar s) {
  switch (s) {
    case Scalar::f64: case Scalar::i64: case Scalar::u64: return 8;
    case Scalar::f32: case Scalar::i32: case Scalar::u32: return 4;
    case Scalar::i16: case Scalar::u16: return 2;
    case Scalar::i8: case Scalar::u8: return 1;
    case Scalar::none: return 0;
  }
  return 0;
}

template <class T>
T load(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

double scalar_at(const char* p, Scalar s) {
  switch (s) {
    case Scalar::f64: return load<double>(p);
    case Scalar::f32: return load<float>(p);
    case Scalar::i64: return double(load<std::int64_t>(p));
    case Scalar::u64: return double(load<std::uint64_t>(p));
    case Scalar::i32: return load<std::int32_t>(p);
    case Scalar::u32: return load<std::uint32_t>(p);
    case Scalar::i16: return load<std::int16_t>(p);
    case Scalar::u16: return load<std::uint16_t>(p);
    case Scalar::i8: return load<std::int8_t>(p);
    case Scalar::u8: return load<std::uint8_t>(p);
    case Scalar::none: break;
  }
  return 0.0;
}

// The value of attr="..." inside one XML start tag, or nullopt.
std::optional<std::string> attribute(const std::string& tag, const std::string& name) {
  const std::string key = " " + name + "=\"";
  const auto at = tag.find(key);
  if (at == std::string::npos) return std::nullopt;
  const auto begin = at + key.size();
  const auto end = tag.find('"', begin);
  if (end == std::string::npos) return std::nullopt;
  return tag.substr(begin, end - begin);
}

std::uint32_t as_index(double v) { return v < 0 ? 0u : static_cast<std::uint32_t>(std::llround(v)); }

void assign_material(ParticleFrame& f, const std::vector<double>& values) {
  f.material.resize(values.size());
  std::transform(values.begin(), values.end(), f.material.begin(), as_index);
}

// ---- PLY -------------------------------------------------------------------------------------

struct PlyProperty {
  std::string name;
  Scalar type = Scalar::none;
  bool list = false;
  Scalar count_type = Scalar::none;
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> props;
  // Read values: scalars per property (index = property), lists flattened with offsets.
  std::vector<std::vector<double>> scalars;
  std::vector<std::vector<std::uint32_t>> lists;
};

std::vector<PlyElement> read_ply(const fs::path& file) {
  const std::string bytes = slurp(file);
  const auto header_end = bytes.find("end_header");
  if (bytes.rfind("ply", 0) != 0 || header_end == std::string::npos) fail(file, "not a PLY file");
  std::size_t body = bytes.find('\n', header_end);
  if (body == std::string::npos) fail(file, "truncated header");
  ++body;

  std::istringstream header(bytes.substr(0, header_end));
  std::string line, format;
  std::vector<PlyElement> elements;
  while (std::getline(header, line)) {
    std::istringstream ls(line);
    std::string word;
    ls >> word;
    if (word == "format") {
      ls >> format;
    } else if (word == "element") {
      PlyElement e;
      ls >> e.name >> e.count;
      elements.push_back(e);
    } else if (word == "property") {
      if (elements.empty()) fail(file, "property before any element");
      PlyProperty p;
      std::string type;
      ls >> type;
      if (type == "list") {
        std::string ct, it;
        ls >> ct >> it;
        p.list = true;
        p.count_type = ply_scalar(ct);
        p.type = ply_scalar(it);
      } else {
        p.type = ply_scalar(type);
      }
      ls >> p.name;
      if (p.type == Scalar::none || (p.list && p.count_type == Scalar::none))
        fail(file, "unknown property type in '" + line + "'");
      elements.back().props.push_back(p);
    }
  }
  const bool ascii = format == "ascii";
  if (!ascii && format != "binary_little_endian") fail(file, "unsupported PLY format '" + format + "'");

  std::size_t pos = body;
  std::istringstream text(ascii ? bytes.substr(body) : std::string());
  auto next = [&](Scalar s) -> double {
    if (ascii) {
      double v;
      if (!(text >> v)) fail(file, "truncated ASCII data");
      return v;
    }
    const std::size_t n = scalar_size(s);
    if (pos + n > bytes.size()) fail(file, "truncated binary data");
    const double v = scalar_at(bytes.data() + pos, s);
    pos += n;
    return v;
  };
  for (auto& e : elements) {
    e.scalars.assign(e.props.size(), {});
    e.lists.assign(e.props.size(), {});
    for (std::size_t k = 0; k < e.props.size(); ++k)
      if (!e.props[k].list) e.scalars[k].reserve(e.count);
    for (std::size_t i = 0; i < e.count; ++i) {
      for (std::size_t k = 0; k < e.props.size(); ++k) {
        const auto& p = e.props[k];
        if (!p.list) {
          e.scalars[k].push_back(next(p.type));
          continue;
        }
        const auto n = static_cast<std::size_t>(next(p.count_type));
        e.lists[k].push_back(static_cast<std::uint32_t>(n));  // count, then the items
        for (std::size_t j = 0; j < n; ++j) e.lists[k].push_back(as_index(next(p.type)));
      }
    }
  }
  return elements;
}

const std::vector<double>* ply_scalars(const PlyElement& e, std::initializer_list<const char*> names) {
  for (const char* name : names)
    for (std::size_t k = 0; k < e.props.size(); ++k)
      if (!e.props[k].list && e.props[k].name == name) return &e.scalars[k];
  return nullptr;
}

const PlyElement* ply_element(const std::vector<PlyElement>& elements, const char* name) {
  for (const auto& e : elements)
    if (e.name == name) return &e;
  return nullptr;
}

std::vector<Vec3> ply_positions(const fs::path& file, const PlyElement& v) {
  const auto* x = ply_scalars(v, {"x"});
  const auto* y = ply_scalars(v, {"y"});
  const auto* z = ply_scalars(v, {"z"});
  if (!x || !y || !z) fail(file, "vertex element has no x, y, z");
  std::vector<Vec3> out(v.count);
  for (std::size_t i = 0; i < v.count; ++i) out[i] = Vec3((*x)[i], (*y)[i], (*z)[i]);
  return out;
}

// Fan-triangulates polygon i's corner list into `s`; keeps `flag` per produced triangle.
void add_polygon(SurfaceFrame& s, const std::vector<std::uint32_t>& corners, std::uint8_t flag, bool flagged) {
  for (std::size_t k = 1; k + 1 < corners.size(); ++k) {
    s.triangle.push_back({corners[0], corners[k], corners[k + 1]});
    if (flagged) s.crack.push_back(flag);
  }
}

SurfaceFrame read_ply_surface(const fs::path& file) {
  const auto elements = read_ply(file);
  const PlyElement* v = ply_element(elements, "vertex");
  const PlyElement* f = ply_element(elements, "face");
  if (!v || !f) fail(file, "a surface PLY needs vertex and face elements");
  SurfaceFrame s;
  s.vertex = ply_positions(file, *v);
  if (const auto* d = ply_scalars(*v, {"damage"})) s.damage = *d;
  std::size_t list_prop = f->props.size();
  for (std::size_t k = 0; k < f->props.size(); ++k)
    if (f->props[k].list && (f->props[k].name == "vertex_indices" || f->props[k].name == "vertex_index")) list_prop = k;
  if (list_prop == f->props.size()) fail(file, "face element has no vertex_indices list");
  const auto* crack = ply_scalars(*f, {"crack", "is_crack", "crack_face"});
  const auto& flat = f->lists[list_prop];
  std::size_t at = 0;
  for (std::size_t i = 0; i < f->count; ++i) {
    const std::size_t n = flat.at(at);
    std::vector<std::uint32_t> corners(flat.begin() + std::ptrdiff_t(at + 1), flat.begin() + std::ptrdiff_t(at + 1 + n));
    at += n + 1;
    add_polygon(s, corners, crack && (*crack)[i] != 0.0 ? 1 : 0, crack != nullptr);
  }
  return s;
}

// OBJ: v and f lines; faces after "g"/"o"/"usemtl" whose name contains "crack" are crack faces.
SurfaceFrame read_obj_surface(const fs::path& file) {
  std::ifstream in(file);
  if (!in) fail(file, "cannot open");
  SurfaceFrame s;
  std::string line;
  bool in_crack = false, any_flag = false;
  std::vector<std::uint8_t> flags;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string word;
    ls >> word;
    if (word == "v") {
      double x = 0, y = 0, z = 0;
      ls >> x >> y >> z;
      s.vertex.emplace_back(x, y, z);
    } else if (word == "g" || word == "o" || word == "usemtl") {
      std::string name;
      std::getline(ls, name);
      std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return char(std::tolower(c)); });
      in_crack = name.find("crack") != std::string::npos;
      any_flag = true;
    } else if (word == "f") {
      std::vector<std::uint32_t> corners;
      std::string item;
      while (ls >> item) {
        const long idx = std::strtol(item.c_str(), nullptr, 10);  // "7/3/2" -> 7
        const long resolved = idx < 0 ? long(s.vertex.size()) + idx : idx - 1;
        if (resolved < 0 || resolved >= long(s.vertex.size())) fail(file, "face index out of range in '" + line + "'");
        corners.push_back(static_cast<std::uint32_t>(resolved));
      }
      add_polygon(s, corners, in_crack ? 1 : 0, true);
    }
  }
  if (!any_flag) s.crack.clear();
  return s;
}

}  // namespace

ParticleFrame read_vtu_particles(const fs::path& file) {
  const std::string bytes = slurp(file);
  const auto appended = bytes.find("<AppendedData");
  if (bytes.find("<VTKFile") == std::string::npos || appended == std::string::npos)
    fail(file, "not a VTU file with appended data");
  const auto underscore = bytes.find('_', appended);
  if (underscore == std::string::npos) fail(file, "no '_' marker before the appended data");
  const std::size_t data = underscore + 1;

  const auto vtkfile = bytes.find("<VTKFile");
  const std::string root = bytes.substr(vtkfile, bytes.find('>', vtkfile) - vtkfile);
  const bool header64 = attribute(root, "header_type").value_or("UInt32") == "UInt64";
  if (const auto bo = attribute(root, "byte_order"); bo && *bo != "LittleEndian") fail(file, "big-endian data");
  const auto piece_at = bytes.find("<Piece");
  if (piece_at == std::string::npos) fail(file, "no <Piece>");
  const std::string piece = bytes.substr(piece_at, bytes.find('>', piece_at) - piece_at);
  const std::size_t n = std::stoull(attribute(piece, "NumberOfPoints").value_or("0"));

  std::map<std::string, std::vector<double>> arrays;  // by name, converted
  std::size_t search = 0;
  bool in_points = false;
  while (true) {
    const auto tag_at = bytes.find('<', search);
    if (tag_at == std::string::npos || tag_at >= appended) break;
    const auto tag_end = bytes.find('>', tag_at);
    const std::string tag = bytes.substr(tag_at, tag_end - tag_at);
    search = tag_end;
    if (tag.rfind("<Points", 0) == 0) in_points = true;
    if (tag.rfind("</Points", 0) == 0) in_points = false;
    if (tag.rfind("<DataArray", 0) != 0) continue;
    const std::string name = attribute(tag, "Name").value_or("");
    const bool wanted = in_points || name == "volume" || name == "damage" || name == "material_id" || name == "body_id";
    if (!wanted) continue;
    if (attribute(tag, "format").value_or("") != "appended") fail(file, "array '" + name + "' is not appended raw data");
    const Scalar type = vtk_scalar(attribute(tag, "type").value_or(""));
    if (type == Scalar::none) fail(file, "array '" + name + "' has an unknown type");
    const std::size_t offset = std::stoull(attribute(tag, "offset").value_or("0"));
    const std::size_t hsize = header64 ? 8 : 4;
    if (data + offset + hsize > bytes.size()) fail(file, "array '" + name + "' offset is past the end");
    const std::size_t nbytes = header64 ? load<std::uint64_t>(bytes.data() + data + offset)
                                        : load<std::uint32_t>(bytes.data() + data + offset);
    const char* p = bytes.data() + data + offset + hsize;
    if (data + offset + hsize + nbytes > bytes.size()) fail(file, "array '" + name + "' is truncated");
    const std::size_t count = nbytes / scalar_size(type);
    std::vector<double> values(count);
    for (std::size_t i = 0; i < count; ++i) values[i] = scalar_at(p + i * scalar_size(type), type);
    arrays[in_points ? std::string("Points") : name] = std::move(values);
  }

  ParticleFrame f;
  const auto pts = arrays.find("Points");
  if (pts == arrays.end() || pts->second.size() != 3 * n) fail(file, "no Points array with 3 components per point");
  f.position.resize(n);
  for (std::size_t i = 0; i < n; ++i) f.position[i] = Vec3(pts->second[3 * i], pts->second[3 * i + 1], pts->second[3 * i + 2]);
  auto scalar_field = [&](const char* name) -> const std::vector<double>* {
    const auto it = arrays.find(name);
    return it != arrays.end() && it->second.size() == n ? &it->second : nullptr;
  };
  if (const auto* v = scalar_field("volume")) f.volume = *v;
  if (const auto* d = scalar_field("damage")) f.damage = *d;
  if (const auto* m = scalar_field("material_id")) assign_material(f, *m);
  else if (const auto* b = scalar_field("body_id")) assign_material(f, *b);
  return f;
}

ParticleFrame read_ply_particles(const fs::path& file) {
  const auto elements = read_ply(file);
  const PlyElement* v = ply_element(elements, "vertex");
  if (!v) fail(file, "no vertex element");
  ParticleFrame f;
  f.position = ply_positions(file, *v);
  if (const auto* vol = ply_scalars(*v, {"volume"})) f.volume = *vol;
  if (const auto* d = ply_scalars(*v, {"damage"})) f.damage = *d;
  if (const auto* m = ply_scalars(*v, {"material_id", "body_id"})) assign_material(f, *m);
  return f;
}

ParticleFrame read_particles(const fs::path& file) {
  return file.extension() == ".ply" ? read_ply_particles(file) : read_vtu_particles(file);
}

SurfaceFrame read_surface(const fs::path& file) {
  SurfaceFrame s = file.extension() == ".obj" ? read_obj_surface(file) : read_ply_surface(file);
  for (const auto& t : s.triangle)
    for (const auto i : t)
      if (i >= s.vertex.size()) fail(file, "triangle index out of range");
  return s;
}

RunDirectory scan_run_directory(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw RunDataError("'" + dir.string() + "' is not a directory");
  RunDirectory run;
  run.path = dir;
  std::map<std::uint64_t, FrameFiles> frames;
  static const std::regex kName(R"((particles|surface)\.(\d+)\.(vtu|ply|obj))");
  for (const auto& entry : fs::directory_iterator(dir)) {
    std::smatch m;
    const std::string name = entry.path().filename().string();
    if (!std::regex_match(name, m, kName)) continue;
    const std::uint64_t k = std::stoull(m[2].str());
    FrameFiles& f = frames[k];
    f.index = k;
    const std::string kind = m[1].str(), ext = m[3].str();
    if (kind == "particles" && ext != "obj") {
      if (f.particles.empty() || ext == "vtu") f.particles = entry.path();
    } else if (kind == "surface" && ext != "vtu") {
      if (f.surface.empty() || ext == "ply") f.surface = entry.path();
    }
  }
  if (frames.empty())
    throw RunDataError("'" + dir.string() + "' has no particles.NNNN.vtu/.ply or surface.NNNN.ply/.obj frames");

  // Frame times from the .pvd (file="particles.0003.vtu" timestep="..."), else 30 fps.
  std::map<std::string, double> pvd_time;
  if (std::ifstream pvd(dir / "particles.pvd"); pvd) {
    std::string line;
    while (std::getline(pvd, line)) {
      const auto t = attribute(" " + line, "timestep"), f = attribute(" " + line, "file");
      if (t && f) pvd_time[fs::path(*f).filename().string()] = std::strtod(t->c_str(), nullptr);
    }
  }
  for (auto& [k, f] : frames) {
    const auto it = f.particles.empty() ? pvd_time.end() : pvd_time.find(f.particles.filename().replace_extension(".vtu").string());
    f.time = it != pvd_time.end() ? it->second : double(k) / 30.0;
    run.frames.push_back(f);
  }
  if (run.frames.size() >= 2) {
    const auto& a = run.frames.front();
    const auto& b = run.frames.back();
    const double per = (b.time - a.time) / double(b.index - a.index);
    if (per > 0 && std::isfinite(per)) run.frame_rate = 1.0 / per;
  }

  // projectiles.csv: header names the columns; time, id, x, y, z are required, radius optional.
  if (std::ifstream csv(dir / "projectiles.csv"); csv) {
    std::string line;
    std::getline(csv, line);
    std::vector<std::string> cols;
    for (std::istringstream hs(line); std::getline(hs, line, ',');) cols.push_back(line);
    auto col = [&](const char* name) {
      const auto it = std::find(cols.begin(), cols.end(), name);
      return it == cols.end() ? -1 : int(it - cols.begin());
    };
    const int ct = col("time"), cid = col("id"), cx = col("x"), cy = col("y"), cz = col("z"), cr = col("radius");
    if (ct >= 0 && cx >= 0 && cy >= 0 && cz >= 0) {
      while (std::getline(csv, line)) {
        std::vector<double> v;
        for (std::istringstream rs(line); std::getline(rs, line, ',');) v.push_back(std::strtod(line.c_str(), nullptr));
        if (int(v.size()) < int(cols.size())) continue;
        ProjectileState p;
        p.id = cid >= 0 ? std::size_t(v[std::size_t(cid)]) : 0;
        p.center = Vec3(v[std::size_t(cx)], v[std::size_t(cy)], v[std::size_t(cz)]);
        p.radius = cr >= 0 ? v[std::size_t(cr)] : 0.0;
        const double t = v[std::size_t(ct)];
        if (run.projectiles.empty() || run.projectiles.back().first != t) run.projectiles.push_back({t, {}});
        run.projectiles.back().second.push_back(p);
      }
    }
  }
  return run;
}

std::vector<ProjectileState> projectiles_at(const RunDirectory& run, const FrameFiles& frame) {
  if (run.projectiles.empty()) return {};
  const auto best = std::min_element(run.projectiles.begin(), run.projectiles.end(), [&](const auto& a, const auto& b) {
    return std::abs(a.first - frame.time) < std::abs(b.first - frame.time);
  });
  return best->second;
}

}  // namespace perifx::render
