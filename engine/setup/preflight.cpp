#include "setup/preflight.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#if defined(__linux__)
#include <unistd.h>
#endif

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <oneapi/tbb/info.h>

#include "geometry/geometry.hpp"
#include "setup/world_setup.hpp"

namespace perifx::setup {
namespace {

double mem_available() {
  std::ifstream in("/proc/meminfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("MemAvailable:", 0) != 0) continue;
    std::istringstream fields(line.substr(13));
    double kib = -1.0;
    fields >> kib;
    return kib >= 0.0 ? kib * 1024.0 : -1.0;
  }
  return -1.0;
}

// Tets the structured mesher makes for a primitive (6 per cube cell, curved shapes filling their
// share of the bounding box), from the cell size alone; 0 for meshes read from files.
double primitive_tets(const scene::Body& body) {
  const auto& g = body.geometry;
  auto cells = [&](const Vec3& size, double longest) {
    const double cell = g.edge_length > 0.0 ? g.edge_length : longest / (g.resolution > 0 ? g.resolution : 20);
    return std::ceil(size.x() / cell) * std::ceil(size.y() / cell) * std::ceil(size.z() / cell);
  };
  switch (g.kind) {
    case scene::Geometry::Kind::box: return 6.0 * cells(g.size, g.size.maxCoeff());
    case scene::Geometry::Kind::sphere: return kPi * cells(Vec3::Constant(2 * g.radius), 2 * g.radius);
    case scene::Geometry::Kind::cylinder: {
      const double d = 2 * g.radius, longest = std::max(d, g.height);
      return 6.0 * kPi / 4.0 * cells(Vec3(d, d, g.height), longest);
    }
    default: return 0.0;
  }
}

}  // namespace

double bytes_per_bond(const scene::Scene& scene) {
  bool plastic = false, planes = false;
  for (const auto& m : scene.materials) {
    plastic = plastic || can_yield(m);
    planes = planes || !m.strength.weak_planes.empty();
  }
  return kBytesPerBondState + (plastic ? kBytesPerBondPlastic : 0.0) + (planes ? kBytesPerBondScale : 0.0) +
         (scene.contact.mode != scene::Contact::Mode::off ? kBytesPerBondContact : 0.0);  // an upper bound
}

double bytes_per_particle(const scene::Scene& scene) {
  return kBytesPerParticle + (scene.contact.mode != scene::Contact::Mode::off ? kBytesPerParticleContact : 0.0);
}

namespace {

double per_particle_bytes(const scene::Scene& scene, double bonds_per_particle) {
  return bonds_per_particle * bytes_per_bond(scene) + bytes_per_particle(scene) + kBytesPerTet;
}

[[noreturn]] void refuse(const scene::Scene& scene, const MemoryEstimate& e, const std::string& how) {
  char ranks[160] = "";
  if (e.ranks > 1)
    std::snprintf(ranks, sizeof ranks, " on this machine, for %d of the job's %d ranks (one process: %s)", e.local_ranks,
                  e.ranks, format_bytes(e.world_bytes).c_str());
  char buf[560];
  std::snprintf(buf, sizeof buf,
                "not enough memory: %s (got an estimated peak of %s%s for %.3g particles and %.3g bonds; expected at "
                "most the %s available; use coarser meshes, %sor perifx run --force)",
                how.c_str(), format_bytes(e.bytes).c_str(), ranks, double(e.particles), e.bonds,
                format_bytes(e.available).c_str(), e.local_ranks > 1 ? "fewer ranks per machine, " : "");
  throw MemoryError(scene.source.string() + ": /bodies: " + buf);
}

}  // namespace

std::string format_bytes(double b) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  int u = 0;
  while (b >= 1024.0 && u < 6) b /= 1024.0, ++u;
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.3g %s", b, units[u]);
  return buf;
}

void release_freed_memory_promptly() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 1 << 20);  // also stops the dynamic trim threshold
#endif
}

