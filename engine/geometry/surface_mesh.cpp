// Closed-surface checks and tetrahedralization by the external `tetgen` program. TetGen is AGPL, so
// it is run as a separate process on files in a private temp directory, never linked.
#include <fcntl.h>
#include <spawn.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>  // cross()

#include "geometry/mesh_checks.hpp"
#include "io/atomic.hpp"
#include "io/tetgen.hpp"

extern char** environ;

namespace perifx::geometry {

namespace {

namespace fs = std::filesystem;

std::string vertex_at(const SurfaceMesh& s, std::uint32_t v) {
  std::ostringstream o;
  o << v << " at (" << s.vertices[v].x() << ", " << s.vertices[v].y() << ", " << s.vertices[v].z() << ")";
  return o.str();
}

// One directed use of an undirected edge (a < b) by a triangle.
struct EdgeUse {
  std::uint32_t a, b;
  std::uint32_t triangle;
  std::uint8_t local;    // edge k of the triangle runs from corner k to corner k+1
  bool forward;          // the triangle runs a -> b
  bool operator<(const EdgeUse& o) const {
    return a != o.a ? a < o.a : b != o.b ? b < o.b : triangle < o.triangle;
  }
};

// A temp directory removed with everything in it when it goes out of scope.
struct TempDir {
  fs::path path;
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "perifx_tetgen_XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) {
      throw GeometryError("cannot create a temporary directory for tetgen: " + std::string(std::strerror(errno)));
    }
    path = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
};

// An executable on PATH, or empty.
fs::path find_program(const char* name) {
  const char* path = std::getenv("PATH");
  const std::string dirs = path ? path : "/usr/local/bin:/usr/bin:/bin";
  std::size_t start = 0;
  while (start <= dirs.size()) {
    std::size_t end = dirs.find(':', start);
    if (end == std::string::npos) end = dirs.size();
    const fs::path dir = end > start ? fs::path(dirs.substr(start, end - start)) : fs::path(".");
    const fs::path candidate = dir / name;
    std::error_code ec;
    if (fs::is_regular_file(candidate, ec) && access(candidate.c_str(), X_OK) == 0) return candidate;
    start = end + 1;
  }
  return {};
}

std::string tail_of(const fs::path& log, std::size_t max_chars) {
  std::ifstream in(log, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r' || text.back() == ' ')) text.pop_back();
  if (text.size() > max_chars) text = "..." + text.substr(text.size() - max_chars);
  for (char& c : text) {
    if (c == '\n') c = ' ';
  }
  return text.empty() ? "(no output)" : text;
}

// Runs `tetgen <switches> <input>` with its output in `log`. Returns "" on success, else how it
// ended ("exit status 3", "killed by signal 6"). TetGen reports progress on a buffered stdout and
// aborts on some bad inputs, which would lose the buffer; `stdbuf -oL` (coreutils), when present,
// keeps the log up to the failing stage.
std::string run_tetgen(const fs::path& exe, const std::string& switches, const fs::path& input, const fs::path& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  const fs::path stdbuf = find_program("stdbuf");
  std::vector<std::string> args;
  if (!stdbuf.empty()) args = {"stdbuf", "-oL"};
  args.insert(args.end(), {exe.string(), switches, input.string()});
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const fs::path program = stdbuf.empty() ? exe : stdbuf;
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, program.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) throw GeometryError("cannot run '" + program.string() + "': " + std::strerror(rc));
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw GeometryError("waiting for tetgen failed: " + std::string(std::strerror(errno)));
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status) == 0 ? "" : "exit status " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) return "killed by signal " + std::to_string(WTERMSIG(status));
  return "unknown wait status " + std::to_string(status);
}

TetMesh tetgen_fill(const SurfaceMesh& s, const fs::path& exe, double max_volume, const std::string& source) {
  TempDir dir;
  const fs::path input = dir.path / "surface.smesh";
  try {
    io::write_tetgen_smesh(input, s.vertices, s.triangles);
  } catch (const io::IoError& e) {
    throw GeometryError(std::string("cannot write the tetgen input: ") + e.what());
  }
  std::ostringstream sw;
  // -p: fill the surface (a piecewise linear complex), q1.414: radius-edge ratio bound, a: volume
  // bound. Not -Q: the progress lines in the log say which stage failed.
  sw << "-pq1.414a" << std::setprecision(6) << max_volume;
  const fs::path log = dir.path / "tetgen.log";
  const std::string failure = run_tetgen(exe, sw.str(), input, log);
  if (!failure.empty()) {
    throw GeometryError(source + ": tetgen " + sw.str() + " failed (" + failure +
                        "; a self-intersecting surface is the usual cause). Its output ends: " + tail_of(log, 400));
  }
  try {
    return read_tetgen(dir.path / "surface.1.node");
  } catch (const GeometryError& e) {
    throw GeometryError(source + ": reading tetgen's output: " + e.what() + " (tetgen said: " + tail_of(log, 300) + ")");
  }
}

}  // namespace

