// Run-directory reading (see run_dir.hpp), on top of the format readers of engine/io: VTU and PVD
// (vtk.hpp), PLY (ply.hpp), OBJ (obj.hpp); plus projectiles.csv and mesh.json, which only runs
// have, written and read here.
#include "io/run_dir.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "io/atomic.hpp"
#include "io/obj.hpp"
#include "io/ply.hpp"
#include "io/vtk.hpp"

namespace perifx::io {

namespace fs = std::filesystem;

namespace {

// Runs a format reader; its ReadError (which names the file) becomes a RunDirError.
template <class Read>
auto reading(Read&& read) {
  return io::rethrow_as<ReadError, RunDirError>(std::forward<Read>(read));
}

std::uint32_t as_index(double v) { return v < 0 ? 0u : static_cast<std::uint32_t>(std::llround(v)); }

std::vector<std::uint32_t> as_indices(const std::vector<double>& values) {
  std::vector<std::uint32_t> out(values.size());
  std::transform(values.begin(), values.end(), out.begin(), as_index);
  return out;
}

bool frame_field(const std::string& name) {
  return name == "volume" || name == "damage" || name == "material_id" || name == "body_id" || name == "fragment_id";
}

ParticleFrame read_vtu_particles(const fs::path& file) {
  const VtkArrays vtk = reading([&] { return read_vtk_arrays(file, frame_field); });
  const std::size_t n = vtk.points;
  const auto pts = vtk.arrays.find("Points");
  if (pts == vtk.arrays.end() || pts->second.size() != 3 * n)
    throw RunDirError("cannot read '" + file.string() + "': no Points array with 3 components per point");
  ParticleFrame f;
  f.position.resize(n);
  for (std::size_t i = 0; i < n; ++i) f.position[i] = Vec3(pts->second[3 * i], pts->second[3 * i + 1], pts->second[3 * i + 2]);
  auto scalar_field = [&](const char* name) -> const std::vector<double>* {
    const auto it = vtk.arrays.find(name);
    return it != vtk.arrays.end() && it->second.size() == n ? &it->second : nullptr;
  };
  if (const auto* v = scalar_field("volume")) f.volume = *v;
  if (const auto* d = scalar_field("damage")) f.damage = *d;
  if (const auto* m = scalar_field("material_id")) f.material = as_indices(*m);
  else if (const auto* b = scalar_field("body_id")) f.material = as_indices(*b);
  if (const auto* g = scalar_field("fragment_id")) f.fragment = as_indices(*g);
  return f;
}

ParticleFrame read_ply_particles(const fs::path& file) {
  const PlyContent ply = reading([&] { return read_ply(file); });
  ParticleFrame f;
  f.position = ply.surface.vertices;
  auto field = [&](const char* name) -> const std::vector<double>* {
    const auto it = ply.vertex_properties.find(name);
    return it == ply.vertex_properties.end() ? nullptr : &it->second;
  };
  if (const auto* v = field("volume")) f.volume = *v;
  if (const auto* d = field("damage")) f.damage = *d;
  if (const auto* m = field("material_id")) f.material = as_indices(*m);
  else if (const auto* b = field("body_id")) f.material = as_indices(*b);
  if (const auto* g = field("fragment_id")) f.fragment = as_indices(*g);
  return f;
}

}  // namespace

ParticleFrame read_particle_frame(const fs::path& file) {
  return file.extension() == ".ply" ? read_ply_particles(file) : read_vtu_particles(file);
}

SurfaceFrame read_surface_frame(const fs::path& file) {
  SurfaceFrame s;
  if (file.extension() == ".obj") {
    TriangleSurface obj = reading([&] { return read_obj(file); });
    s.vertex = std::move(obj.vertices);
    s.triangle = std::move(obj.triangles);
    s.crack = std::move(obj.crack);
  } else {
    PlyContent ply = reading([&] { return read_ply(file); });
    s.vertex = std::move(ply.surface.vertices);
    s.triangle = std::move(ply.surface.triangles);
    s.crack = std::move(ply.surface.crack);
    const auto& vp = ply.vertex_properties;
    if (const auto d = vp.find("damage"); d != vp.end()) s.damage = d->second;
    if (vp.count("rx") && vp.count("ry") && vp.count("rz")) {
      s.reference.resize(s.vertex.size());
      for (std::size_t v = 0; v < s.vertex.size(); ++v) s.reference[v] = Vec3(vp.at("rx")[v], vp.at("ry")[v], vp.at("rz")[v]);
    }
    if (const auto it = vp.find("source"); it != vp.end()) s.source = as_indices(it->second);
    if (const auto it = ply.face_properties.find("fragment"); it != ply.face_properties.end()) s.fragment = as_indices(it->second);
    if (const auto it = ply.face_properties.find("tet"); it != ply.face_properties.end()) s.tet = as_indices(it->second);
  }
  for (const auto& t : s.triangle)
    for (const auto i : t)
      if (i >= s.vertex.size()) throw RunDirError("cannot read '" + file.string() + "': triangle index out of range");
  return s;
}

std::vector<TimedFile> particle_series(const fs::path& dir) {
  const fs::path pvd = dir / "particles.pvd";
  if (!fs::exists(pvd)) throw RunDirError(dir.string() + ": not a run directory (no particles.pvd)");
  std::vector<TimedFile> out;
  for (const PvdEntry& e : reading([&] { return read_pvd(pvd); })) out.push_back({e.time, dir / e.file});
  if (out.empty()) throw RunDirError(pvd.string() + ": no frames");
  return out;
}

RunDirectory scan_run_directory(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw RunDirError("'" + dir.string() + "' is not a directory");
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
    throw RunDirError("'" + dir.string() + "' has no particles.NNNN.vtu/.ply or surface.NNNN.ply/.obj frames");

  // Frame times from the .pvd (file="particles.0003.vtu" timestep="..."), else from mesh.json's frame
  // rate and step as the runner places frames (runner.cpp), else 30 fps.
  std::map<std::string, double> pvd_time;
  if (fs::exists(dir / "particles.pvd"))
    for (const PvdEntry& e : reading([&] { return read_pvd(dir / "particles.pvd"); }))
      pvd_time[e.file.filename().string()] = e.time;
  const RunMesh mesh = pvd_time.empty() ? read_run_mesh(dir) : RunMesh{};
  auto placed_time = [&](std::uint64_t k) {
    if (!(mesh.frame_rate > 0.0 && mesh.dt > 0.0)) return double(k) / 30.0;
    return double(frame_step(k, mesh.frame_rate, mesh.dt)) * mesh.dt;
  };
  for (auto& [k, f] : frames) {
    const auto it = f.particles.empty() ? pvd_time.end() : pvd_time.find(f.particles.filename().replace_extension(".vtu").string());
    f.time = it != pvd_time.end() ? it->second : placed_time(k);
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

void write_run_mesh(const fs::path& dir, const RunMesh& m) {
  // Hand-formatted (one tet per line) rather than dumped, so the file stays readable and its bytes
  // stay what earlier versions wrote.
  std::string text = "{\n  \"solver\": \"" + m.solver;
  text += "\",\n  \"particles_are\": \"";
  text += m.vertices_are_particles ? "mesh_vertices" : "tet_barycenters";
  text += "\",\n  \"particles\": " + std::to_string(m.particles);
  text += ",\n  \"vertices\": " + std::to_string(m.vertices);
  text += ",\n  \"tet_count\": " + std::to_string(m.tet_count);
  text += ",\n  \"tet_hash\": \"" + m.hash + "\"";
  // Each only when known (> 0): the horizon for runs that write surfaces (what `perifx check-surface`
  // measures against), the frame rate and step for frame times without particles.pvd.
  for (const auto& [key, value] : {std::pair{"horizon", m.horizon}, std::pair{"frame_rate", m.frame_rate}, std::pair{"dt", m.dt}}) {
    if (!(value > 0.0)) continue;
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof buf, value);
    text += ",\n  \"" + std::string(key) + "\": " + std::string(buf, r.ptr);
  }
  if (m.vertices_are_particles) {  // the connectivity that maps vertices back to the PD particles
    text += ",\n  \"tets\": [";
    for (std::size_t t = 0; t < m.tets.size(); ++t) {
      const auto& v = m.tets[t];
      text += (t ? ",\n    [" : "\n    [") + std::to_string(v[0]) + "," + std::to_string(v[1]) + "," +
              std::to_string(v[2]) + "," + std::to_string(v[3]) + "]";
    }
    text += "\n  ]";
  }
  text += "\n}\n";
  write_atomic(dir / "mesh.json", [&](std::ostream& out) { out << text; });
}

RunMesh read_run_mesh(const fs::path& dir) {
  RunMesh m;
  const fs::path file = dir / "mesh.json";
  if (!fs::exists(file)) return m;
  try {
    const auto j = nlohmann::json::parse(reading([&] { return read_file(file, "mesh.json"); }));
    m.present = true;
    m.solver = j.at("solver").get<std::string>();
    m.vertices_are_particles = j.at("particles_are").get<std::string>() == "mesh_vertices";
    m.particles = j.at("particles").get<std::size_t>();
    m.vertices = j.value("vertices", std::size_t{0});
    m.tet_count = j.at("tet_count").get<std::size_t>();
    m.hash = j.at("tet_hash").get<std::string>();
    m.horizon = j.value("horizon", 0.0);
    m.frame_rate = j.value("frame_rate", 0.0);
    m.dt = j.value("dt", 0.0);
    if (j.contains("tets")) m.tets = j["tets"].get<std::vector<std::array<std::uint32_t, 4>>>();
  } catch (const nlohmann::json::exception& e) {
    throw RunDirError(file.string() + ": " + e.what());
  }
  return m;
}

}  // namespace perifx::io
