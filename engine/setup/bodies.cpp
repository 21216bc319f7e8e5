// Bodies and particles: meshes every body of the scene (structured mesher, TetGen, Gmsh or a closed
// surface through the tetgen program), applies its transform, sorts its tets in Morton order and
// places one particle per tet at the barycenter (V = tet volume, m = ρV, paper §5.2), or, for the
// FEM reference solver, one particle per mesh vertex with its lumped volume. Also sizes the per-step
// state arrays.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>

#include <oneapi/tbb/parallel_for.h>

#include "geometry/geometry.hpp"
#include "setup/world_setup.hpp"
#include "systems/bond_rules.hpp"
#include "systems/huge_pages.hpp"
#include "systems/parallel.hpp"

namespace perifx::setup {
namespace {

TetMesh mesh_for(const scene::Body& body) {
  const auto& g = body.geometry;
  auto cell_for = [&](double longest) {
    if (g.edge_length > 0.0) return g.edge_length;
    const int res = g.resolution > 0 ? g.resolution : 20;
    return longest / res;
  };
  switch (g.kind) {
    case scene::Geometry::Kind::box: return geometry::mesh_box(g.size, cell_for(g.size.maxCoeff()), g.mirror);
    case scene::Geometry::Kind::sphere: return geometry::mesh_sphere(g.radius, cell_for(2.0 * g.radius), g.mirror);
    case scene::Geometry::Kind::cylinder:
      return geometry::mesh_cylinder(g.radius, g.height, g.axis, cell_for(std::max(2.0 * g.radius, g.height)),
                                     g.mirror);
    case scene::Geometry::Kind::tetgen: return geometry::read_tetgen(g.path);
    case scene::Geometry::Kind::gmsh: return geometry::read_gmsh(g.path);
    case scene::Geometry::Kind::surface: {
      geometry::SurfaceResolution res;
      res.edge_length = g.edge_length;
      res.particles = g.particles;
      res.resolution = g.resolution > 0 ? g.resolution : 20;
      return geometry::load_surface(g.path, res);
    }
  }
  return {};
}

// A mesh problem as the scene's one-line error: "<scene>: /bodies/<k>/geometry: <problem> (...)".
[[noreturn]] void body_error(const scene::Scene& scene, std::size_t bi, const std::string& problem) {
  throw scene::SceneError(scene.source.string(), "/bodies/" + std::to_string(bi) + "/geometry", problem);
}

}  // namespace

TetMesh placed_mesh(const scene::Scene& scene, std::size_t bi) {
  const scene::Body& body = scene.bodies[bi];
  TetMesh mesh;
  try {
    mesh = mesh_for(body);
  } catch (const geometry::GeometryError& e) {
    body_error(scene, bi, e.what());
  }
  const auto kind = body.geometry.kind;
  if (body.geometry.jitter > 0.0 &&
      (kind == scene::Geometry::Kind::box || kind == scene::Geometry::Kind::sphere ||
       kind == scene::Geometry::Kind::cylinder))
    geometry::jitter_vertices(mesh, body.geometry.jitter, static_cast<std::uint64_t>(body.geometry.seed),
                              body.geometry.mirror);
  parallel_for_each(mesh.vertices.size(), [&](std::size_t v) {
    mesh.vertices[v] = body.transform.rotation * (body.transform.scale * mesh.vertices[v]) + body.transform.translation;
  }, 4096);
  if (mesh.tets.empty()) body_error(scene, bi, "the mesh has no tetrahedra (got 0; expected at least one)");
  // Degenerate placement (scale 1e300, radius 1e-300 ...): every coordinate finite and within
  // kMaxCoordinate, every tet with a positive, normal (not subnormal) volume.
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
    if (!(mesh.vertices[v].cwiseAbs().maxCoeff() <= scene::kMaxCoordinate)) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "(%.3g, %.3g, %.3g)", mesh.vertices[v].x(), mesh.vertices[v].y(), mesh.vertices[v].z());
      body_error(scene, bi, "vertex " + std::to_string(v) + " out of range after the transform (got " + buf +
                                " m; expected finite coordinates within 1e9 m)");
    }
  std::vector<double> volume(mesh.tets.size());
  parallel_for_each(mesh.tets.size(), [&](std::size_t t) { volume[t] = geometry::tet_volume(mesh, t); }, 4096);
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {  // the first bad tet is the one reported
    const double vol = volume[t];
    if (!(vol >= std::numeric_limits<double>::min()) || !std::isfinite(vol)) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.3g", vol);
      body_error(scene, bi, "tetrahedron " + std::to_string(t) + " has no usable volume after the transform (got " + buf +
                                " m^3; expected a positive, representable volume: check size, scale and edge_length)");
    }
  }
  std::vector<Vec3> centers(mesh.tets.size());
  parallel_for_each(mesh.tets.size(), [&](std::size_t t) { centers[t] = geometry::tet_barycenter(mesh, t); }, 4096);
  geometry::reorder_tets(mesh, geometry::morton_order(centers));
  return mesh;
}

