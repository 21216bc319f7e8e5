#include "compare.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "io/io.hpp"
#include "world_state.hpp"

namespace perifx {
namespace fs = std::filesystem;
namespace {

const char* solver_name(scene::Solver s) {
  switch (s) {
    case scene::Solver::peridynamics: return "peridynamics";
    case scene::Solver::fem_linear: return "fem_linear";
    case scene::Solver::fem_corotated: return "fem_corotated";
  }
  return "?";
}

std::string tet_hash(const std::vector<std::array<std::uint32_t, 4>>& tets, std::size_t vertices) {
  std::uint64_t h = 0xcbf29ce484222325ull;  // FNV-1a 64
  auto mix = [&h](std::uint64_t word) {
    for (int b = 0; b < 8; ++b) h = (h ^ ((word >> (8 * b)) & 0xffu)) * 0x100000001b3ull;
  };
  mix(vertices);
  mix(tets.size());
  for (const auto& t : tets)
    for (auto v : t) mix(v);
  char buf[20];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

std::string read_text(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw CompareError("cannot read " + file.string());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Value of attribute `name` inside the tag text `tag` ("" when absent).
std::string attribute(const std::string& tag, const std::string& name) {
  const std::string key = " " + name + "=\"";
  const auto at = tag.find(key);
  if (at == std::string::npos) return "";
  const auto start = at + key.size();
  const auto end = tag.find('"', start);
  return end == std::string::npos ? "" : tag.substr(start, end - start);
}

struct Series {
  std::vector<double> times;
  std::vector<fs::path> files;
};

Series read_pvd(const fs::path& dir) {
  const fs::path pvd = dir / "particles.pvd";
  if (!fs::exists(pvd)) throw CompareError(dir.string() + ": not a run directory (no particles.pvd)");
  const std::string text = read_text(pvd);
  Series s;
  for (std::size_t pos = text.find("<DataSet"); pos != std::string::npos; pos = text.find("<DataSet", pos + 1)) {
    const std::string tag = text.substr(pos, text.find('>', pos) - pos);
    const std::string t = attribute(tag, "timestep"), f = attribute(tag, "file");
    if (t.empty() || f.empty()) throw CompareError(pvd.string() + ": malformed DataSet entry");
    s.times.push_back(std::stod(t));
    s.files.push_back(dir / f);
  }
  if (s.files.empty()) throw CompareError(pvd.string() + ": no frames");
  return s;
}

// The point coordinates of a perifx particle VTU (binary appended raw, Float64 points, UInt64 headers).
std::vector<Vec3> read_vtu_points(const fs::path& file) {
  const std::string text = read_text(file);
  auto fail = [&](const std::string& why) -> CompareError { return CompareError(file.string() + ": " + why); };
  const auto piece = text.find("<Piece");
  if (piece == std::string::npos) throw fail("no <Piece> (not a perifx particle VTU)");
  const std::string piece_tag = text.substr(piece, text.find('>', piece) - piece);
  const std::size_t n = std::stoull(attribute(piece_tag, "NumberOfPoints"));
  const auto points = text.find("<Points>");
  const auto array = text.find("<DataArray", points);
  if (points == std::string::npos || array == std::string::npos) throw fail("no <Points> array");
  const std::string tag = text.substr(array, text.find('>', array) - array);
  if (attribute(tag, "type") != "Float64" || attribute(tag, "format") != "appended")
    throw fail("points are not Float64 appended data");
  if (text.find("header_type=\"UInt64\"") == std::string::npos) throw fail("expected header_type UInt64");
  const auto appended = text.find("<AppendedData");
  const auto marker = text.find('_', appended);
  if (appended == std::string::npos || marker == std::string::npos) throw fail("no appended data");
  const std::size_t at = marker + 1 + std::stoull(attribute(tag, "offset"));
  std::uint64_t bytes = 0;
  if (at + sizeof bytes > text.size()) throw fail("truncated");
  std::memcpy(&bytes, text.data() + at, sizeof bytes);
  if (bytes != n * 3 * sizeof(double) || at + sizeof bytes + bytes > text.size()) throw fail("points block has the wrong size");
  std::vector<Vec3> out(n);
  for (std::size_t i = 0; i < n; ++i) {
    double xyz[3];
    std::memcpy(xyz, text.data() + at + sizeof bytes + 24 * i, sizeof xyz);
    out[i] = Vec3(xyz[0], xyz[1], xyz[2]);
  }
  return out;
}

struct RunMesh {
  bool present = false;
  std::string solver = "unknown", hash;
  bool vertices_are_particles = false;
  std::size_t particles = 0, tet_count = 0;
  std::vector<std::array<std::uint32_t, 4>> tets;
};

RunMesh read_mesh(const fs::path& dir) {
  RunMesh m;
  const fs::path file = dir / "mesh.json";
  if (!fs::exists(file)) return m;
  try {
    const auto j = nlohmann::json::parse(read_text(file));
    m.present = true;
    m.solver = j.at("solver").get<std::string>();
    m.vertices_are_particles = j.at("particles_are").get<std::string>() == "mesh_vertices";
    m.particles = j.at("particles").get<std::size_t>();
    m.tet_count = j.at("tet_count").get<std::size_t>();
    m.hash = j.at("tet_hash").get<std::string>();
    if (j.contains("tets")) m.tets = j["tets"].get<std::vector<std::array<std::uint32_t, 4>>>();
  } catch (const nlohmann::json::exception& e) {
    throw CompareError(file.string() + ": " + e.what());
  }
  return m;
}

double diagonal_of(const std::vector<Vec3>& pts) {
  Vec3 lo = Vec3::Constant(kInfinity), hi = -lo;
  for (const auto& p : pts) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  return (hi - lo).norm();
}

std::vector<Vec3> barycenters(const std::vector<Vec3>& vertices, const RunMesh& m, const fs::path& dir) {
  std::vector<Vec3> out(m.tets.size());
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    Vec3 c = Vec3::Zero();
    for (auto v : m.tets[t]) {
      if (v >= vertices.size()) throw CompareError(dir.string() + ": mesh.json tet " + std::to_string(t) + " names vertex " +
                                                   std::to_string(v) + " but the frames have " + std::to_string(vertices.size()) + " points");
      c += vertices[v];
    }
    out[t] = 0.25 * c;
  }
  return out;
}

}  // namespace

void write_run_mesh(const WorldState& w, const fs::path& directory) {
  const bool fem = w.scene.solver != scene::Solver::peridynamics;
  std::string text = "{\n  \"solver\": \"";
  text += solver_name(w.scene.solver);
  text += "\",\n  \"particles_are\": \"";
  text += fem ? "mesh_vertices" : "tet_barycenters";
  text += "\",\n  \"particles\": " + std::to_string(w.particles.count());
  text += ",\n  \"vertices\": " + std::to_string(w.mesh.vertices.size());
  text += ",\n  \"tet_count\": " + std::to_string(w.mesh.tets.size());
  text += ",\n  \"tet_hash\": \"" + tet_hash(w.mesh.tets, w.mesh.vertices.size()) + "\"";
  if (fem) {  // the connectivity that maps vertices back to the PD particles (tet barycenters)
    text += ",\n  \"tets\": [";
    for (std::size_t t = 0; t < w.mesh.tets.size(); ++t) {
      const auto& v = w.mesh.tets[t];
      text += (t ? ",\n    [" : "\n    [") + std::to_string(v[0]) + "," + std::to_string(v[1]) + "," +
              std::to_string(v[2]) + "," + std::to_string(v[3]) + "]";
    }
    text += "\n  ]";
  }
  text += "\n}\n";
  io::write_atomic(directory / "mesh.json", [&](std::ostream& out) { out << text; });
}

CompareResult compare_runs(const fs::path& dir_a, const fs::path& dir_b) {
  const Series sa = read_pvd(dir_a), sb = read_pvd(dir_b);
  const RunMesh ma = read_mesh(dir_a), mb = read_mesh(dir_b);
  CompareResult r;
  r.solver_a = ma.solver;
  r.solver_b = mb.solver;
  r.frames_a = sa.files.size();
  r.frames_b = sb.files.size();
  if (ma.present && mb.present && ma.hash != mb.hash)
    throw CompareError("the runs are not of the same tet mesh: " + dir_a.string() + " has " + std::to_string(ma.tet_count) +
                       " tets (hash " + ma.hash + "), " + dir_b.string() + " has " + std::to_string(mb.tet_count) +
                       " tets (hash " + mb.hash + "); compare runs of the same scene and resolution");
  // How each run's frame points become the compared points (tet barycenters when the kinds differ).
  const bool a_vertices = ma.vertices_are_particles, b_vertices = mb.vertices_are_particles;
  const bool map_a = a_vertices && !b_vertices, map_b = b_vertices && !a_vertices;
  if (map_a && ma.tets.empty()) throw CompareError(dir_a.string() + ": FEM run without tets in mesh.json");
  if (map_b && mb.tets.empty()) throw CompareError(dir_b.string() + ": FEM run without tets in mesh.json");
  r.mapping = map_a ? "run A's FEM vertices averaged per tet onto run B's particles (tet barycenters)"
              : map_b ? "run B's FEM vertices averaged per tet onto run A's particles (tet barycenters)"
                      : "direct, particle by particle";
  auto points_of = [&](const Series& s, std::size_t k, bool map, const RunMesh& m, const fs::path& dir) {
    auto pts = read_vtu_points(s.files[k]);
    return map ? barycenters(pts, m, dir) : pts;
  };

  const std::size_t frames = std::min(sa.files.size(), sb.files.size());
  const double spacing = frames > 1 ? std::abs(sa.times[1] - sa.times[0]) : 1.0;
  double sum_all = 0.0;
  std::size_t count_all = 0;
  for (std::size_t k = 0; k < frames; ++k) {
    if (std::abs(sa.times[k] - sb.times[k]) > 0.01 * spacing + 1e-12)
      throw CompareError("frame " + std::to_string(k) + " is at t = " + std::to_string(sa.times[k]) + " s in " +
                         dir_a.string() + " but t = " + std::to_string(sb.times[k]) + " s in " + dir_b.string() +
                         "; the runs need the same frame rate");
    const auto pa = points_of(sa, k, map_a, ma, dir_a);
    const auto pb = points_of(sb, k, map_b, mb, dir_b);
    if (pa.size() != pb.size())
      throw CompareError("frame " + std::to_string(k) + ": " + std::to_string(pa.size()) + " points in " + dir_a.string() +
                         " vs " + std::to_string(pb.size()) + " in " + dir_b.string() +
                         (ma.present && mb.present ? "" : " (a run without mesh.json cannot be mapped)") +
                         "; compare runs of the same scene and resolution");
    if (k == 0) {
      r.points = pa.size();
      r.diagonal = diagonal_of(map_a ? read_vtu_points(sa.files[0]) : pa);
      if (!(r.diagonal > 0.0)) throw CompareError(dir_a.string() + ": frame 0 has a zero bounding box");
      // Same scene ⇒ identical reference positions (up to the VTU's exact doubles and the 1/4 mean).
      double worst = 0.0;
      for (std::size_t i = 0; i < pa.size(); ++i) worst = std::max(worst, (pa[i] - pb[i]).norm());
      if (worst > 1e-9 * r.diagonal)
        throw CompareError("frame 0 differs by up to " + std::to_string(worst / r.diagonal) +
                           " of the diagonal: the runs do not start from the same mesh (same scene and resolution?)");
    }
    CompareFrame f;
    f.time_a = sa.times[k];
    f.time_b = sb.times[k];
    double sum = 0.0;
    for (std::size_t i = 0; i < pa.size(); ++i) {
      const double e = (pa[i] - pb[i]).norm() / r.diagonal;
      f.max_error = std::max(f.max_error, e);
      sum += e;
    }
    f.mean_error = pa.empty() ? 0.0 : sum / double(pa.size());
    sum_all += sum;
    count_all += pa.size();
    r.max_error = std::max(r.max_error, f.max_error);
    r.frames.push_back(f);
  }
  r.mean_error = count_all ? sum_all / double(count_all) : 0.0;
  return r;
}

void write_compare_csv(const CompareResult& r, const fs::path& file) {
  std::ostringstream s;
  s.precision(9);
  s << "frame,time,max_error,mean_error\n";
  for (std::size_t k = 0; k < r.frames.size(); ++k)
    s << k << ',' << r.frames[k].time_a << ',' << r.frames[k].max_error << ',' << r.frames[k].mean_error << '\n';
  s << "overall,," << r.max_error << ',' << r.mean_error << '\n';
  const std::string text = s.str();
  io::write_atomic(file, [&](std::ostream& out) { out << text; });
}

}  // namespace perifx
