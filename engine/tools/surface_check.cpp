// Surface checker (see surface_check.hpp).
#include "tools/surface_check.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <ostream>
#include <unordered_map>

#include "io/run_dir.hpp"

namespace perifx {
namespace {

// Cells of side h over a point set: points in the 27 cells around p are the candidates within h.
struct PointGrid {
  double h = 1.0;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> cells;
  static std::uint64_t key(long long i, long long j, long long k) {
    return (static_cast<std::uint64_t>(i & 0x1FFFFF) << 42) | (static_cast<std::uint64_t>(j & 0x1FFFFF) << 21) |
           static_cast<std::uint64_t>(k & 0x1FFFFF);
  }
  long long cell(double x) const { return static_cast<long long>(std::floor(x / h)); }
  PointGrid(const std::vector<Vec3>& p, double size) : h(size) {
    for (std::uint32_t i = 0; i < p.size(); ++i) cells[key(cell(p[i].x()), cell(p[i].y()), cell(p[i].z()))].push_back(i);
  }
  template <class F>
  void near(const Vec3& q, F&& f) const {
    const long long ci = cell(q.x()), cj = cell(q.y()), ck = cell(q.z());
    for (long long i = ci - 1; i <= ci + 1; ++i)
      for (long long j = cj - 1; j <= cj + 1; ++j)
        for (long long k = ck - 1; k <= ck + 1; ++k) {
          const auto it = cells.find(key(i, j, k));
          if (it == cells.end()) continue;
          for (std::uint32_t p : it->second)
            if (f(p)) return;
        }
  }
};

}  // namespace

SurfaceCheckReport check_run_surfaces(const std::filesystem::path& dir, const SurfaceCheckOptions& options) {
  io::RunDirectory run;
  io::RunMesh mesh;
  try {
    run = io::scan_run_directory(dir);
    mesh = io::read_run_mesh(dir);
  } catch (const io::RunDirError& e) {
    throw SurfaceCheckError(e.what());
  }
  SurfaceCheckReport report;
  report.horizon = options.horizon > 0.0 ? options.horizon : mesh.horizon;
  if (!(report.horizon > 0.0))
    throw SurfaceCheckError(dir.string() + ": mesh.json records no horizon (a run without surface output, or an "
                                           "older run): give it with --horizon");
  const double delta = report.horizon;
  std::vector<Vec3> reference_particles;  // frame 0
  std::unique_ptr<PointGrid> reference_grid;
  for (const io::FrameFiles& files : run.frames) {
    if (options.frames && files.index >= *options.frames) break;
    if (files.surface.empty() || files.particles.empty()) continue;
    io::ParticleFrame particles;
    io::SurfaceFrame s;
    try {
      particles = io::read_particle_frame(files.particles);
      s = io::read_surface_frame(files.surface);
    } catch (const io::RunDirError& e) {
      throw SurfaceCheckError(e.what());
    }
    if (reference_particles.empty()) {
      reference_particles = particles.position;
      reference_grid = std::make_unique<PointGrid>(reference_particles, delta);
    }
    SurfaceFrameCheck c;
    c.frame = files.index;
    c.time = files.time;
    c.triangles = s.triangle.size();
    const std::size_t nv = s.vertex.size();
    // Welded vertex ids.
    std::vector<std::uint32_t> weld(nv);
    {
      std::unordered_map<std::uint32_t, std::uint32_t> first;
      for (std::uint32_t v = 0; v < nv; ++v) {
        const std::uint32_t key = s.source.size() == nv ? s.source[v] : v;
        weld[v] = first.emplace(key, v).first->second;
      }
    }
    std::vector<char> used(nv, 0);
    for (const auto& t : s.triangle)
      for (auto v : t) used[weld[v]] = 1;
    c.vertices = static_cast<std::size_t>(std::count(used.begin(), used.end(), 1));
    const bool have_pieces = s.fragment.size() == s.triangle.size() && particles.fragment.size() == particles.position.size();
    // Piece per (welded) vertex, from its triangles.
    constexpr std::uint32_t kNone = 0xFFFFFFFFu;
    std::vector<std::uint32_t> vertex_piece(nv, kNone);
    std::map<std::uint32_t, int> pieces;
    for (std::size_t f = 0; f < s.triangle.size(); ++f) {
      const std::uint32_t piece = have_pieces ? s.fragment[f] : 0u;
      pieces[piece] = 1;
      for (auto v : s.triangle[f]) vertex_piece[weld[v]] = piece;
    }
    c.pieces = pieces.size();
    // Far vertices.
    {
      const PointGrid grid(particles.position, delta);
      // A vertex beyond δ of every particle of its piece is measured against its own rest distance
      // when the file has reference positions (perifx's PLY): the particles of its piece, by piece,
      // made on the first such vertex.
      const bool have_rest = s.reference.size() == nv && reference_particles.size() == particles.position.size();
      std::map<std::uint32_t, std::vector<std::uint32_t>> piece_particles;
      for (std::uint32_t v = 0; v < nv; ++v) {
        if (!used[v]) continue;
        bool found = false;
        grid.near(s.vertex[v], [&](std::uint32_t p) {
          if (have_pieces && particles.fragment[p] != vertex_piece[v]) return false;
          found = (particles.position[p] - s.vertex[v]).squaredNorm() <= delta * delta;
          return found;
        });
        if (found) continue;
        if (!have_rest && !options.details) {  // the δ test alone decides; no distances to report
          ++c.far_vertices;
          continue;
        }
        if (piece_particles.empty())
          for (std::uint32_t p = 0; p < particles.position.size(); ++p) piece_particles[have_pieces ? particles.fragment[p] : 0u].push_back(p);
        double nearest = kInfinity, nearest_at_rest = kInfinity;
        if (const auto it = piece_particles.find(have_pieces ? vertex_piece[v] : 0u); it != piece_particles.end())
          for (const std::uint32_t p : it->second) {
            nearest = std::min(nearest, (particles.position[p] - s.vertex[v]).norm());
            if (have_rest) nearest_at_rest = std::min(nearest_at_rest, (reference_particles[p] - s.reference[v]).norm());
          }
        // Not a spike: no farther from its piece than at rest (within 0.1 δ). A small piece of
        // elongated tets (TetGen at a radius-edge bound of 3) has vertices beyond δ of its particles
        // at rest; moved rigidly they keep that distance, which the δ test alone called far.
        if (have_rest && nearest <= nearest_at_rest + 0.1 * delta) continue;
        ++c.far_vertices;
        if (options.details) {
          char line[320];
          std::snprintf(line, sizeof line,
                        "far vertex source %u piece %u at (%.6g %.6g %.6g): nearest particle of its piece %.4g m = %.3g delta"
                        " (at rest %.4g m)",
                        s.source.size() == nv ? s.source[v] : v, vertex_piece[v], s.vertex[v].x(), s.vertex[v].y(),
                        s.vertex[v].z(), nearest, nearest / delta, nearest_at_rest);
          c.details.push_back(line);
        }
      }
    }
    // Edges: directed uses per undirected welded edge; shells by union over edges.
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::uint32_t>> edges;
    std::vector<std::uint32_t> parent(s.triangle.size());
    for (std::uint32_t f = 0; f < parent.size(); ++f) parent[f] = f;
    auto find = [&](std::uint32_t a) {
      while (parent[a] != a) a = parent[a] = parent[parent[a]];
      return a;
    };
    for (std::uint32_t f = 0; f < s.triangle.size(); ++f)
      for (int e = 0; e < 3; ++e) {
        const std::uint32_t a = weld[s.triangle[f][static_cast<std::size_t>(e)]];
        const std::uint32_t b = weld[s.triangle[f][static_cast<std::size_t>((e + 1) % 3)]];
        c.longest_edge = std::max(c.longest_edge, (s.vertex[a] - s.vertex[b]).norm());
        edges[{std::min(a, b), std::max(a, b)}].push_back(f);
      }
    std::vector<char> shell_open(s.triangle.size(), 0);
    for (const auto& [key, faces] : edges) {
      for (std::size_t k = 1; k < faces.size(); ++k) {
        const std::uint32_t ra = find(faces[0]), rb = find(faces[k]);
        if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
      }
    }
    for (const auto& [key, faces] : edges)
      if (faces.size() != 2) {
        ++(faces.size() < 2 ? c.open_edges : c.nonmanifold_edges);
        shell_open[find(faces[0])] = 1;
        if (options.details) {
          std::string line = faces.size() < 2 ? "open" : "non-manifold";
          line += " edge sources ";
          line += std::to_string(s.source.size() == nv ? s.source[key.first] : key.first);
          line += '-';
          line += std::to_string(s.source.size() == nv ? s.source[key.second] : key.second);
          line += ", tets";
          for (auto f : faces) {
            line += ' ';
            line += std::to_string(s.tet.size() == s.triangle.size() ? s.tet[f] : f);
          }
          c.details.push_back(line);
        }
      }
    struct Shell {
      double volume = 0.0;
      Vec3 lo = Vec3::Constant(kInfinity), hi = Vec3::Constant(-kInfinity);
      std::uint32_t piece = 0;
    };
    std::map<std::uint32_t, Shell> shells;
    for (std::uint32_t f = 0; f < s.triangle.size(); ++f) {
      const auto& t = s.triangle[f];
      Shell& sh = shells[find(f)];
      sh.volume += s.vertex[t[0]].dot(s.vertex[t[1]].cross(s.vertex[t[2]])) / 6.0;
      for (auto v : t) sh.lo = sh.lo.cwiseMin(s.vertex[v]), sh.hi = sh.hi.cwiseMax(s.vertex[v]);
      sh.piece = have_pieces ? s.fragment[f] : 0u;
    }
    // A closed shell with negative volume inside (bounding box) a positive closed shell of its own
    // piece bounds a cavity or an internal crack (outward normals point into the void): not inverted.
    for (const auto& [root, sh] : shells) {
      if (shell_open[root] || !(sh.volume < 0.0)) continue;
      bool enclosed = false;
      for (const auto& [other, outer] : shells)
        enclosed = enclosed || (other != root && !shell_open[other] && outer.volume > 0.0 && outer.piece == sh.piece &&
                                (outer.lo.array() <= sh.lo.array()).all() && (sh.hi.array() <= outer.hi.array()).all());
      ++(enclosed ? c.cavities : c.inverted_shells);
      if (!enclosed && options.details) {
        std::vector<std::uint32_t> tets;
        for (std::uint32_t f = 0; f < s.triangle.size(); ++f)
          if (find(f) == root) tets.push_back(s.tet.size() == s.triangle.size() ? s.tet[f] : f);
        std::sort(tets.begin(), tets.end());
        tets.erase(std::unique(tets.begin(), tets.end()), tets.end());
        char head[96];
        std::snprintf(head, sizeof head, "inverted shell piece %u volume %.3g m^3, tets", sh.piece, sh.volume);
        std::string line = head;
        for (auto t : tets) {
          line += ' ';
          line += std::to_string(t);
        }
        c.details.push_back(line);
      }
    }
    // Stretched triangles.
    if (s.reference.size() == nv && s.tet.size() == s.triangle.size() && particles.position.size() == reference_particles.size()) {
      c.stretched_triangles = 0;
      const double limit = options.stretch_ratio;
      for (std::uint32_t f = 0; f < s.triangle.size(); ++f) {
        double worst = 0.0, worst_ref = 0.0, worst_now = 0.0;  // the most stretched edge, m
        for (int e = 0; e < 3; ++e) {
          const std::uint32_t a = s.triangle[f][static_cast<std::size_t>(e)], b = s.triangle[f][static_cast<std::size_t>((e + 1) % 3)];
          const double ref = (s.reference[a] - s.reference[b]).norm();
          const double now = (s.vertex[a] - s.vertex[b]).norm();
          if (ref > 0.0 && now / ref > worst) worst = now / ref, worst_ref = ref, worst_now = now;
        }
        if (worst <= limit) continue;
        const std::uint32_t p = s.tet[f];
        if (p >= reference_particles.size()) continue;
        double particle_stretch = 0.0;
        reference_grid->near(reference_particles[p], [&](std::uint32_t q) {
          if (q == p || (have_pieces && particles.fragment[q] != particles.fragment[p])) return false;
          const double ref = (reference_particles[q] - reference_particles[p]).norm();
          if (ref > delta || ref == 0.0) return false;
          particle_stretch = std::max(particle_stretch, (particles.position[q] - particles.position[p]).norm() / ref);
          return particle_stretch > limit;
        });
        c.stretched_triangles += particle_stretch <= limit;
        if (particle_stretch <= limit && options.details) {
          // The edge's lengths say whether it is a spike (an edge grown past the horizon) or the short
          // edge of a sliver opened to an ordinary edge (the full bunny's, assets/report/surfaces.md).
          char line[224];
          std::snprintf(line, sizeof line,
                        "stretched triangle of tet %u: edge ratio %.3g (%.3g m at rest, %.3g m = %.2g delta now), its "
                        "particles' neighbourhood %.3g",
                        p, worst, worst_ref, worst_now, worst_now / delta, particle_stretch);
          c.details.push_back(line);
        }
      }
    }
    report.frames.push_back(c);
  }
  if (report.frames.empty()) throw SurfaceCheckError(dir.string() + ": no frame has both surface and particle files");
  return report;
}

void print_surface_check(std::ostream& out, const SurfaceCheckReport& r) {
  char buf[256];
  std::snprintf(buf, sizeof buf, "horizon %.6g m\n", r.horizon);
  out << buf;
  out << "frame     time [s]  vertices  triangles  pieces   far  inverted  open  non-manifold  stretched  longest edge [m]  cavities\n";
  SurfaceFrameCheck total;
  bool any_stretch = false;
  for (const auto& f : r.frames) {
    char stretched[24];
    if (f.stretched_triangles < 0) std::snprintf(stretched, sizeof stretched, "n/a");
    else std::snprintf(stretched, sizeof stretched, "%lld", f.stretched_triangles);
    std::snprintf(buf, sizeof buf, "%5llu  %11.5g  %8zu  %9zu  %6zu  %4zu  %8zu  %4zu  %12zu  %9s  %16.5g  %8zu\n",
                  static_cast<unsigned long long>(f.frame), f.time, f.vertices, f.triangles, f.pieces, f.far_vertices,
                  f.inverted_shells, f.open_edges, f.nonmanifold_edges, stretched, f.longest_edge, f.cavities);
    out << buf;
    for (const auto& line : f.details) out << "       " << line << "\n";
    total.far_vertices += f.far_vertices;
    total.inverted_shells += f.inverted_shells;
    total.open_edges += f.open_edges;
    total.nonmanifold_edges += f.nonmanifold_edges;
    any_stretch = any_stretch || f.stretched_triangles >= 0;
    total.stretched_triangles = std::max(total.stretched_triangles, 0LL) + std::max(f.stretched_triangles, 0LL);
    total.longest_edge = std::max(total.longest_edge, f.longest_edge);
  }
  char stretched[24];
  if (any_stretch) std::snprintf(stretched, sizeof stretched, "%lld", std::max(total.stretched_triangles, 0LL));
  else std::snprintf(stretched, sizeof stretched, "n/a");
  std::snprintf(buf, sizeof buf,
                "total  far %zu, inverted %zu, open %zu, non-manifold %zu, stretched %s, longest edge %.5g m: %s\n",
                total.far_vertices, total.inverted_shells, total.open_edges, total.nonmanifold_edges, stretched,
                total.longest_edge, r.issues() ? "PROBLEMS" : "ok");
  out << buf;
}

}  // namespace perifx