void add_bodies(const scene::Scene& scene, WorldState& w) {
  const bool fem = scene.solver != scene::Solver::peridynamics;
  auto& p = w.particles;
  const std::size_t body_count = scene.bodies.size();
  // Each body's mesh depends on its own spec only, so the bodies are meshed side by side (and each
  // mesher's loops run in parallel inside). A failure is reported for the lowest failing body, as a
  // serial loop would.
  std::vector<TetMesh> meshes(body_count);
  std::vector<double> mean_edge(body_count, 0.0);
  std::vector<std::exception_ptr> failure(body_count);
  tbb::parallel_for(std::size_t{0}, body_count, [&](std::size_t bi) {
    try {
      meshes[bi] = placed_mesh(scene, bi);
      mean_edge[bi] = geometry::mean_edge_length(meshes[bi]);
    } catch (...) {
      failure[bi] = std::current_exception();
    }
  });
  for (const auto& f : failure)
    if (f) std::rethrow_exception(f);

  // Where each body's particles, vertices and tets go in the world's arrays.
  std::vector<std::size_t> first_particle(body_count + 1, 0), first_tet(body_count + 1, 0);
  std::size_t vertex_total = 0;
  for (std::size_t bi = 0; bi < body_count; ++bi) {
    const TetMesh& mesh = meshes[bi];
    first_particle[bi + 1] = first_particle[bi] + (fem ? mesh.vertices.size() : mesh.tets.size());
    first_tet[bi + 1] = first_tet[bi] + mesh.tets.size();
    vertex_total += mesh.vertices.size();
  }
  const std::size_t n = first_particle[body_count];
  p.reference_position.resize(n);
  p.volume.resize(n);
  p.mass.resize(n);
  p.material_id.resize(n);
  p.body_id.resize(n);
  p.velocity.resize(n);
  w.model.horizon.resize(n);
  w.mesh.tets.resize(first_tet[body_count]);
  w.mesh.vertices.reserve(vertex_total);

  for (std::size_t bi = 0; bi < body_count; ++bi) {
    const scene::Body& body = scene.bodies[bi];
    const TetMesh& mesh = meshes[bi];
    BodyInfo info;
    info.name = body.name;
    info.first_particle = static_cast<std::uint32_t>(first_particle[bi]);
    info.particle_count = static_cast<std::uint32_t>(first_particle[bi + 1] - first_particle[bi]);
    info.first_vertex = static_cast<std::uint32_t>(w.mesh.vertices.size());
    info.vertex_count = static_cast<std::uint32_t>(mesh.vertices.size());
    info.mean_edge_length = mean_edge[bi];
    info.horizon = body.horizon_length > 0.0 ? body.horizon_length : body.horizon_factor * info.mean_edge_length;

    const auto& mat = scene.materials[static_cast<std::size_t>(body.material)];
    const std::size_t first = first_particle[bi];
    auto set_particle = [&](std::size_t i, const Vec3& x, double vol) {
      p.reference_position[i] = x;
      p.volume[i] = vol;
      p.mass[i] = mat.density * vol;
      p.material_id[i] = static_cast<std::uint16_t>(body.material);
      p.body_id[i] = static_cast<std::uint16_t>(bi);
      w.model.horizon[i] = info.horizon;
    };
    parallel_for_each(mesh.tets.size(), [&](std::size_t t) {
      auto tet = mesh.tets[t];
      for (auto& v : tet) v += info.first_vertex;
      w.mesh.tets[first_tet[bi] + t] = tet;
      if (!fem) set_particle(first + t, geometry::tet_barycenter(mesh, t), geometry::tet_volume(mesh, t));
    }, 4096);
    w.mesh.vertices.insert(w.mesh.vertices.end(), mesh.vertices.begin(), mesh.vertices.end());
    if (fem) {
      std::vector<double> vertex_volume(mesh.vertices.size(), 0.0);  // lumped: Σ V_t/4, in tet order
      for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
        const double vol = geometry::tet_volume(mesh, t);
        for (auto v : mesh.tets[t]) vertex_volume[v] += 0.25 * vol;
      }
      for (std::size_t v = 0; v < vertex_volume.size(); ++v) {
        if (!(vertex_volume[v] > 0.0))
          throw geometry::GeometryError("body '" + body.name + "': vertex " + std::to_string(v) +
                                        " belongs to no tetrahedron; the FEM solver cannot give it a mass");
        set_particle(first + v, mesh.vertices[v], vertex_volume[v]);
      }
    }
    // Initial rigid velocity about the body's center of mass (summed in particle order).
    Vec3 com = Vec3::Zero();
    double total = 0.0;
    const std::size_t last = first_particle[bi + 1];
    for (std::size_t i = first; i < last; ++i) {
      com += p.mass[i] * p.reference_position[i];
      total += p.mass[i];
    }
    com /= total;
    parallel_for_each(last - first, [&](std::size_t k) {
      p.velocity[first + k] = body.velocity + body.angular_velocity.cross(p.reference_position[first + k] - com);
    }, 4096);
    w.bodies.push_back(info);
  }
  meshes = {};
  p.position = p.reference_position;
}

