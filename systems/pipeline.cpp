// The step, as a list. Velocity Verlet (kick–drift–kick) with constraints applied to the velocity
// before the drift:
//   kick_begin → boundary_conditions → drift → (projectile_drift) → colliders → (contact)
//   → dilatation → bond_pass (plasticity + elastic force + fracture test + damage, one bond pass)
//   external_loads (gravity + scene loads; reads the drifted positions and the half-step velocity)
//   → (projectile_contact) → kick_end → (surface_frames, for the next step's colliders)
//   → (fracture_threshold) → (crack_faces → mesh_split) → (mesh_rotations → mesh_vertices)
//                                                                               (embedded mesh, §5.2)
// Distributed runs add the halo exchanges (halo_motion after colliders, halo_dilatation after
// dilatation, halo_threshold after fracture_threshold) and keep only mesh_rotations of the embedded mesh.
// FEM mode replaces dilatation + bond_pass by fem_force. The scheduler derives the actual graph from
// each system's declared reads and writes; this order only settles who comes first on shared data.
#include "pipeline.hpp"

#include "field_registry.hpp"
#include "systems.hpp"

namespace perifx::systems {

std::vector<SystemDecl> step_pipeline(WorldState& w, PipelineOptions options) {
  std::vector<SystemDecl> s;
  const bool fem = w.settings.solver != scene::Solver::peridynamics;
  const bool separate = options.separate_bond_systems && !fem;
  s.push_back(kick_begin_system(w));
  s.push_back(boundary_condition_system(w));
  s.push_back(drift_system(w));
  if (!w.projectiles.bodies.empty()) s.push_back(projectile_drift_system(w));
  s.push_back(collider_system(w));
  const auto* halo = options.halo;
  if (halo)
    s.push_back({"halo_motion", {Component::position, Component::velocity}, {Component::position, Component::velocity},
                 halo->motion});
  // Contact reads the bonds as they were at the start of the step (before this step's breaks).
  if (w.contact.enabled) s.push_back(contact_system(w));
  if (fem) {
    s.push_back(fem_force_system(w));
  } else {
    s.push_back(dilatation_system(w));
    if (halo) s.push_back({"halo_dilatation", {Component::dilatation}, {Component::dilatation}, halo->dilatation});
    if (separate) {
      if (w.any_plastic) s.push_back(plasticity_system(w));
      s.push_back(elastic_force_system(w));
    } else {
      s.push_back(bond_pass_system(w));
    }
  }
  s.push_back(external_load_system(w));
  if (!w.projectiles.bodies.empty())
    s.push_back(projectile_contact_system(w, halo ? &halo->projectile_contacts : nullptr));
  s.push_back(kick_end_system(w));
  if (!w.state.surface_frame.empty()) s.push_back(surface_frame_system(w));
  if (separate && w.any_fracture) {
    s.push_back(fracture_system(w));
    s.push_back(damage_system(w));
  }
  if (w.any_fracture) s.push_back(fracture_threshold_system(w));
  if (halo && w.any_fracture)
    s.push_back({"halo_threshold", {Component::fracture_threshold}, {Component::fracture_threshold}, halo->threshold});
  // Embedded mesh (§5.2): crack faces and vertex splitting when bonds can break; vertex motion when
  // anything uses the mesh surface (fracture, or surface/tet output requested).
  // A distributed run's local world steps only the held rotations (per particle, from its family);
  // rank 0 replays the crack faces and vertex splits (engine/distributed/runtime.hpp).
  if (!fem && !options.embedded_mesh && !w.embedded.held_deformation.empty()) s.push_back(mesh_rotation_system(w));
  if (!fem && options.embedded_mesh) {
    if (w.any_fracture) s.push_back(crack_face_system(w));
    if (w.any_fracture) s.push_back(mesh_split_system(w));
    if (w.any_fracture || w.settings.mesh_output) {
      s.push_back(mesh_rotation_system(w));
      s.push_back(mesh_vertex_system(w));
    }
  }
  return s;
}


FieldRegistry step_fields() {
  FieldRegistry r;
  register_integration_fields(r);
  register_dilatation_fields(r);
  register_damage_fields(r);
  register_plasticity_fields(r);
  register_fragment_fields(r);
  // The particles' own constants, set when the world is built.
  r.push_back(make_field("volume", FieldType::f64, 1, "m^3", "particle volume V",
                         [](WorldState& w, FieldView& v) { view_array(v, w.particles.volume); }));
  r.push_back(make_field("mass", FieldType::f64, 1, "kg", "particle mass",
                         [](WorldState& w, FieldView& v) { view_array(v, w.particles.mass); }));
  r.push_back(make_field("material_id", FieldType::u16, 1, "1", "index into the scene's materials",
                         [](WorldState& w, FieldView& v) { view_array(v, w.particles.material_id); }));
  r.push_back(make_field("body_id", FieldType::u16, 1, "1", "index into the scene's bodies",
                         [](WorldState& w, FieldView& v) { view_array(v, w.particles.body_id); }));
  return r;
}

}  // namespace perifx::systems
