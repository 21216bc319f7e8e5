// VTK XML writing and reading (see vtk.hpp). Written for two properties: a reader (ParaView
// following a running simulation) never sees a half-written file (write_atomic), and the bytes of a
// frame depend only on its data, so reruns can be compared with cmp: no timestamps, no
// locale-dependent number text.
#include "io/vtk.hpp"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <numeric>
#include <optional>

#include "io/atomic.hpp"
#include "io/render_surface.hpp"
#include "io/write_checks.hpp"

namespace perifx::io {

namespace fs = std::filesystem;

// The binary blocks are the in-memory bytes of the arrays, declared little endian; no supported
// target is big endian, so refuse to build rather than silently write wrong files.
static_assert(std::endian::native == std::endian::little, "perifx io writes host-order bytes as little endian");
// Points are written straight from std::vector<Vec3> memory as x0 y0 z0 x1 ..., which needs Vec3 to
// be exactly three packed doubles (true for Eigen::Vector3d: it is not a vectorizable fixed size).
static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 must be three packed doubles");

namespace {

std::string xml_escape(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (const char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

// Shortest decimal text that parses back to the same double, independent of the global locale
// (a "%g" under a German locale would print a comma and ParaView would misread the time).
std::string double_text(double v) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, res.ptr);
}

const char* vtk_type_name(FieldType t) {
  switch (t) {
    case FieldType::f64: return "Float64";
    case FieldType::f32: return "Float32";
    case FieldType::u32: return "UInt32";
    case FieldType::u16: return "UInt16";
    case FieldType::u8: return "UInt8";
  }
  return nullptr;
}

template <class T>
void add_vector(VtkAppendedWriter& w, std::string_view type, std::string_view name, int components,
                const std::vector<T>& a) {
  w.add_array(type, name, components, a.data(), a.size() * sizeof(T));
}

}  // namespace

// ---- The appended-data writer ----

VtkAppendedWriter::VtkAppendedWriter(std::string dataset, const std::string& piece_attributes)
    : dataset_(std::move(dataset)) {
  xml_ = "<?xml version=\"1.0\"?>\n<VTKFile type=\"" + dataset_ +
         "\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n  <" + dataset_ + ">\n";
  xml_ += "    <Piece " + piece_attributes + ">\n";
}

void VtkAppendedWriter::begin_section(std::string_view name) {
  section_ = std::string(name);
  xml_ += "      <" + section_ + ">\n";
}

void VtkAppendedWriter::end_section() { xml_ += "      </" + section_ + ">\n"; }

void VtkAppendedWriter::add_array(std::string_view vtk_type, std::string_view name, int components, const void* data,
                                  std::size_t bytes) {
  add_array(vtk_type, name, components, bytes, [data, bytes](std::ostream& os) {
    if (bytes > 0) os.write(static_cast<const char*>(data), static_cast<std::streamsize>(bytes));
  });
}

void VtkAppendedWriter::add_array(std::string_view vtk_type, std::string_view name, int components, std::size_t bytes,
                                  std::function<void(std::ostream&)> payload) {
  xml_ += "        <DataArray type=\"" + std::string(vtk_type) + "\" Name=\"" + xml_escape(name) + "\"";
  if (components > 0) xml_ += " NumberOfComponents=\"" + std::to_string(components) + "\"";
  // Offsets count from the first byte after the '_' marker; each block is its 8-byte count header
  // plus its payload.
  xml_ += " format=\"appended\" offset=\"" + std::to_string(offset_) + "\"/>\n";
  offset_ += sizeof(std::uint64_t) + bytes;
  blocks_.emplace_back(bytes, std::move(payload));
}

void VtkAppendedWriter::write(const fs::path& target) const {
  const std::string head = xml_ + "    </Piece>\n  </" + dataset_ + ">\n  <AppendedData encoding=\"raw\">\n   _";
  static constexpr std::string_view kTail = "\n  </AppendedData>\n</VTKFile>\n";
  write_atomic(target, [&](std::ostream& os) {
    os.write(head.data(), static_cast<std::streamsize>(head.size()));
    for (const auto& [bytes, payload] : blocks_) {
      const std::uint64_t header = bytes;
      os.write(reinterpret_cast<const char*>(&header), sizeof header);
      payload(os);
    }
    os.write(kTail.data(), static_cast<std::streamsize>(kTail.size()));
  });
}

// ---- The three files perifx writes with it ----

void write_vtu_points(const fs::path& target, const std::vector<Vec3>& points, const std::vector<FieldView>& fields) {
  const std::size_t n = points.size();
  detail::check_particle_fields(target, fields, n);
  const std::string ns = std::to_string(n);
  VtkAppendedWriter w("UnstructuredGrid", "NumberOfPoints=\"" + ns + "\" NumberOfCells=\"" + ns + "\"");
  w.begin_section("PointData");
  for (const FieldView& f : fields) w.add_array(vtk_type_name(f.type), f.name, f.components, f.data, detail::field_bytes(f));
  w.end_section();
  w.begin_section("Points");
  w.add_array("Float64", "Points", 3, points.data(), n * 3 * sizeof(double));
  w.end_section();
  // One vertex cell per point: connectivity 0..n-1, offsets 1..n (Int64 so they never overflow),
  // generated while writing rather than held as arrays the size of the frame.
  auto counting = [n](std::int64_t first) {
    return [n, first](std::ostream& os) {
      std::vector<std::int64_t> ints(n);
      std::iota(ints.begin(), ints.end(), first);
      if (n) os.write(reinterpret_cast<const char*>(ints.data()), static_cast<std::streamsize>(n * sizeof(std::int64_t)));
    };
  };
  w.begin_section("Cells");
  w.add_array("Int64", "connectivity", 0, n * sizeof(std::int64_t), counting(0));
  w.add_array("Int64", "offsets", 0, n * sizeof(std::int64_t), counting(1));
  w.add_array("UInt8", "types", 0, n, [n](std::ostream& os) {
    constexpr std::uint8_t kVtkVertex = 1;
    const std::vector<std::uint8_t> types(n, kVtkVertex);
    if (n) os.write(reinterpret_cast<const char*>(types.data()), static_cast<std::streamsize>(n));
  });
  w.end_section();
  w.write(target);
}

void write_vtp_surface(const fs::path& target, const SurfaceMesh& surface) {
  detail::check_surface(target, surface);
  const RenderSurface r = render_surface(surface);
  const std::size_t nv = r.position.size(), nf = surface.triangles.size();
  std::vector<std::int64_t> connectivity, offsets(nf);
  connectivity.reserve(3 * nf);
  for (std::size_t f = 0; f < nf; ++f) {
    for (auto v : r.triangles[f]) connectivity.push_back(v);
    offsets[f] = static_cast<std::int64_t>(3 * (f + 1));
  }
  std::vector<std::uint32_t> tet = surface.tet;
  tet.resize(nf, 0u);
  // The writer keeps pointers to the arrays until write(): every array must outlive it (no temporaries).
  const std::vector<std::uint32_t> pieces = vertex_pieces(r, surface);
  VtkAppendedWriter w("PolyData", "NumberOfPoints=\"" + std::to_string(nv) +
                                      "\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"" +
                                      std::to_string(nf) + "\"");
  w.begin_section("PointData");
  add_vector(w, "Float64", "normal", 3, r.normal);
  add_vector(w, "Float64", "velocity", 3, r.velocity);
  add_vector(w, "Float64", "reference", 3, r.reference);
  add_vector(w, "UInt32", "source", 0, r.source);
  add_vector(w, "UInt32", "piece", 0, pieces);
  w.end_section();
  w.begin_section("CellData");
  add_vector(w, "UInt8", "crack", 0, surface.crack);
  add_vector(w, "UInt32", "fragment", 0, surface.fragment);
  add_vector(w, "UInt32", "tet", 0, tet);
  w.end_section();
  w.begin_section("Points");
  add_vector(w, "Float64", "Points", 3, r.position);
  w.end_section();
  w.begin_section("Polys");
  add_vector(w, "Int64", "connectivity", 0, connectivity);
  add_vector(w, "Int64", "offsets", 0, offsets);
  w.end_section();
  w.write(target);
}

void write_vtu_tets(const fs::path& target, const std::vector<Vec3>& vertices,
                    const std::vector<std::array<std::uint32_t, 4>>& tets, const std::vector<double>& damage,
                    const std::vector<std::uint32_t>& fragment) {
  const std::size_t nv = vertices.size(), nt = tets.size();
  if (damage.size() != nt || fragment.size() != nt)
    throw IoError("cannot write '" + target.string() + "': per-tet arrays must have one value per tet");
  std::vector<std::int64_t> connectivity, offsets(nt);
  connectivity.reserve(4 * nt);
  for (std::size_t t = 0; t < nt; ++t) {
    for (auto v : tets[t]) {
      if (v >= nv) throw IoError("cannot write '" + target.string() + "': tet vertex out of range");
      connectivity.push_back(v);
    }
    offsets[t] = static_cast<std::int64_t>(4 * (t + 1));
  }
  constexpr std::uint8_t kVtkTetra = 10;
  const std::vector<std::uint8_t> types(nt, kVtkTetra);
  VtkAppendedWriter w("UnstructuredGrid", "NumberOfPoints=\"" + std::to_string(nv) + "\" NumberOfCells=\"" +
                                              std::to_string(nt) + "\"");
  w.begin_section("CellData");
  add_vector(w, "Float64", "damage", 0, damage);
  add_vector(w, "UInt32", "fragment", 0, fragment);
  w.end_section();
  w.begin_section("Points");
  add_vector(w, "Float64", "Points", 3, vertices);
  w.end_section();
  w.begin_section("Cells");
  add_vector(w, "Int64", "connectivity", 0, connectivity);
  add_vector(w, "Int64", "offsets", 0, offsets);
  add_vector(w, "UInt8", "types", 0, types);
  w.end_section();
  w.write(target);
}

// ---- ParaView collection ----

PvdSeries::PvdSeries(fs::path target) : target_(std::move(target)) {}

void PvdSeries::add(double time, const fs::path& file) {
  // A NaN time would never compare equal, so restarts could not replace it, and ParaView cannot
  // order it anyway.
  if (!std::isfinite(time))
    throw IoError("cannot add a non-finite time to '" + target_.string() + "': time is " + double_text(time));

  // Work on a copy so a failed write leaves the series as it was on disk and in memory.
  auto entries = entries_;
  // Kept sorted by time; an equal time replaces its entry (a restart rewriting a frame).
  auto it = std::lower_bound(entries.begin(), entries.end(), time, [](const auto& e, double t) { return e.first < t; });
  // generic_string: ParaView wants '/' separators in the collection whatever the host.
  if (it != entries.end() && it->first == time) {
    it->second = file.generic_string();
  } else {
    entries.insert(it, {time, file.generic_string()});
  }

  std::string xml;
  xml += "<?xml version=\"1.0\"?>\n";
  xml += "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n";
  xml += "  <Collection>\n";
  for (const auto& [t, f] : entries) {
    xml += "    <DataSet timestep=\"" + double_text(t) + "\" group=\"\" part=\"0\" file=\"" + xml_escape(f) + "\"/>\n";
  }
  xml += "  </Collection>\n";
  xml += "</VTKFile>\n";

  write_atomic(target_, [&](std::ostream& os) { os.write(xml.data(), static_cast<std::streamsize>(xml.size())); });
  entries_ = std::move(entries);
}

// ---- Reading ----

namespace {

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

std::string xml_unescape(const std::string& s) {
  static const std::pair<std::string_view, char> kEntities[] = {
      {"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}};
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    bool replaced = false;
    if (s[i] == '&')
      for (const auto& [entity, c] : kEntities)
        if (s.compare(i, entity.size(), entity) == 0) {
          out += c;
          i += entity.size() - 1;
          replaced = true;
          break;
        }
    if (!replaced) out += s[i];
  }
  return out;
}

template <class T>
T load(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

// Size of a VTK scalar type and a converter to double; size 0 for an unknown type.
std::size_t vtk_size(const std::string& t) {
  if (t == "Float64" || t == "Int64" || t == "UInt64") return 8;
  if (t == "Float32" || t == "Int32" || t == "UInt32") return 4;
  if (t == "Int16" || t == "UInt16") return 2;
  if (t == "Int8" || t == "UInt8") return 1;
  return 0;
}

double vtk_value(const char* p, const std::string& t) {
  if (t == "Float64") return load<double>(p);
  if (t == "Float32") return load<float>(p);
  if (t == "Int64") return double(load<std::int64_t>(p));
  if (t == "UInt64") return double(load<std::uint64_t>(p));
  if (t == "Int32") return load<std::int32_t>(p);
  if (t == "UInt32") return load<std::uint32_t>(p);
  if (t == "Int16") return load<std::int16_t>(p);
  if (t == "UInt16") return load<std::uint16_t>(p);
  if (t == "Int8") return load<std::int8_t>(p);
  return load<std::uint8_t>(p);
}

}  // namespace

std::vector<PvdEntry> read_pvd(const fs::path& pvd) {
  const std::string text = read_file(pvd, "ParaView collection");
  std::vector<PvdEntry> out;
  for (std::size_t pos = text.find("<DataSet"); pos != std::string::npos; pos = text.find("<DataSet", pos + 1)) {
    const std::string tag = text.substr(pos, text.find('>', pos) - pos);
    const auto t = attribute(tag, "timestep"), f = attribute(tag, "file");
    if (!t || !f || t->empty() || f->empty()) throw ReadError(pvd.string() + ": malformed DataSet entry");
    PvdEntry e;
    const auto [ptr, ec] = std::from_chars(t->data(), t->data() + t->size(), e.time);
    if (ec != std::errc() || ptr != t->data() + t->size())
      throw ReadError(pvd.string() + ": bad timestep '" + *t + "'");
    e.file = xml_unescape(*f);
    out.push_back(std::move(e));
  }
  return out;
}

VtkArrays read_vtk_arrays(const fs::path& file, const std::function<bool(const std::string&)>& wanted) {
  auto fail = [&](const std::string& why) { return ReadError("cannot read '" + file.string() + "': " + why); };
  std::string bytes;
  try {
    bytes = read_file(file, "VTK");
  } catch (const ReadError&) {
    throw fail("cannot open");
  }
  const auto vtkfile = bytes.find("<VTKFile");
  const auto appended = bytes.find("<AppendedData");
  if (vtkfile == std::string::npos || appended == std::string::npos) throw fail("not a VTK XML file with appended data");
  const auto underscore = bytes.find('_', appended);
  if (underscore == std::string::npos) throw fail("no '_' marker before the appended data");
  const std::size_t data = underscore + 1;

  const std::string root = bytes.substr(vtkfile, bytes.find('>', vtkfile) - vtkfile);
  const bool header64 = attribute(root, "header_type").value_or("UInt32") == "UInt64";
  if (const auto bo = attribute(root, "byte_order"); bo && *bo != "LittleEndian") throw fail("big-endian data");
  const auto piece_at = bytes.find("<Piece");
  if (piece_at == std::string::npos) throw fail("no <Piece>");
  const std::string piece = bytes.substr(piece_at, bytes.find('>', piece_at) - piece_at);

  VtkArrays out;
  out.points = std::stoull(attribute(piece, "NumberOfPoints").value_or("0"));
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
    const std::string name = xml_unescape(attribute(tag, "Name").value_or(""));
    if (!in_points && !wanted(name)) continue;
    if (attribute(tag, "format").value_or("") != "appended") throw fail("array '" + name + "' is not appended raw data");
    const std::string type = attribute(tag, "type").value_or("");
    const std::size_t size = vtk_size(type);
    if (size == 0) throw fail("array '" + name + "' has an unknown type");
    const std::size_t offset = std::stoull(attribute(tag, "offset").value_or("0"));
    const std::size_t hsize = header64 ? 8 : 4;
    if (data + offset + hsize > bytes.size()) throw fail("array '" + name + "' offset is past the end");
    const std::size_t nbytes = header64 ? load<std::uint64_t>(bytes.data() + data + offset)
                                        : load<std::uint32_t>(bytes.data() + data + offset);
    if (data + offset + hsize + nbytes > bytes.size()) throw fail("array '" + name + "' is truncated");
    const char* p = bytes.data() + data + offset + hsize;
    std::vector<double> values(nbytes / size);
    for (std::size_t i = 0; i < values.size(); ++i) values[i] = vtk_value(p + i * size, type);
    out.arrays[in_points ? std::string("Points") : name] = std::move(values);
  }
  return out;
}

}  // namespace perifx::io