void allocate_step_state(WorldState& w) {
  const std::size_t n = w.particles.count();
  auto& p = w.particles;
  // In memory advised for huge pages and cleared by all threads (systems/huge_pages.hpp): the bond
  // passes gather from these, and allocating them on one thread, then moving them, took 0.65 s at 9e5.
  using systems::assign_huge_pages;
  assign_huge_pages(p.acceleration, n, Vec3(Vec3::Zero()));
  assign_huge_pages(p.flags, n, std::uint8_t{0});
  auto& s = w.state;
  assign_huge_pages(s.dilatation, n, 0.0);
  assign_huge_pages(s.dilatation_coupling, n, 0.0);
  assign_huge_pages(s.internal_force, n, Vec3(Vec3::Zero()));
  assign_huge_pages(s.external_force, n, Vec3(Vec3::Zero()));
  assign_huge_pages(s.damage, n, 0.0);
  assign_huge_pages(s.break_extension, n, kInfinity);
  assign_huge_pages(s.bond_end, n, BondEnd{});
  // Which collider held each particle this step (colliders.cpp, kick_end): peridynamic and FEM worlds alike.
  if (!w.settings.colliders.empty()) assign_huge_pages(s.collider_contact, n, ColliderContact{});
  assign_huge_pages(s.contact_force, n, Vec3(Vec3::Zero()));
  assign_huge_pages(s.broken_bonds, n, std::uint32_t{0});
  // GᵀG per particle, before anything measures a bond's weighted length (families, embedded mesh).
  w.model.anisotropy_metric.clear();
  if (w.any_anisotropic) {
    w.model.anisotropy_metric.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      w.model.anisotropy_metric[i] = systems::anisotropy_metric(w.settings.materials[p.material_id[i]].anisotropy);
  }
}

}  // namespace perifx::setup
