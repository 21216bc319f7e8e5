#include "setup/world_setup.hpp"

#include "geometry/geometry.hpp"
#include "systems/parallel.hpp"
#include "systems/systems.hpp"

namespace perifx::setup {
namespace {

// What the step reads from the scene, copied once (systems never see the scene itself).
void resolve_settings(const scene::Scene& scene, StepSettings& s) {
  s.gravity = scene.gravity;
  s.normalization = scene.normalization;
  s.family = scene.family;
  s.solver = scene.solver;
  s.materials = scene.materials;
  s.colliders = scene.colliders;
  s.contact = scene.contact;
  s.projectiles = scene.projectiles;
  s.threads = scene.threads;
  s.mesh_output = scene.output.obj || scene.output.surface_ply || scene.output.tets_vtu;
}

}  // namespace

std::unique_ptr<WorldState> build_world_state(const scene::Scene& scene, Scheduler& scheduler) {
  auto world = std::make_unique<WorldState>();
  WorldState& w = *world;
  w.clock.dt = scene.time.dt;
  resolve_settings(scene, w.settings);
  for (const auto& m : scene.materials) {
    w.any_plastic = w.any_plastic || std::isfinite(m.yield_energy) || (m.yield_stress > 0.0 && std::isfinite(m.yield_stress));
    w.any_anisotropic = w.any_anisotropic || m.anisotropy != Mat3::Identity();
    w.any_fracture = w.any_fracture || std::isfinite(m.critical_stretch) ||
                     (m.fracture_energy > 0.0 && std::isfinite(m.fracture_energy));
  }

  // FEM mode (components/fem.hpp): the particles are the mesh vertices; elastic materials only.
  const bool fem = scene.solver != scene::Solver::peridynamics;
  if (fem && (w.any_plastic || w.any_fracture))
    throw std::invalid_argument("model/solver: the FEM reference solver is elastic only; this scene has a material "
                                "with a finite yield_energy, yield_stress, critical_stretch or fracture_energy (use solver 'peridynamics')");
  if (fem && !scene.cracks.empty())
    throw std::invalid_argument("model/solver: initial cracks need solver 'peridynamics'");

  add_bodies(scene, w);
  allocate_step_state(w);
  resolve_boundary_conditions(scene.boundary_conditions, w);
  auto& p = w.particles;

  if (fem) {
    // No bonds: an empty CSR so bond-walking code (output fields, fragments) sees empty families.
    w.bonds.offsets.assign(p.count() + 1, 0);
    w.bonds.initial_count.assign(p.count(), 0);
    scheduler.execute([&] {
      systems::setup_fem(w);
      systems::compute_model_constants(w);  // the damping rate; the rest is unused without bonds
      systems::compute_fem_force(w, p.position, w.fem.corner_force, w.state.internal_force);
      parallel_for_each(p.count(), [&](std::size_t i) {
        w.state.external_force[i] = p.mass[i] * w.settings.gravity;
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
    systems::apply_strength_field(w);
    systems::compute_fracture_thresholds(w);
    // Initial acceleration for the first kick of velocity Verlet.
    systems::compute_dilatation(w, p.position, w.state.dilatation, w.state.dilatation_coupling);
    systems::compute_internal_force(w, p.position, w.state.dilatation_coupling, w.state.internal_force);
    parallel_for_each(p.count(), [&](std::size_t i) {
      w.state.external_force[i] = p.mass[i] * w.settings.gravity;
      p.acceleration[i] = (w.state.internal_force[i] + w.state.external_force[i]) / p.mass[i];
    });
  });
  systems::setup_contact(w);
  systems::setup_projectiles(w);
  return world;
}

}  // namespace perifx::setup
