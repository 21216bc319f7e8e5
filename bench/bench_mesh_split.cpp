// Embedded mesh (paper §5.2) per-step costs on the ~3e5-tet box of bench_support.hpp, to compare
// with BM_FullStep at the same size (the mesh systems must not dominate a step):
//   BM_MeshNoCracks   crack_faces + mesh_split when no bond broke (the every-step cost of a fracture
//                     scene between crack events): a parallel scan of the watched face pairs.
//   BM_MeshSplit/N    the step in which N face-pair bonds broke: crack_faces + mesh_split +
//                     mesh_vertices, N = 1e3 (part of one grid plane) and 1e5 (whole z planes, then
//                     x planes): N faces become pending and are opened by splitting in that step.
//   BM_MeshVertices   the per-frame vertex pass (VertexMotion::deformation: F_p of every particle
//                     from its bonds, then every vertex; paid once per output frame).
//   BM_CrackSmoothing/N  the per-frame crack smoothing (crack_smoothing.cpp, the default 3 iterations)
//                     with N face pairs of grid planes cracked and split (as BM_MeshSplit), then the
//                     vertex pass it precedes when the mesh is read: what World::surface adds per frame.
//   BM_MeshRotations/P  the per-step held-rotation system (mesh_rotations.cpp) with P % of the
//                     particles tracked (0: an intact body, only the scan; 100: every particle damaged,
//                     the worst case). Tracked particles are set directly; their families are intact, so
//                     this measures the fitting branch (K, N, K⁻¹), the common one.
// The mesh is restored from a snapshot outside the timed region before each BM_MeshSplit iteration.
#include <algorithm>

#include "systems/bond_rules.hpp"
#include "bench_support.hpp"

namespace perifx::bench {
namespace {

constexpr std::int64_t kParticles = 303918;  // c = 37

// Face pairs of the box's original mesh lying on grid planes, z planes first, then x planes.
std::vector<std::uint32_t> plane_pairs(const WorldState& w, std::size_t count) {
  const auto& e = w.embedded;
  std::vector<std::pair<int, std::uint32_t>> keyed;
  for (std::uint32_t p = 0; p < e.pair_tets.size(); ++p) {
    const auto t = e.pair_tets[p][0];
    const auto k = e.pair_local[p][0];
    Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
    for (int c = 0; c < 4; ++c) {
      if (c == k) continue;
      const Vec3& v = e.reference_vertices[e.tets[t][static_cast<std::size_t>(c)]];
      lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
    }
    const Vec3 span = hi - lo;
    if (span.z() < 1e-12) keyed.push_back({0, p});
    else if (span.x() < 1e-12) keyed.push_back({1, p});
  }
  std::stable_sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::uint32_t> out;
  for (std::size_t q = 0; q < keyed.size() && out.size() < count; ++q) out.push_back(keyed[q].second);
  return out;
}

// Breaks both directions of the bond behind each face pair.
void break_pairs(WorldState& w, const std::vector<std::uint32_t>& pairs) {
  for (std::uint32_t p : pairs) {
    const std::uint32_t k = w.embedded.pair_bond[p];  // bond t→u, owned by t (the pair's first tet)
    w.bonds.alive[k] = w.bonds.alive[systems::mirror_bond(w.bonds, w.embedded.pair_tets[p][0], k)] = 0;
  }
}

void BM_MeshNoCracks(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  World& world = world_for(kParticles, threads);
  WorldState& w = world.state_mutable();
  for (auto _ : state) {
    arena(threads).execute([&] {
      benchmark::DoNotOptimize(systems::collect_crack_faces(w));
      benchmark::DoNotOptimize(systems::split_mesh_vertices(w));
    });
  }
  state.counters["face_pairs"] = static_cast<double>(w.embedded.watched_pairs.size());
  state.counters["tets"] = static_cast<double>(w.embedded.tets.size());
}
BENCHMARK(BM_MeshNoCracks)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

void BM_MeshSplit(benchmark::State& state) {
  const auto faces = static_cast<std::size_t>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  World& world = world_for(kParticles, threads);
  WorldState& w = world.state_mutable();
  const EmbeddedMesh snapshot = w.embedded;
  const std::vector<std::uint8_t> alive = w.bonds.alive;
  const auto pairs = plane_pairs(w, faces);
  std::size_t copies = 0;
  for (auto _ : state) {
    state.PauseTiming();
    w.embedded = snapshot;
    w.bonds.alive = alive;
    break_pairs(w, pairs);
    state.ResumeTiming();
    arena(threads).execute([&] {
      systems::collect_crack_faces(w);
      copies = systems::split_mesh_vertices(w);
      systems::update_mesh_vertices(w, 0.0);
    });
  }
  state.counters["crack_faces"] = static_cast<double>(pairs.size());
  state.counters["vertex_copies"] = static_cast<double>(copies);
  state.counters["still_pending"] = static_cast<double>(w.embedded.pending.size());
  w.embedded = snapshot;
  w.bonds.alive = alive;
}
BENCHMARK(BM_MeshSplit)
    ->ArgNames({"faces", "threads"})
    ->Args({1000, 1})
    ->Args({1000, 2})
    ->Args({100000, 1})
    ->Args({100000, 2})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

void BM_MeshVertices(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  World& world = world_for(kParticles, threads);
  WorldState& w = world.state_mutable();
  for (auto _ : state) arena(threads).execute([&] { systems::update_mesh_vertices(w, 0.0); });
  state.counters["vertices"] = static_cast<double>(w.embedded.vertices.size());
}
BENCHMARK(BM_MeshVertices)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

void BM_CrackSmoothing(benchmark::State& state) {
  const auto faces = static_cast<std::size_t>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  World& world = world_for(kParticles, threads);
  WorldState& w = world.state_mutable();
  const EmbeddedMesh snapshot = w.embedded;
  const std::vector<std::uint8_t> alive = w.bonds.alive;
  break_pairs(w, plane_pairs(w, faces));
  arena(threads).execute([&] {
    systems::collect_crack_faces(w);
    systems::split_mesh_vertices(w);
  });
  std::size_t moved = 0;
  for (auto _ : state)
    arena(threads).execute([&] {
      moved = systems::smooth_crack_faces(w, 3);
      systems::update_mesh_vertices(w, 0.0);
    });
  state.counters["crack_faces"] = static_cast<double>(faces);
  state.counters["vertices_moved"] = static_cast<double>(moved);
  w.embedded = snapshot;
  w.bonds.alive = alive;
}
BENCHMARK(BM_CrackSmoothing)
    ->ArgNames({"faces", "threads"})
    ->Args({1000, 1})
    ->Args({100000, 1})
    ->Args({100000, 2})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

void BM_MeshRotations(benchmark::State& state) {
  const auto percent = static_cast<std::size_t>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  World& world = world_for(kParticles, threads);
  WorldState& w = world.state_mutable();
  const auto tracked = w.embedded.held_tracked;
  const std::size_t n = w.particles.count();
  for (std::size_t p = 0; p < n; ++p) w.embedded.held_tracked[p] = (p * 100 < percent * n) ? 1 : tracked[p];
  for (auto _ : state) arena(threads).execute([&] { systems::update_held_rotations(w); });
  state.counters["tracked"] = static_cast<double>(std::count(w.embedded.held_tracked.begin(), w.embedded.held_tracked.end(), 1));
  w.embedded.held_tracked = tracked;
}
BENCHMARK(BM_MeshRotations)
    ->ArgNames({"percent", "threads"})
    ->Args({0, 1})
    ->Args({0, 2})
    ->Args({10, 1})
    ->Args({100, 1})
    ->Args({100, 2})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace perifx::bench
