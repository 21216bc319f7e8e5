// Load setup: the boundary faces of the reference tet mesh as surface patches of their particles
// (components/loads.hpp; also built for projectiles and colliders, which meet a body at these faces), and for each
// scene load the particles and patches it acts on. Regions are
// tested once, on reference positions: a surface load takes the boundary faces whose centroid lies in
// its region, a body load the particles whose reference position does. A traction with a `depth`
// shares each face's force among the particles under it (spread_in_layer): those shares are patches
// too (area × volume share, the face's normal), listed only by that load.
#include <algorithm>

#include "geometry/geometry.hpp"
#include "setup/world_setup.hpp"
#include "systems/parallel.hpp"
#include "systems/region.hpp"

namespace perifx::setup {
namespace {

struct Patch {
  std::uint32_t particle;
  double area;
  Vec3 normal, point, centroid;  // point: where the load is evaluated; centroid: the region test
  double radius = 0.0;           // whole faces of peridynamic bodies: centroid to farthest corner
  std::array<Vec3, 3> corners{};  // whole faces of peridynamic bodies: the face's corners (else zero)
};

// Every boundary face of the reference mesh, as patches in particle order (faces of one particle in
// tet-local face order), so the CSR below is deterministic.
std::vector<Patch> boundary_patches(const WorldState& w, const std::vector<std::array<std::int32_t, 4>>& neighbors,
                                    bool fem) {
  const TetMesh& mesh = w.mesh;
  std::vector<Patch> out;
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    for (int k = 0; k < 4; ++k) {
      if (neighbors[t][static_cast<std::size_t>(k)] >= 0) continue;
      std::array<Vec3, 3> v;
      std::array<std::uint32_t, 3> ids{};
      std::size_t m = 0;
      for (std::size_t c = 0; c < 4; ++c) {
        if (c == static_cast<std::size_t>(k)) continue;
        ids[m] = mesh.tets[t][c];
        v[m] = mesh.vertices[ids[m]];
        ++m;
      }
      const Vec3 centroid = (v[0] + v[1] + v[2]) / 3.0;
      Vec3 n = (v[1] - v[0]).cross(v[2] - v[0]);
      const double area = 0.5 * n.norm();
      if (!(area > 0.0)) continue;
      n.normalize();
      if (n.dot(mesh.vertices[mesh.tets[t][static_cast<std::size_t>(k)]] - centroid) > 0.0) n = -n;
      if (!fem) {
        const double radius = std::max({(v[0] - centroid).norm(), (v[1] - centroid).norm(), (v[2] - centroid).norm()});
        out.push_back({static_cast<std::uint32_t>(t), area, n, centroid, centroid, radius, v});
        continue;
      }
      // FEM: a third of the face per corner, evaluated at the centroid of that corner's third
      // (the quadrilateral corner, edge midpoints and face centroid).
      for (int c = 0; c < 3; ++c) {
        const Vec3& a = v[static_cast<std::size_t>(c)];
        const Vec3& b = v[static_cast<std::size_t>((c + 1) % 3)];
        const Vec3& d = v[static_cast<std::size_t>((c + 2) % 3)];
        out.push_back({ids[static_cast<std::size_t>(c)], area / 3.0, n, (22.0 * a + 7.0 * b + 7.0 * d) / 36.0, centroid});
      }
    }
  }
  std::stable_sort(out.begin(), out.end(), [](const Patch& a, const Patch& b) { return a.particle < b.particle; });
  return out;
}

bool surface_load(scene::Load::Kind k) {
  using K = scene::Load::Kind;
  return k == K::traction || k == K::blast || k == K::radial_impulse || k == K::directional;
}

// A traction with a depth: each selected face's force is shared, by volume, among the particles of
// its body that lie at most `depth` below its plane and have it as their nearest selected face
// (centroid distance); a face that gets no particle keeps its force on its own particle. The shares
// are appended to `all` as patches of those particles (same normal, area × volume share), so the
// total force is unchanged: T Σ a_f n_f.
void spread_in_layer(const WorldState& w, double depth, const std::vector<std::size_t>& selected,
                     std::vector<Patch>& all, std::vector<std::size_t>& used) {
  const auto& p = w.particles;
  if (selected.empty()) return;
  Vec3 lo = all[selected[0]].centroid, hi = lo;
  for (auto q : selected) lo = lo.cwiseMin(all[q].centroid), hi = hi.cwiseMax(all[q].centroid);
  lo.array() -= depth;
  hi.array() += depth;
  std::vector<std::vector<std::uint32_t>> members(selected.size());
  for (std::size_t i = 0; i < p.count(); ++i) {
    const Vec3& x = p.reference_position[i];
    if (!((x.array() >= lo.array()).all() && (x.array() <= hi.array()).all())) continue;
    std::size_t best = selected.size();
    double best_d2 = kInfinity;
    for (std::size_t k = 0; k < selected.size(); ++k) {
      const Patch& f = all[selected[k]];
      if (p.body_id[f.particle] != p.body_id[i]) continue;
      const double below = (f.centroid - x).dot(f.normal);
      if (below < 0.0 || below > depth) continue;
      const double d2 = (f.centroid - x).squaredNorm();
      if (d2 < best_d2) best_d2 = d2, best = k;
    }
    if (best < selected.size()) members[best].push_back(static_cast<std::uint32_t>(i));
  }
  for (std::size_t k = 0; k < selected.size(); ++k) {
    const Patch f = all[selected[k]];
    if (members[k].empty()) {
      used.push_back(selected[k]);
      continue;
    }
    double volume = 0.0;
    for (auto i : members[k]) volume += p.volume[i];
    for (auto i : members[k]) {
      all.push_back({i, f.area * p.volume[i] / volume, f.normal, f.centroid, f.centroid});
      used.push_back(all.size() - 1);
    }
  }
}

}  // namespace