double enclosed_volume(const SurfaceMesh& s) {
  if (s.vertices.empty()) return 0.0;
  // About a point near the surface, so large offsets from the origin do not cost precision.
  const Vec3 o = s.vertices[0];
  double six_v = 0.0;
  for (const auto& t : s.triangles) {
    six_v += (s.vertices[t[0]] - o).dot((s.vertices[t[1]] - o).cross(s.vertices[t[2]] - o));
  }
  return six_v / 6.0;
}

void check_closed_surface(SurfaceMesh& s, const std::string& source) {
  const std::size_t nt = s.triangles.size();
  if (nt == 0) throw GeometryError(source + ": the surface has no triangles");
  if (nt > static_cast<std::size_t>(UINT32_MAX / 3)) throw GeometryError(source + ": too many triangles");
  for (std::size_t t = 0; t < nt; ++t) {
    for (std::uint32_t v : s.triangles[t]) {
      if (v >= s.vertices.size()) {
        throw GeometryError(source + ": triangle " + std::to_string(t) + " references vertex " + std::to_string(v) +
                            " but there are " + std::to_string(s.vertices.size()));
      }
    }
  }
  Vec3 lo = s.vertices[0], hi = s.vertices[0];
  for (const Vec3& p : s.vertices) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double diag = (hi - lo).norm();

  // Zero-area triangles: TetGen cannot use them as facets.
  for (std::size_t t = 0; t < nt; ++t) {
    const auto& f = s.triangles[t];
    const double area = 0.5 * (s.vertices[f[1]] - s.vertices[f[0]]).cross(s.vertices[f[2]] - s.vertices[f[0]]).norm();
    if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2] || !(area > 1e-14 * diag * diag)) {
      throw GeometryError(source + ": triangle " + std::to_string(t) + " (vertices " + std::to_string(f[0]) + ", " +
                          std::to_string(f[1]) + ", " + std::to_string(f[2]) + ", counted from 0) has zero area; first vertex " +
                          vertex_at(s, f[0]));
    }
  }

  // Edge uses, sorted so the uses of one undirected edge are adjacent.
  std::vector<EdgeUse> uses;
  uses.reserve(3 * nt);
  for (std::size_t t = 0; t < nt; ++t) {
    for (std::uint8_t k = 0; k < 3; ++k) {
      const std::uint32_t p = s.triangles[t][k], q = s.triangles[t][(k + 1) % 3];
      uses.push_back({std::min(p, q), std::max(p, q), static_cast<std::uint32_t>(t), k, p < q});
    }
  }
  std::sort(uses.begin(), uses.end());
  std::size_t boundary = 0;
  const EdgeUse* first_boundary = nullptr;
  // Across edge k of triangle t: the neighbor, and whether both run the edge the same way.
  std::vector<std::array<std::uint32_t, 3>> across(nt);
  std::vector<std::array<bool, 3>> same_way(nt);
  for (std::size_t i = 0; i < uses.size();) {
    std::size_t j = i + 1;
    while (j < uses.size() && uses[j].a == uses[i].a && uses[j].b == uses[i].b) ++j;
    if (j - i == 1) {
      if (boundary++ == 0) first_boundary = &uses[i];
    } else if (j - i > 2) {
      throw GeometryError(source + ": non-manifold edge between vertices " + vertex_at(s, uses[i].a) + " and " +
                          vertex_at(s, uses[i].b) + ": used by " + std::to_string(j - i) +
                          " triangles (at most 2; vertices counted from 0)");
    } else {
      const EdgeUse& x = uses[i];
      const EdgeUse& y = uses[i + 1];
      across[x.triangle][x.local] = y.triangle;
      across[y.triangle][y.local] = x.triangle;
      same_way[x.triangle][x.local] = same_way[y.triangle][y.local] = x.forward == y.forward;
    }
    i = j;
  }
  if (boundary > 0) {
    throw GeometryError(source + ": surface is not closed: " + std::to_string(boundary) +
                        " boundary edges, e.g. between vertices " + vertex_at(s, first_boundary->a) + " and " +
                        vertex_at(s, first_boundary->b) + " (counted from 0); a solid needs a watertight surface");
  }

  // Pieces and orientation in one walk: a neighbor that runs a shared edge the same way is flipped
  // relative to its predecessor; a contradiction means the surface is not orientable.
  constexpr std::uint32_t kUnseen = UINT32_MAX;
  std::vector<std::uint32_t> piece(nt, kUnseen);
  std::vector<char> flip(nt, 0);
  std::vector<std::uint32_t> stack;
  std::uint32_t pieces = 0;
  for (std::size_t seed = 0; seed < nt; ++seed) {
    if (piece[seed] != kUnseen) continue;
    piece[seed] = pieces;
    stack.assign(1, static_cast<std::uint32_t>(seed));
    while (!stack.empty()) {
      const std::uint32_t t = stack.back();
      stack.pop_back();
      for (std::size_t k = 0; k < 3; ++k) {
        const std::uint32_t u = across[t][k];
        const char want = static_cast<char>(flip[t] ^ (same_way[t][k] ? 1 : 0));
        if (piece[u] == kUnseen) {
          piece[u] = pieces;
          flip[u] = want;
          stack.push_back(u);
        } else if (flip[u] != want) {
          throw GeometryError(source + ": surface is not orientable (like a Klein bottle): triangles " +
                              std::to_string(t) + " and " + std::to_string(u) + " cannot be oriented consistently");
        }
      }
    }
    ++pieces;
  }
  if (pieces > 1) {
    throw GeometryError(source + ": surface has " + std::to_string(pieces) +
                        " disconnected pieces; split them into separate bodies (a hollow solid with an inner "
                        "shell is not supported either)");
  }
  for (std::size_t t = 0; t < nt; ++t) {
    if (flip[t]) std::swap(s.triangles[t][1], s.triangles[t][2]);
  }
  const double volume = enclosed_volume(s);
  if (!(std::abs(volume) > 1e-12 * diag * diag * diag)) {
    throw GeometryError(source + ": the surface encloses no volume");
  }
  if (volume < 0.0) {
    for (auto& t : s.triangles) std::swap(t[1], t[2]);
  }
}

