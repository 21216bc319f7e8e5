#include "setup/world_setup.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>

#include "geometry/geometry.hpp"
#include "systems/huge_pages.hpp"
#include "systems/parallel.hpp"
#include "systems/systems.hpp"
#include "systems/yield_law.hpp"

namespace perifx::setup {
namespace {

// What the step reads from the scene, copied once (systems never see the scene itself).
void resolve_settings(const scene::Scene& scene, StepSettings& s) {
  s.gravity = scene.gravity;  // the loads are resolved with their particle lists (setup/loads.cpp)
  s.normalization = scene.normalization;
  s.family = scene.family;
  s.solver = scene.solver;
  s.materials = scene.materials;
  // A datasheet's yield strength (0.2 % offset) becomes the flow stress of the paper's per-bond law,
  // which is what the model constants read (systems/yield_law.hpp).
  for (auto& m : s.materials) {
    if (!(m.yield_stress == 0.0 && m.offset_yield_stress > 0.0 && std::isfinite(m.offset_yield_stress))) continue;
    m.yield_stress = systems::flow_stress_for_offset_yield(m.bulk_modulus, m.shear_modulus, m.offset_yield_stress);
    if (!(m.yield_stress > 0.0 && std::isfinite(m.yield_stress)))
      throw scene::SceneError(scene.source.string(), "/materials/" + m.name + "/offset_yield_stress",
                              "no flow stress has this offset yield stress (got " + std::to_string(m.offset_yield_stress) +
                                  " Pa; expected a positive stress, with positive moduli)");
  }
  s.colliders = scene.colliders;
  s.contact = scene.contact;
  s.projectiles = scene.projectiles;
  s.distributed = scene.distributed;
  s.threads = scene.threads;
  s.mesh_output = scene.output.obj || scene.output.surface_ply || scene.output.tets_vtu;
}

// The instability bound of kick_end (StepSettings::max_speed): no free particle of a healthy run moves
// faster than every speed the scene can put into it, and elastic waves carry momentum at most at the
// wave speed c = sqrt((κ + 4μ/3)/ρ) (a particle's own speed stays far below it: σ/(ρc)). The sum of
// the fastest wave speed and every prescribed speed (initial, boundary conditions — a displacement
// over its ramp, or over one step without one —, colliders and projectiles including their spin at
// the scene's extent, gravity over the duration) is a generous upper bound; kMaxSpeedFactor = 10
// leaves room above it. A blow-up grows exponentially, so it crosses the bound within a few steps.
constexpr double kMaxSpeedFactor = 10.0;

// The diagonal of the bodies' reference box, or of a collider if one is larger: the arm of every spin.
double scene_extent(const scene::Scene& scene, const WorldState& w) {
  Vec3 lo = Vec3::Constant(kInfinity), hi = Vec3::Constant(-kInfinity);
  for (const Vec3& x : w.particles.reference_position) lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
  double extent = w.particles.count() ? (hi - lo).norm() : 0.0;
  for (const auto& c : scene.colliders) extent = std::max(extent, c.half_extents.norm() + c.radius);
  return extent;
}

// Every speed the scene prescribes, summed (so a bound on any closing speed of two of them): the
// bodies' initial motion, boundary conditions, colliders and projectiles, spins at the scene's extent.
// A condition's displacement or rotation counts over its ramp, or over `jump` without one (max_speed:
// one step; the automatic step: none, as a jump happens in one step whatever the step).
double prescribed_speed(const scene::Scene& scene, double extent, double jump) {
  double speed = 0.0;
  for (const auto& b : scene.bodies) speed += b.velocity.norm() + b.angular_velocity.norm() * extent;
  for (const auto& bc : scene.boundary_conditions) {
    speed += bc.velocity.norm() + bc.angular_velocity.norm() * extent;
    const double over = std::max(bc.window.ramp, jump);
    if (over > 0.0) speed += bc.displacement.norm() / over + std::abs(bc.rotation_angle) * extent / over;
  }
  for (const auto& c : scene.colliders) speed += c.velocity.norm() + c.angular_velocity.norm() * extent;
  for (const auto& pr : scene.projectiles) speed += pr.velocity.norm() + pr.angular_velocity.norm() * pr.radius;
  return speed;
}

// `extent`: scene_extent.
double max_speed(const scene::Scene& scene, double extent, double dt) {
  double wave = 0.0;
  for (const auto& m : scene.materials) {
    // Anisotropy scales the stiffness by up to the largest |G| entry squared.
    const double g = std::max(1.0, m.anisotropy.cwiseAbs().maxCoeff());
    wave = std::max(wave, g * std::sqrt((m.bulk_modulus + 4.0 / 3.0 * m.shear_modulus) / m.density));
  }
  const double speed = wave + scene.gravity.norm() * (scene.time.duration + dt) +
                       prescribed_speed(scene, extent, dt);
  return kMaxSpeedFactor * speed;
}

// "dt": "auto" (scene.hpp, Time::auto_dt; systems/README.md §7): the smaller of
//   - 80 % of the stable limit `stable` (the estimate of stable_time_step.cpp): the limit is that of the
//     linearized model at rest, and compression, contact and impacts stiffen a running scene (the CLI
//     warns above 80 % of it);
//   - the step in which the fastest prescribed motion (prescribed_speed) covers kMotionPerStep of the
//     finest length: the finest body's mean edge length λ, or a projectile's radius if smaller. A 60 m/s
//     bullet at 80 % of a jelly's limit crossed 1.2 cm cells in one step and passed through without
//     breaking a bond, where the scene's own 5e-5 s (0.3 of a cell per step) breaks 7,688
//     (assets/scenes/jello_bullet.json). The radius keeps a projectile's blow the same at every
//     resolution: how much an impact breaks depends on the step through the contact stiffness
//     (systems/README.md §8.4), and with λ alone the jelly's 2 cm preview took twice the final's step
//     and broke nothing, where at the final's step it breaks 1,314 bonds (0.26 %; the final 0.19 %);
//     12 mm radius.
// then shortened to the frame interval divided into a whole number of steps, so that every frame falls
// on a step. Throws SceneError naming /time/dt when no limit can be computed or the step is too small
// for the duration.
constexpr double kStableFraction = 0.8;
constexpr double kMotionPerStep = 0.25;

// The step the two rules above allow, before it is fitted to the frames: min(80 % of `stable`, the
// step in which the fastest prescribed motion covers kMotionPerStep of the finest length). 0 when the
// stable limit could not be estimated.
// It is also the contact time scale τ of contact/time_scale "auto" (systems/contact_law.hpp: the
// contact and projectile springs are k = stiffness_factor·m/max(τ, dt)²), for whatever step the scene
// gives. So the contact is a property of the scene, not of its step: the same for a given step and for
// "auto" (whose step is at most τ), and unchanged when a step is halved. 80 % of the limit ties it to
// the material (k ∝ m/dt_max², the stiffness of a bond of the body); the motion term keeps a fast
// projectile's penetration, ≈ v τ/√stiffness_factor, within about a cell or its radius. Speed that
// gravity builds up during the run is not counted.
double allowed_time_step(const scene::Scene& scene, const WorldState& w, double extent, double stable) {
  if (!(stable > 0.0) || !std::isfinite(stable)) return 0.0;
  double finest = kInfinity;  // λ of the finest body, or the smallest projectile's radius
  for (const auto& b : w.bodies) finest = std::min(finest, b.mean_edge_length);
  for (const auto& pr : scene.projectiles) finest = std::min(finest, pr.radius);
  const double speed = prescribed_speed(scene, extent, 0.0);
  const double by_motion = speed > 0.0 && finest < kInfinity ? kMotionPerStep * finest / speed : kInfinity;
  return std::min(kStableFraction * stable, by_motion);
}

// `allowed` (allowed_time_step) fitted to the frame interval.
double automatic_time_step(const scene::Scene& scene, double extent, double stable, double allowed) {
  const std::string file = scene.source.string();
  auto g = [](double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", x);
    return std::string(buf);
  };
  if (!(allowed > 0.0))
    throw scene::SceneError(file, "/time/dt",
                            "\"auto\" found no stable step for these bodies (got a stable limit of " +
                                g(stable) + " s; expected bodies with bonds or tets; give dt in seconds)");
  const double interval = 1.0 / scene.time.frame_rate;
  const double steps_per_frame = std::ceil(interval / allowed);
  scene::Scene resolved = scene;
  resolved.time.dt = interval / steps_per_frame;
  try {
    scene::check_time(resolved);
  } catch (const scene::SceneError& e) {
    throw scene::SceneError(file, "/time/dt", std::string("\"auto\" picked ") + g(resolved.time.dt) +
                                                  " s (the stable limit is " + g(stable) + " s, the fastest prescribed motion " +
                                                  g(prescribed_speed(scene, extent, 0.0)) +
                                                  " m/s), which the time settings refuse: " + e.message());
  }
  return resolved.time.dt;
}

}  // namespace

bool can_yield(const scene::Material& m) {
  return std::isfinite(m.yield_energy) || (m.yield_stress > 0.0 && std::isfinite(m.yield_stress)) ||
         (m.offset_yield_stress > 0.0 && std::isfinite(m.offset_yield_stress));
}

void check_solver(const scene::Scene& scene) {
  if (scene.solver == scene::Solver::peridynamics) return;
  for (const auto& m : scene.materials)
    if (can_yield(m) || scene::can_break(m))
      throw scene::SceneError(scene.source.string(), "/model/solver",
                              "the FEM reference solver is elastic only (got a material with a finite yield_energy, "
                              "yield_stress, critical_stretch or fracture_energy; expected solver 'peridynamics')");
  if (!scene.cracks.empty())
    throw scene::SceneError(scene.source.string(), "/model/solver",
                            "initial cracks need the peridynamic solver (got an FEM solver; expected 'peridynamics')");
}

void release_arrays(WorldState& w) {
  for_each_array(w, [](ArrayKind, const char*, auto& array) { std::remove_reference_t<decltype(array)>().swap(array); });
}

void release_contact_buffers(WorldState& w) {
  for_each_array(w, [](ArrayKind kind, const char* name, auto& array) {
    if (kind == ArrayKind::contact && std::string_view(name) != "contact.size")  // the colliders' reach reads it
      std::remove_reference_t<decltype(array)>().swap(array);
  });
  w.contact.pairs.valid = false;
  w.contact.pairs.search_grid_valid = false;
}

std::unique_ptr<WorldState> build_world_state(const scene::Scene& scene, Scheduler& scheduler,
                                              std::vector<PhaseTime>* times, bool shell, double* stable_time_step) {
  // Phase timer: each call closes the phase that began at the previous one.
  auto last = std::chrono::steady_clock::now();
  auto phase = [&](const char* name) {
    const auto now = std::chrono::steady_clock::now();
    if (times) times->push_back({name, std::chrono::duration<double>(now - last).count()});
    last = now;
  };
  auto world = std::make_unique<WorldState>();
  WorldState& w = *world;
  w.clock.dt = scene.time.dt;
  resolve_settings(scene, w.settings);
  for (const auto& m : scene.materials) {
    w.any_plastic = w.any_plastic || can_yield(m);
    w.any_anisotropic = w.any_anisotropic || m.anisotropy != Mat3::Identity();
    w.any_fracture = w.any_fracture || scene::can_break(m);
  }

  // FEM mode (components/fem.hpp): the particles are the mesh vertices; elastic materials only.
  const bool fem = scene.solver != scene::Solver::peridynamics;
  check_solver(scene);

  if (shell) {
    // What a local world takes from the whole world besides its arrays (engine/distributed/
    // local_world.cpp: set_local_frame, finish_local_world), resolved as below, without meshing a body:
    // what needs the meshes (bodies' measures, the instability bound, the contact reach) comes from
    // rank 0 before the split (take_world_frame).
    for (const auto& body : scene.bodies) w.bodies.push_back(BodyInfo{body.name});
    w.boundary.conditions = scene.boundary_conditions;
    w.loads.loads = scene.loads;
    w.fem.corotated = scene.solver == scene::Solver::fem_corotated;
    systems::resolve_contact(w);
    if (fem) w.contact.enabled = false;
    phase("shell (the whole world is rank 0's)");
    return world;
  }
  scheduler.execute([&] { add_bodies(scene, w); });
  phase("bodies (mesh, Morton order, particles)");
  scheduler.execute([&] { allocate_step_state(w); });  // parallel page clearing, in the world's arena
  resolve_boundary_conditions(scene.boundary_conditions, w);
  phase("step state and boundary conditions");
  // Face adjacency of the tet mesh, once: the boundary faces (loads, projectiles, colliders), the
  // families' mesh rule and the embedded mesh read it.
  std::vector<std::array<std::int32_t, 4>> adjacency;
  scheduler.execute([&] { adjacency = geometry::face_neighbors(w.mesh); });
  phase("mesh adjacency");
  resolve_loads(scene.loads, adjacency, w);
  phase("loads");
  auto& p = w.particles;
  // An automatic step (scene.time.auto_dt) from the stable limit of the finished model, before anything
  // reads the step (the first half step's loads, contact and projectile stiffness, surface frames).
  // The same for the contact time scale (contact/time_scale "auto") when anything touches: particle
  // contact or a projectile.
  auto resolve_time_step = [&] {
    const double extent = scene_extent(scene, w);  // one pass over the particles, for all rules below
    const bool touches = (!fem && systems::contact_runs(w)) || !scene.projectiles.empty();
    const bool auto_contact = touches && scene.contact.time_scale == 0.0;
    if (scene.time.auto_dt || auto_contact) {
      double stable = std::numeric_limits<double>::quiet_NaN();  // no estimate: automatic_time_step says so
      try {
        stable = estimate_stable_time_step(w);
      } catch (const std::runtime_error&) {
      }
      const double allowed = allowed_time_step(scene, w, extent, stable);  // also the auto contact τ
      if (scene.time.auto_dt) w.clock.dt = automatic_time_step(scene, extent, stable, allowed);
      if (auto_contact) w.settings.contact.time_scale = allowed;
      if (stable_time_step) *stable_time_step = stable;
      phase(scene.time.auto_dt ? "stable time step (dt \"auto\")" : "stable time step (contact time scale)");
    }
    w.settings.max_speed = max_speed(scene, extent, w.clock.dt);
  };

  if (fem) {
    // No bonds: an empty CSR so bond-walking code (output fields, fragments) sees empty families.
    w.bonds.offsets.assign(p.count() + 1, 0);
    w.bonds.initial_count.assign(p.count(), 0);
    scheduler.execute([&] {
      systems::setup_fem(w);
      systems::compute_model_constants(w);  // the damping rate; the rest is unused without bonds
      resolve_time_step();
      systems::compute_fem_force(w, p.position, w.fem.corner_force, w.state.internal_force);
      systems::compute_external_force(w, 0.0, 0.0, 0.5 * w.clock.dt);  // the first half step, [0, dt/2]
      parallel_for_each(p.count(), [&](std::size_t i) {
        p.acceleration[i] = (w.state.internal_force[i] + w.state.external_force[i]) / p.mass[i];
      });
    });
    systems::setup_contact(w);
    w.contact.enabled = false;  // particle contact assumes unbonded particles; FEM vertices are not
    systems::setup_projectiles(w);
    return world;
  }
  scheduler.execute([&] {
    systems::pack_reference_points(w);
    systems::build_families(w, adjacency);
    systems::remove_cracked_bonds(w, scene.cracks);
    systems::mark_anisotropic_families(w);
    phase("families");
    systems::setup_embedded_mesh(w, adjacency);  // after the bonds: a face pair without one starts cracked
    resolve_openable_faces(adjacency, w);         // the same rule for the colliders' crack faces
    phase("embedded mesh");
    systems::compute_model_constants(w);
    systems::apply_strength_field(w);
    systems::compute_fracture_thresholds(w);
    phase("model constants");
    resolve_time_step();
    // Initial acceleration for the first kick of velocity Verlet. In the reference configuration every
    // extension is exactly 0.0 (|y_j − y_i| and |ξ| are the same bits) and e^p starts at 0, so θ and the
    // internal force are exactly zero: the passes (0.7 s at 9e5 particles) run only if a position differs.
    const bool at_reference = p.position.size() == p.reference_position.size() &&
                              std::memcmp(p.position.data(), p.reference_position.data(), p.position.size() * sizeof(Vec3)) == 0;
    if (at_reference) {
      parallel_for_each(p.count(), [&](std::size_t i) {
        w.state.dilatation[i] = 0.0;
        w.state.dilatation_coupling[i] = 0.0;
        w.state.internal_force[i] = Vec3::Zero();
      });
    } else {
      systems::compute_dilatation(w, p.position, w.state.dilatation, w.state.dilatation_coupling);
      systems::compute_internal_force(w, p.position, w.state.dilatation_coupling, w.state.internal_force);
    }
    systems::compute_external_force(w, 0.0, 0.0, 0.5 * w.clock.dt);  // the first half step, [0, dt/2]
    parallel_for_each(p.count(), [&](std::size_t i) {
      p.acceleration[i] = (w.state.internal_force[i] + w.state.external_force[i]) / p.mass[i];
    });
    phase("initial force");
    // The colliders meet the faces placed by the surface frames (systems/surface_frames.cpp).
    if (!w.settings.colliders.empty() && !w.surface.radius.empty()) {
      systems::assign_huge_pages(w.state.surface_frame, p.count(), Eigen::Matrix3f(Eigen::Matrix3f::Zero()));
      if (!w.openable_faces.corner.empty()) systems::assign_huge_pages(w.state.open_faces, p.count(), std::uint8_t{0});
      systems::update_surface_frames(w);
    }
  });
  scheduler.execute([&] {  // their buffers are cleared by the arena's threads (huge_pages.hpp)
    systems::setup_contact(w);
    systems::setup_projectiles(w);
  });
  phase("contact and projectiles");
  // The per-particle arrays the bond passes gather from into huge pages (systems/huge_pages.hpp; the
  // bond arrays were allocated there). Mesh and contact arrays stay: copying them cost more set-up
  // time (about 1.5 s at 9e5 particles) than they gain.
  // The step state (particles.acceleration, .flags and state.*) was allocated there already.
  scheduler.execute([&] {
    for_each_array(w, [](ArrayKind kind, const char* name, auto& array) {
      const std::string_view n(name);
      const bool step_state = n.starts_with("state.") || n == "particles.acceleration" || n == "particles.flags";
      if (kind == ArrayKind::particle && !step_state) systems::move_to_huge_pages(array);
    });
  });
  phase("huge pages");
  return world;
}

}  // namespace perifx::setup