void restart_with_huge_page_malloc(char** argv) {
#if defined(__GLIBC__) && defined(__linux__)
  // The restarted process: the marker holds GLIBC_TUNABLES as the caller had it ("=value", or empty
  // when it was unset). glibc has read the tunable already; the environment goes back as it was.
  constexpr const char* kMarker = "PERIFX_GLIBC_TUNABLES_BEFORE";
  if (const char* before = std::getenv(kMarker)) {
    if (before[0] == '=') ::setenv("GLIBC_TUNABLES", before + 1, 1);
    else ::unsetenv("GLIBC_TUNABLES");
    ::unsetenv(kMarker);
    return;
  }
  if (const char* opt = std::getenv("PERIFX_HUGE_PAGE_MALLOC"); opt && std::strcmp(opt, "0") == 0) return;
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  if (tunables && std::strstr(tunables, "glibc.malloc.hugetlb")) return;
  {  // "always [madvise] never": huge pages only for memory that asks, which the tunable makes malloc do
    std::ifstream mode("/sys/kernel/mm/transparent_hugepage/enabled");
    std::string line;
    if (!std::getline(mode, line) || line.find("[madvise]") == std::string::npos) return;
  }
  const std::string before = tunables ? "=" + std::string(tunables) : std::string();
  const std::string now = (tunables && *tunables ? std::string(tunables) + ":" : std::string()) + "glibc.malloc.hugetlb=1";
  ::setenv(kMarker, before.c_str(), 1);
  ::setenv("GLIBC_TUNABLES", now.c_str(), 1);
  ::execv("/proc/self/exe", argv);
  // Not restarted (no /proc, exec refused): go on with the allocator as it is.
  if (tunables) ::setenv("GLIBC_TUNABLES", tunables, 1);
  else ::unsetenv("GLIBC_TUNABLES");
  ::unsetenv(kMarker);
#else
  (void)argv;
#endif
}

ResidentMemory resident_memory() {
  ResidentMemory r;
  std::ifstream in("/proc/self/smaps_rollup");
  std::string line;
  auto field = [&](const char* name, double& out) {
    const std::size_t length = std::strlen(name);
    if (line.compare(0, length, name) != 0) return;
    std::istringstream fields(line.substr(length));
    double kib = -1.0;
    if (fields >> kib) out = kib * 1024.0;
  };
  while (std::getline(in, line)) {
    field("Rss:", r.total);
    field("AnonHugePages:", r.huge_pages);
  }
  return r;
}

double machine_bytes(double world_bytes, const RankPlacement& p) {
  if (p.ranks <= 1) return world_bytes;
  const double part = kPartPeakFactor * world_bytes / p.ranks;
  const int others = p.local_ranks - (p.holds_rank0 ? 1 : 0);
  return (p.holds_rank0 ? world_bytes + part : 0.0) + others * part;
}

int setup_threads(int threads, int rank, const RankPlacement& p) {
  if (rank != 0 || threads <= 0 || p.local_ranks <= 1) return threads;
  return std::max(threads, std::min(threads * p.local_ranks, tbb::info::default_concurrency()));
}

MemoryEstimate preflight(const scene::Scene& scene, bool enforce, const RankPlacement& placement) {
  MemoryEstimate e;
  e.ranks = placement.ranks;
  e.local_ranks = placement.local_ranks;
  e.available = mem_available();
  const bool limit = enforce && e.available > 0.0;
  // 1. Primitives, from their cell counts: a resolution-300 box is refused before meshing. Bonds per
  //    particle are at least the ~40 a horizon of 1.45 λ holds in a structured mesh.
  double tets = 0.0;
  for (const auto& body : scene.bodies) tets += primitive_tets(body);
  const double early = kPeakFactor * tets * per_particle_bytes(scene, 40.0);
  if (limit && machine_bytes(early, placement) > e.available) {
    e.particles = static_cast<std::size_t>(std::min(tets, 1e18));
    e.bonds = 40.0 * tets;
    e.world_bytes = early;
    e.bytes = machine_bytes(early, placement);
    refuse(scene, e, "the primitives' meshes alone are too fine");
  }
  // 2. Every body's mesh as setup builds it; bonds from the horizon sphere's volume over the mean
  //    particle volume (capped by the body's particle count).
  const bool fem = scene.solver != scene::Solver::peridynamics;
  for (std::size_t bi = 0; bi < scene.bodies.size(); ++bi) {
    const TetMesh mesh = placed_mesh(scene, bi);
    const scene::Body& body = scene.bodies[bi];
    const double n = double(fem ? mesh.vertices.size() : mesh.tets.size());
    double volume = 0.0;
    for (std::size_t t = 0; t < mesh.tets.size(); ++t) volume += geometry::tet_volume(mesh, t);
    const double lambda = geometry::mean_edge_length(mesh);
    const double horizon = body.horizon_length > 0.0 ? body.horizon_length : body.horizon_factor * lambda;
    const double per = fem ? 0.0 : std::min(n - 1.0, 4.0 / 3.0 * kPi * std::pow(horizon, 3) / (volume / n));
    e.particles += static_cast<std::size_t>(n);
    e.bonds += n * per;
    e.world_bytes += kPeakFactor * (n * (bytes_per_particle(scene) + per * bytes_per_bond(scene)) + double(mesh.tets.size()) * kBytesPerTet);
  }
  e.bytes = machine_bytes(e.world_bytes, placement);
  e.meshed = true;
  if (limit && e.bytes > e.available) refuse(scene, e, "the meshes are too fine");
  return e;
}

}  // namespace perifx::setup
