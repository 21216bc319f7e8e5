// Load setup: the boundary faces of the reference tet mesh as surface patches of their particles
// (components/loads.hpp), and for each scene load the particles and patches it acts on. Regions are
// tested once, on reference positions: a surface load takes the boundary faces whose centroid lies in
// its region, a body load the particles whose reference position does.
#include <algorithm>

#include "geometry/geometry.hpp"
#include "setup/world_setup.hpp"

namespace perifx::setup {
namespace {

struct Patch {
  std::uint32_t particle;
  double area;
  Vec3 normal, point, centroid;  // point: where the load is evaluated; centroid: the region test
};

// Every boundary face of the reference mesh, as patches in particle order (faces of one particle in
// tet-local face order), so the CSR below is deterministic.
std::vector<Patch> boundary_patches(const WorldState& w, bool fem) {
  const TetMesh& mesh = w.mesh;
  const auto neighbors = geometry::face_neighbors(mesh);
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
        out.push_back({static_cast<std::uint32_t>(t), area, n, centroid, centroid});
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

}  // namespace

void resolve_loads(const std::vector<scene::Load>& loads, WorldState& w) {
  const auto& p = w.particles;
  const std::size_t n = p.count();
  const bool fem = w.settings.solver != scene::Solver::peridynamics;
  auto& s = w.surface;
  s = {};
  auto& set = w.loads;
  set = {};
  set.loads = loads;
  set.particles.resize(loads.size());
  set.patch_offsets.resize(loads.size());
  set.patches.resize(loads.size());
  const bool any_surface = std::any_of(loads.begin(), loads.end(), [](const auto& l) { return surface_load(l.kind); });
  std::vector<Patch> patches;
  if (any_surface) patches = boundary_patches(w, fem);
  s.offsets.assign(any_surface ? n + 1 : 0, 0);
  for (const Patch& q : patches) {
    ++s.offsets[q.particle + 1];
    s.area.push_back(q.area);
    s.normal.push_back(q.normal);
    s.offset.push_back(q.point - p.reference_position[q.particle]);
  }
  for (std::size_t i = 0; any_surface && i < n; ++i) s.offsets[i + 1] += s.offsets[i];

  for (std::size_t l = 0; l < loads.size(); ++l) {
    const scene::Load& load = loads[l];
    auto& list = set.particles[l];
    if (!surface_load(load.kind)) {
      for (std::size_t i = 0; i < n; ++i)
        if (in_region(load.region, p.reference_position[i], p.body_id[i])) list.push_back(static_cast<std::uint32_t>(i));
      continue;
    }
    auto& offsets = set.patch_offsets[l];
    auto& chosen = set.patches[l];
    offsets.push_back(0);
    for (std::size_t q = 0; q < patches.size(); ++q) {
      const std::uint32_t i = patches[q].particle;
      if (!in_region(load.region, patches[q].centroid, p.body_id[i])) continue;
      if (list.empty() || list.back() != i) {
        if (!list.empty()) offsets.push_back(static_cast<std::uint32_t>(chosen.size()));
        list.push_back(i);
      }
      chosen.push_back(static_cast<std::uint32_t>(q));
    }
    if (!list.empty()) offsets.push_back(static_cast<std::uint32_t>(chosen.size()));
  }
}

}  // namespace perifx::setup
