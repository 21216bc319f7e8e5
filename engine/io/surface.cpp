// Embedded tet mesh output: surface meshes (OBJ + MTL, binary PLY, VTP) and the tet mesh (VTU).
// Same rules as io.cpp: every file goes through write_atomic, no timestamps, locale-free number
// text (std::to_chars), so a frame's bytes depend only on its data.
#include <charconv>
#include <cstring>
#include <string>

#include "io/io.hpp"

namespace perifx::io {
namespace fs = std::filesystem;
namespace {

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

void check_surface(const fs::path& target, const SurfaceMesh& s) {
  const std::size_t n = s.triangles.size();
  if (s.crack.size() != n || s.fragment.size() != n)
    throw IoError("cannot write '" + target.string() + "': surface arrays have different lengths");
  for (const auto& t : s.triangles)
    for (auto v : t)
      if (v >= s.vertices.size())
        throw IoError("cannot write '" + target.string() + "': triangle vertex " + std::to_string(v) + " out of range");
}

template <class T>
void put(std::ostream& os, const T& v) {
  os.write(reinterpret_cast<const char*>(&v), sizeof v);
}

template <class T>
void vtk_block(std::ostream& os, const std::vector<T>& a) {
  const std::uint64_t bytes = a.size() * sizeof(T);
  put(os, bytes);
  if (bytes) os.write(reinterpret_cast<const char*>(a.data()), static_cast<std::streamsize>(bytes));
}

}  // namespace

void write_obj_surface(const fs::path& target, const SurfaceMesh& surface, const std::string& mtl_file) {
  check_surface(target, surface);
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
  for (std::uint8_t group : {std::uint8_t{0}, std::uint8_t{1}}) {
    text += group ? "g crack\nusemtl crack\n" : "g surface\nusemtl surface\n";
    for (std::size_t f = 0; f < surface.triangles.size(); ++f) {
      if (surface.crack[f] != group) continue;
      text += 'f';
      for (auto v : surface.triangles[f]) {
        text += ' ';
        append_number(text, std::uint64_t{v} + 1);
      }
      text += '\n';
    }
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

void write_ply_surface(const fs::path& target, const SurfaceMesh& surface) {
  check_surface(target, surface);
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment perifx embedded mesh surface\nelement vertex ";
  append_number(header, std::uint64_t{surface.vertices.size()});
  header += "\nproperty float x\nproperty float y\nproperty float z\nelement face ";
  append_number(header, std::uint64_t{surface.triangles.size()});
  header += "\nproperty list uchar int vertex_indices\nproperty uchar crack\nproperty uint fragment\nend_header\n";
  // Face record: 1 + 12 + 1 + 4 = 18 bytes, packed.
  std::string body;
  body.resize(12 * surface.vertices.size() + 18 * surface.triangles.size());
  char* out = body.data();
  for (const Vec3& v : surface.vertices) {
    const float xyz[3] = {static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z())};
    std::memcpy(out, xyz, sizeof xyz);
    out += sizeof xyz;
  }
  for (std::size_t f = 0; f < surface.triangles.size(); ++f) {
    *out++ = 3;
    for (auto v : surface.triangles[f]) {
      const auto i = static_cast<std::int32_t>(v);
      std::memcpy(out, &i, 4);
      out += 4;
    }
    *out++ = static_cast<char>(surface.crack[f]);
    std::memcpy(out, &surface.fragment[f], 4);
    out += 4;
  }
  write_atomic(target, [&](std::ostream& os) {
    os.write(header.data(), static_cast<std::streamsize>(header.size()));
    os.write(body.data(), static_cast<std::streamsize>(body.size()));
  });
}

void write_vtp_surface(const fs::path& target, const SurfaceMesh& surface) {
  check_surface(target, surface);
  const std::size_t nv = surface.vertices.size(), nf = surface.triangles.size();
  std::vector<std::int64_t> connectivity, offsets(nf);
  connectivity.reserve(3 * nf);
  for (std::size_t f = 0; f < nf; ++f) {
    for (auto v : surface.triangles[f]) connectivity.push_back(v);
    offsets[f] = static_cast<std::int64_t>(3 * (f + 1));
  }
  std::uint64_t offset = 0;
  auto next = [&](std::size_t bytes) {
    const std::uint64_t here = offset;
    offset += 8 + bytes;
    return std::to_string(here);
  };
  std::string xml = "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n  <PolyData>\n";
  xml += "    <Piece NumberOfPoints=\"" + std::to_string(nv) + "\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"" + std::to_string(nf) + "\">\n";
  xml += "      <CellData>\n        <DataArray type=\"UInt8\" Name=\"crack\" format=\"appended\" offset=\"" + next(nf) + "\"/>\n";
  xml += "        <DataArray type=\"UInt32\" Name=\"fragment\" format=\"appended\" offset=\"" + next(4 * nf) + "\"/>\n      </CellData>\n";
  xml += "      <Points>\n        <DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" format=\"appended\" offset=\"" + next(24 * nv) + "\"/>\n      </Points>\n";
  xml += "      <Polys>\n        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\" offset=\"" + next(8 * 3 * nf) + "\"/>\n";
  xml += "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"appended\" offset=\"" + next(8 * nf) + "\"/>\n      </Polys>\n";
  xml += "    </Piece>\n  </PolyData>\n  <AppendedData encoding=\"raw\">\n   _";
  write_atomic(target, [&](std::ostream& os) {
    os.write(xml.data(), static_cast<std::streamsize>(xml.size()));
    vtk_block(os, surface.crack);
    vtk_block(os, surface.fragment);
    vtk_block(os, surface.vertices);
    vtk_block(os, connectivity);
    vtk_block(os, offsets);
    os << "\n  </AppendedData>\n</VTKFile>\n";
  });
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
  std::uint64_t offset = 0;
  auto next = [&](std::size_t bytes) {
    const std::uint64_t here = offset;
    offset += 8 + bytes;
    return std::to_string(here);
  };
  std::string xml = "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n  <UnstructuredGrid>\n";
  xml += "    <Piece NumberOfPoints=\"" + std::to_string(nv) + "\" NumberOfCells=\"" + std::to_string(nt) + "\">\n";
  xml += "      <CellData>\n        <DataArray type=\"Float64\" Name=\"damage\" format=\"appended\" offset=\"" + next(8 * nt) + "\"/>\n";
  xml += "        <DataArray type=\"UInt32\" Name=\"fragment\" format=\"appended\" offset=\"" + next(4 * nt) + "\"/>\n      </CellData>\n";
  xml += "      <Points>\n        <DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" format=\"appended\" offset=\"" + next(24 * nv) + "\"/>\n      </Points>\n";
  xml += "      <Cells>\n        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\" offset=\"" + next(8 * 4 * nt) + "\"/>\n";
  xml += "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"appended\" offset=\"" + next(8 * nt) + "\"/>\n";
  xml += "        <DataArray type=\"UInt8\" Name=\"types\" format=\"appended\" offset=\"" + next(nt) + "\"/>\n      </Cells>\n";
  xml += "    </Piece>\n  </UnstructuredGrid>\n  <AppendedData encoding=\"raw\">\n   _";
  write_atomic(target, [&](std::ostream& os) {
    os.write(xml.data(), static_cast<std::streamsize>(xml.size()));
    vtk_block(os, damage);
    vtk_block(os, fragment);
    vtk_block(os, vertices);
    vtk_block(os, connectivity);
    vtk_block(os, offsets);
    vtk_block(os, types);
    os << "\n  </AppendedData>\n</VTKFile>\n";
  });
}

}  // namespace perifx::io
