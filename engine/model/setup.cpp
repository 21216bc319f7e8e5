#include "model/setup.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <numeric>

#include "geometry/geometry.hpp"
#include "systems/parallel.hpp"
#include "systems/systems.hpp"

namespace perifx::model {
namespace {

TetMesh mesh_for(const scene::Body& body) {
  const auto& g = body.geometry;
  auto cell_for = [&](double longest) {
    if (g.edge_length > 0.0) return g.edge_length;
    const int res = g.resolution > 0 ? g.resolution : 20;
    return longest / res;
  };
  switch (g.kind) {
    case scene::Geometry::Kind::box: return geometry::mesh_box(g.size, cell_for(g.size.maxCoeff()));
    case scene::Geometry::Kind::sphere: return geometry::mesh_sphere(g.radius, cell_for(2.0 * g.radius));
    case scene::Geometry::Kind::cylinder:
      return geometry::mesh_cylinder(g.radius, g.height, g.axis, cell_for(std::max(2.0 * g.radius, g.height)));
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

bool in_region(const scene::Region& region, const Vec3& x, int body) {
  if (region.body >= 0 && region.body != body) return false;
  switch (region.kind) {
    case scene::Region::Kind::all: return true;
    case scene::Region::Kind::box:
      return (x.array() >= region.min.array()).all() && (x.array() <= region.max.array()).all();
    case scene::Region::Kind::sphere: return (x - region.center).squaredNorm() <= region.radius * region.radius;
    case scene::Region::Kind::halfspace: return (x - region.point).dot(region.normal) >= 0.0;
  }
  return false;
}

void allocate_state(WorldState& w) {
  const std::size_t n = w.particles.count();
  auto& p = w.particles;
  p.acceleration.assign(n, Vec3::Zero());
  p.flags.assign(n, 0);
  auto& s = w.state;
  s.dilatation.assign(n, 0.0);
  s.dilatation_coupling.assign(n, 0.0);
  s.internal_force.assign(n, Vec3::Zero());
  s.external_force.assign(n, Vec3::Zero());
  s.damage.assign(n, 0.0);
  s.break_extension.assign(n, kInfinity);
  s.bond_end.assign(n, BondEnd{});
  s.contact_force.assign(n, Vec3::Zero());
  s.broken_bonds.assign(n, 0);
}

}  // namespace

std::unique_ptr<WorldState> build_world_state(const scene::Scene& scene, Scheduler& scheduler) {
  auto world = std::make_unique<WorldState>();
  WorldState& w = *world;
  w.scene = scene;
  w.clock.dt = scene.time.dt;
  for (const auto& m : scene.materials) {
    w.any_plastic = w.any_plastic || std::isfinite(m.yield_energy);
    w.any_anisotropic = w.any_anisotropic || m.anisotropy != Mat3::Identity();
    w.any_fracture = w.any_fracture || std::isfinite(m.critical_stretch);
  }

  // FEM mode (components/fem.hpp): the particles are the mesh vertices; elastic materials only.
  const bool fem = scene.solver != scene::Solver::peridynamics;
  if (fem && (w.any_plastic || w.any_fracture))
    throw std::invalid_argument("model/solver: the FEM reference solver is elastic only; this scene has a material "
                                "with a finite yield_energy or critical_stretch (use solver 'peridynamics')");
  if (fem && !scene.cracks.empty())
    throw std::invalid_argument("model/solver: initial cracks need solver 'peridynamics'");

  auto& p = w.particles;
  for (std::size_t bi = 0; bi < scene.bodies.size(); ++bi) {
    const scene::Body& body = scene.bodies[bi];
    TetMesh mesh = mesh_for(body);
    for (Vec3& v : mesh.vertices) v = body.transform.rotation * (body.transform.scale * v) + body.transform.translation;
    if (mesh.tets.empty()) throw geometry::GeometryError("body '" + body.name + "': its mesh has no tetrahedra");
    std::vector<Vec3> centers(mesh.tets.size());
    for (std::size_t t = 0; t < mesh.tets.size(); ++t) centers[t] = geometry::tet_barycenter(mesh, t);
    geometry::reorder_tets(mesh, geometry::morton_order(centers));

    BodyInfo info;
    info.name = body.name;
    info.first_particle = static_cast<std::uint32_t>(p.reference_position.size());
    info.particle_count = static_cast<std::uint32_t>(fem ? mesh.vertices.size() : mesh.tets.size());
    info.first_vertex = static_cast<std::uint32_t>(w.mesh.vertices.size());
    info.vertex_count = static_cast<std::uint32_t>(mesh.vertices.size());
    info.mean_edge_length = geometry::mean_edge_length(mesh);
    info.horizon = body.horizon_length > 0.0 ? body.horizon_length : body.horizon_factor * info.mean_edge_length;

    const auto& mat = scene.materials[static_cast<std::size_t>(body.material)];
    const std::size_t first = p.reference_position.size();
    std::vector<double> vertex_volume(fem ? mesh.vertices.size() : 0, 0.0);  // lumped: Σ V_t/4
    for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
      const double vol = geometry::tet_volume(mesh, t);
      if (fem) {
        for (auto v : mesh.tets[t]) vertex_volume[v] += 0.25 * vol;
      } else {
        const Vec3 c = geometry::tet_barycenter(mesh, t);
        p.reference_position.push_back(c);
        p.volume.push_back(vol);
        p.mass.push_back(mat.density * vol);
        p.material_id.push_back(static_cast<std::uint16_t>(body.material));
        p.body_id.push_back(static_cast<std::uint16_t>(bi));
        w.model.horizon.push_back(info.horizon);
      }
      auto tet = mesh.tets[t];
      for (auto& v : tet) v += info.first_vertex;
      w.mesh.tets.push_back(tet);
    }
    w.mesh.vertices.insert(w.mesh.vertices.end(), mesh.vertices.begin(), mesh.vertices.end());
    for (std::size_t v = 0; v < vertex_volume.size(); ++v) {
      if (!(vertex_volume[v] > 0.0))
        throw geometry::GeometryError("body '" + body.name + "': vertex " + std::to_string(v) +
                                      " belongs to no tetrahedron; the FEM solver cannot give it a mass");
      p.reference_position.push_back(mesh.vertices[v]);
      p.volume.push_back(vertex_volume[v]);
      p.mass.push_back(mat.density * vertex_volume[v]);
      p.material_id.push_back(static_cast<std::uint16_t>(body.material));
      p.body_id.push_back(static_cast<std::uint16_t>(bi));
      w.model.horizon.push_back(info.horizon);
    }
    // Initial rigid velocity about the body's center of mass.
    Vec3 com = Vec3::Zero();
    double total = 0.0;
    const std::size_t last = p.reference_position.size();
    for (std::size_t i = first; i < last; ++i) {
      com += p.mass[i] * p.reference_position[i];
      total += p.mass[i];
    }
    com /= total;
    for (std::size_t i = first; i < last; ++i)
      p.velocity.push_back(body.velocity + body.angular_velocity.cross(p.reference_position[i] - com));
    w.bodies.push_back(info);
  }
  p.position = p.reference_position;
  allocate_state(w);

  // Boundary condition regions, resolved once on reference positions.
  w.boundary.conditions = scene.boundary_conditions;
  w.boundary.particles.resize(scene.boundary_conditions.size());
  for (std::size_t c = 0; c < scene.boundary_conditions.size(); ++c) {
    for (std::size_t i = 0; i < p.count(); ++i)
      if (in_region(scene.boundary_conditions[c].region, p.reference_position[i], p.body_id[i]))
        w.boundary.particles[c].push_back(static_cast<std::uint32_t>(i));
    w.boundary.constrained.insert(w.boundary.constrained.end(), w.boundary.particles[c].begin(),
                                  w.boundary.particles[c].end());
  }
  std::sort(w.boundary.constrained.begin(), w.boundary.constrained.end());
  w.boundary.constrained.erase(std::unique(w.boundary.constrained.begin(), w.boundary.constrained.end()),
                               w.boundary.constrained.end());

  if (fem) {
    // No bonds: an empty CSR so bond-walking code (output fields, fragments) sees empty families.
    w.bonds.offsets.assign(p.count() + 1, 0);
    w.bonds.initial_count.assign(p.count(), 0);
    scheduler.execute([&] {
      systems::setup_fem(w);
      systems::compute_model_constants(w);  // the damping rate; the rest is unused without bonds
      systems::compute_fem_force(w, p.position, w.fem.corner_force, w.state.internal_force);
      parallel_for_each(p.count(), [&](std::size_t i) {
        w.state.external_force[i] = p.mass[i] * scene.gravity;
        p.acceleration[i] = (w.state.internal_force[i] + w.state.external_force[i]) / p.mass[i];
      });
    });
    systems::setup_contact(w);
    w.contact.enabled = false;  // particle contact assumes unbonded particles; FEM vertices are not
    systems::setup_projectiles(w);
    return world;
  }
  scheduler.execute([&] {
    const auto adjacency = geometry::face_neighbors(w.mesh);
    systems::build_families(w, adjacency);
    systems::remove_cracked_bonds(w, scene.cracks);
    systems::setup_embedded_mesh(w, adjacency);  // after the bonds: a face pair without one starts cracked
    systems::compute_model_constants(w);
    systems::compute_fracture_thresholds(w);
    // Initial acceleration for the first kick of velocity Verlet.
    systems::compute_dilatation(w, p.position, w.state.dilatation, w.state.dilatation_coupling);
    systems::compute_internal_force(w, p.position, w.state.dilatation_coupling, w.state.internal_force);
    parallel_for_each(p.count(), [&](std::size_t i) {
      w.state.external_force[i] = p.mass[i] * scene.gravity;
      p.acceleration[i] = (w.state.internal_force[i] + w.state.external_force[i]) / p.mass[i];
    });
  });
  systems::setup_contact(w);
  systems::setup_projectiles(w);
  return world;
}

void add_step_systems(WorldState& w, Scheduler& scheduler) {
  scheduler.add(systems::kick_begin_system(w));
  scheduler.add(systems::boundary_condition_system(w));
  scheduler.add(systems::drift_system(w));
  if (!w.projectiles.bodies.empty()) scheduler.add(systems::projectile_drift_system(w));
  scheduler.add(systems::collider_system(w));
  // Contact reads the bonds as they were at the start of the step (before this step's breaks).
  if (w.contact.enabled) scheduler.add(systems::contact_system(w));
  if (w.scene.solver != scene::Solver::peridynamics) {
    scheduler.add(systems::fem_force_system(w));
  } else {
    scheduler.add(systems::dilatation_system(w));
    scheduler.add(systems::bond_pass_system(w));  // plasticity, force, fracture, damage in one pass
  }
  scheduler.add(systems::external_load_system(w));
  if (!w.projectiles.bodies.empty()) scheduler.add(systems::projectile_contact_system(w));
  scheduler.add(systems::kick_end_system(w));
  if (w.any_fracture) scheduler.add(systems::fracture_threshold_system(w));
  // Embedded mesh (§5.2): crack faces and vertex splitting when bonds can break; vertex motion when
  // anything uses the mesh surface (fracture, or surface/tet output requested).
  if (w.scene.solver == scene::Solver::peridynamics) {
    if (w.any_fracture) scheduler.add(systems::crack_face_system(w));
    if (w.any_fracture) scheduler.add(systems::mesh_split_system(w));
    const auto& out = w.scene.output;
    if (w.any_fracture || out.obj || out.surface_ply || out.tets_vtu) scheduler.add(systems::mesh_vertex_system(w));
  }
}

double estimate_stable_time_step(const WorldState& w) {
  const std::size_t n = w.particles.count();
  const bool fem = w.scene.solver != scene::Solver::peridynamics;
  if (n == 0 || (!fem && w.bonds.count() == 0)) return kInfinity;
  const auto& x = w.particles.reference_position;
  const auto& mass = w.particles.mass;
  double min_spacing = kInfinity;
  for (double r : w.bonds.reference_length) min_spacing = std::min(min_spacing, r);
  if (fem)
    for (const auto& t : w.mesh.tets)
      for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b) min_spacing = std::min(min_spacing, (x[t[a]] - x[t[b]]).norm());
  std::vector<Vec3> corner_scratch;