void resolve_loads(const std::vector<scene::Load>& loads, const std::vector<std::array<std::int32_t, 4>>& face_neighbors,
                   WorldState& w) {
  const auto& p = w.particles;
  const std::size_t n = p.count();
  const bool fem = w.settings.solver != scene::Solver::peridynamics;
  auto& set = w.loads;
  set = {};
  set.loads = loads;
  set.particles.resize(loads.size());
  set.patch_offsets.resize(loads.size());
  set.patches.resize(loads.size());
  // The faces are built for surface loads, and for projectiles and colliders in peridynamic worlds.
  const bool any_surface = std::any_of(loads.begin(), loads.end(), [](const auto& l) { return surface_load(l.kind); }) ||
                           (!fem && (!w.settings.projectiles.empty() || !w.settings.colliders.empty()));
  // The boundary faces, then the layer shares of tractions with a depth; each load's patches.
  std::vector<Patch> all;
  if (any_surface) all = boundary_patches(w, face_neighbors, fem);
  const std::size_t faces = all.size();
  std::vector<std::vector<std::size_t>> used(loads.size());
  for (std::size_t l = 0; l < loads.size(); ++l) {
    const scene::Load& load = loads[l];
    if (!surface_load(load.kind)) {
      for (std::size_t i = 0; i < n; ++i)
        if (systems::region_contains(load.region, p.reference_position[i], p.body_id[i]))
          set.particles[l].push_back(static_cast<std::uint32_t>(i));
      continue;
    }
    std::vector<std::size_t> selected;
    for (std::size_t q = 0; q < faces; ++q)
      if (systems::region_contains(load.region, all[q].centroid, p.body_id[all[q].particle])) selected.push_back(q);
    const double depth = load.kind == scene::Load::Kind::traction ? load.depth : 0.0;
    if (depth > 0.0) spread_in_layer(w, depth, selected, all, used[l]);
    else used[l] = std::move(selected);
  }

  // CSR by particle (stable: a particle's patches keep their order), and each load's lists in it.
  std::vector<std::size_t> order(all.size());
  for (std::size_t q = 0; q < order.size(); ++q) order[q] = q;
  std::stable_sort(order.begin(), order.end(), [&](auto a, auto b) { return all[a].particle < all[b].particle; });
  std::vector<std::uint32_t> index_of(all.size());
  auto& s = w.surface;
  s = {};
  s.offsets.assign(any_surface ? n + 1 : 0, 0);
  for (std::size_t k = 0; k < order.size(); ++k) {
    const Patch& q = all[order[k]];
    index_of[order[k]] = static_cast<std::uint32_t>(k);
    ++s.offsets[q.particle + 1];
    s.area.push_back(q.area);
    s.normal.push_back(q.normal);
    s.offset.push_back(q.point - p.reference_position[q.particle]);
    s.radius.push_back(q.radius);
    const Vec3& x = p.reference_position[q.particle];
    s.corner.push_back(q.radius > 0.0 ? std::array<Vec3, 3>{q.corners[0] - x, q.corners[1] - x, q.corners[2] - x}
                                      : std::array<Vec3, 3>{Vec3::Zero(), Vec3::Zero(), Vec3::Zero()});
  }
  for (std::size_t i = 0; any_surface && i < n; ++i) s.offsets[i + 1] += s.offsets[i];

  for (std::size_t l = 0; l < loads.size(); ++l) {
    if (!surface_load(loads[l].kind)) continue;
    std::vector<std::uint32_t> mine;
    for (auto q : used[l]) mine.push_back(index_of[q]);
    std::sort(mine.begin(), mine.end());  // by particle, since the CSR is
    auto& list = set.particles[l];
    auto& offsets = set.patch_offsets[l];
    offsets.push_back(0);
    for (auto q : mine) {
      const std::uint32_t i = all[order[q]].particle;
      if (list.empty() || list.back() != i) {
        if (!list.empty()) offsets.push_back(static_cast<std::uint32_t>(set.patches[l].size()));
        list.push_back(i);
      }
      set.patches[l].push_back(q);
    }
    if (!list.empty()) offsets.push_back(static_cast<std::uint32_t>(set.patches[l].size()));
  }
}