TetMesh mesh_surface(SurfaceMesh surface, const SurfaceResolution& res, const std::string& source) {
  check_closed_surface(surface, source);
  const fs::path exe = find_program("tetgen");
  if (exe.empty()) {
    throw GeometryError(source + ": the surface mesh needs the 'tetgen' program: apt-get install tetgen");
  }
  // TetGen's volume bound caps each tet, and with the quality bound q1.414 the tets come out well
  // below it: measured on spheres, the mean edge is ~0.6 h for the bound h³/(6√2) of a regular tet of
  // edge h, and the count ~5 × volume/bound. So the first bound is scaled by (1/0.6)³, then up to two
  // rescaled runs move toward the target (mean edge h, or the particle count), keeping the closest.
  // The surface's triangles are kept, so the mesh is never coarser than the surface itself.
  constexpr double kFirstGuess = 4.6;
  const double volume = enclosed_volume(surface);
  auto regular_tet = [](double h) { return h * h * h / (6.0 * std::sqrt(2.0)); };
  double h = res.edge_length;
  if (h <= 0.0 && res.particles <= 0) {
    Vec3 lo = surface.vertices[0], hi = surface.vertices[0];
    for (const Vec3& p : surface.vertices) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    h = (hi - lo).maxCoeff() / (res.resolution > 0 ? res.resolution : 20);
  }
  const bool by_count = h <= 0.0;
  double max_volume = by_count ? volume / static_cast<double>(res.particles) : kFirstGuess * regular_tet(h);
  // measured / wanted, as a volume ratio: > 1 means the tets are too small (too many).
  auto ratio_of = [&](const TetMesh& m) {
    if (by_count) return static_cast<double>(m.tets.size()) / static_cast<double>(res.particles);
    const double r = h / mean_edge_length(m);
    return r * r * r;
  };
  TetMesh mesh = tetgen_fill(surface, exe, max_volume, source);
  double last = ratio_of(mesh);
  double best = std::abs(std::log(last));
  const double good_enough = std::log(by_count ? 1.15 : 1.3);  // counts; edge lengths cubed
  for (int attempt = 0; attempt < 2 && best > good_enough; ++attempt) {
    max_volume *= last;
    TetMesh retry = tetgen_fill(surface, exe, max_volume, source);
    const double previous = last;
    last = ratio_of(retry);
    if (std::abs(std::log(last)) < best) {
      best = std::abs(std::log(last));
      mesh = std::move(retry);
    }
    // Barely moved: the surface's own triangles set the size, and another run would not help.
    if (std::abs(std::log(last / previous)) < std::log(1.1)) break;
  }
  return mesh;
}

TetMesh load_surface(const fs::path& file, const SurfaceResolution& resolution) {
  return mesh_surface(read_surface(file), resolution, file.string());
}

}  // namespace perifx::geometry