  // Lanczos on A = M^-1/2 K M^-1/2 (symmetric, same eigenvalues as M⁻¹K). K u is probed as the force
  // change at a displacement small enough to stay linear. The largest Ritz value converges to
  // ω_max² from below in a few tens of iterations, far faster than power iteration.
  std::vector<Vec3> y(n), force(n);
  std::vector<double> theta(n), coupling(n);
  auto apply = [&](const std::vector<Vec3>& q, std::vector<Vec3>& out) {
    const double rms = std::sqrt(deterministic_sum(n, 0.0, [&](std::size_t i) { return q[i].squaredNorm() / mass[i]; }) / double(n));
    const double eps = 1e-7 * min_spacing / std::max(rms, 1e-300);
    parallel_for_each(n, [&](std::size_t i) { y[i] = x[i] + (eps / std::sqrt(mass[i])) * q[i]; });
    if (fem) {
      systems::compute_fem_force(w, y, corner_scratch, force);
    } else {
      systems::compute_dilatation(w, y, theta, coupling);
      systems::compute_internal_force(w, y, coupling, force);
    }
    parallel_for_each(n, [&](std::size_t i) { out[i] = -force[i] / (eps * std::sqrt(mass[i])); });
  };
  auto dot = [&](const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
    return deterministic_sum(n, 0.0, [&](std::size_t i) { return a[i].dot(b[i]); });
  };
  // Deterministic pseudo-random start vector: rich in the high-frequency modes we look for.
  std::vector<Vec3> q(n), q_prev(n, Vec3::Zero()), r(n);
  std::uint64_t seed = 0x9E3779B97F4A7C15ull;
  auto next = [&] {
    seed ^= seed << 13, seed ^= seed >> 7, seed ^= seed << 17;
    return static_cast<double>(seed >> 11) * 0x1.0p-53 - 0.5;
  };
  for (auto& qi : q) qi = Vec3(next(), next(), next());
  const double norm0 = std::sqrt(dot(q, q));
  for (auto& qi : q) qi /= norm0;
  std::vector<double> alpha, beta;
  double lambda = 0.0;
  for (int iter = 0; iter < 40; ++iter) {
    apply(q, r);
    const double a = dot(r, q);
    const double b_prev = beta.empty() ? 0.0 : beta.back();
    parallel_for_each(n, [&](std::size_t i) { r[i] -= a * q[i] + b_prev * q_prev[i]; });
    alpha.push_back(a);
    const double b = std::sqrt(dot(r, r));
    // Largest eigenvalue of the tridiagonal Lanczos matrix.
    const int k = static_cast<int>(alpha.size());
    Eigen::MatrixXd t = Eigen::MatrixXd::Zero(k, k);
    for (int d = 0; d < k; ++d) t(d, d) = alpha[static_cast<std::size_t>(d)];
    for (int d = 0; d + 1 < k; ++d) t(d, d + 1) = t(d + 1, d) = beta[static_cast<std::size_t>(d)];
    const double next_lambda = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(t, Eigen::EigenvaluesOnly).eigenvalues().maxCoeff();
    const bool converged = iter >= 8 && std::abs(next_lambda - lambda) <= 1e-4 * next_lambda;
    lambda = next_lambda;
    if (converged || !(b > 1e-12 * std::abs(a))) break;
    beta.push_back(b);
    std::swap(q_prev, q);
    parallel_for_each(n, [&](std::size_t i) { q[i] = r[i] / b; });
  }
  return lambda > 0.0 ? 2.0 / std::sqrt(lambda) : kInfinity;
}

double elastic_energy(const WorldState& w) {
  if (w.scene.solver != scene::Solver::peridynamics) return systems::fem_elastic_energy(w, w.particles.position);
  const auto& b = w.bonds;
  const auto& p = w.particles;
  const auto& md = w.model;
  return deterministic_sum(p.count(), 0.0, [&](std::size_t i) {
    if (md.dilatation_scale[i] == 0.0) return 0.0;
    const double a = 0.25 * md.a4[i], bb = 0.25 * md.b4[i];
    const double k = (a - bb * md.beta[i]) / md.dilatation_scale[i];
    double bond_sum = 0.0;
    for (std::uint32_t q = b.offsets[i]; q < b.offsets[i + 1]; ++q) {
      if (!b.alive[q]) continue;
      const std::uint32_t j = b.neighbor[q];
      const double e = (p.position[j] - p.position[i]).norm() - b.reference_length[q] - b.plastic_extension[q];
      bond_sum += b.weight[q] * e * e * p.volume[j];
    }
    const double th = w.state.dilatation[i];
    return p.volume[i] * (k * th * th + bb * bond_sum);
  });
}

}  // namespace perifx::model