void resolve_openable_faces(const std::vector<std::array<std::int32_t, 4>>& face_neighbors, WorldState& w) {
  OpenableFaces& of = w.openable_faces;
  of = {};
  const bool peridynamic = w.settings.solver == scene::Solver::peridynamics;
  if (!peridynamic || !w.any_fracture || w.settings.colliders.empty()) return;
  const auto& p = w.particles;
  const auto& b = w.bonds;
  const std::size_t n = p.count();
  of.corner.resize(n);
  of.bond_slot.resize(n);
  parallel_for_each(n, [&](std::size_t t) {
    for (std::size_t c = 0; c < 4; ++c) of.corner[t][c] = (w.mesh.vertices[w.mesh.tets[t][c]] - p.reference_position[t]).cast<float>();
    for (std::size_t k = 0; k < 4; ++k) {
      const std::int32_t u = face_neighbors[t][k];
      std::uint16_t slot = OpenableFaces::kBoundary;
      if (u >= 0) {
        const auto first = b.neighbor.begin() + b.offsets[t], last = b.neighbor.begin() + b.offsets[t + 1];
        const auto at = std::lower_bound(first, last, static_cast<std::uint32_t>(u));  // rows are sorted
        const auto in_row = static_cast<std::size_t>(at - first);
        if (at == last || *at != static_cast<std::uint32_t>(u)) slot = OpenableFaces::kAlwaysOpen;
        else if (in_row < OpenableFaces::kAlwaysOpen) slot = static_cast<std::uint16_t>(in_row);
      }
      of.bond_slot[t][k] = slot;
    }
  }, 4096);
}

}  // namespace perifx::setup
