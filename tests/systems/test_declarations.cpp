// Every system is held to its declaration: run alone on a world in mid-simulation, it may change
// only the arrays of the components it declares as written (systems/system.hpp). The scheduler
// builds the task graph from those declarations, so an undeclared write is a data race waiting to
// happen. Arrays are found through for_each_array (components/world_state.hpp), the same list the
// memory report uses, so a new array is covered as soon as it is counted.
#include <doctest/doctest.h>

#include <cstring>
#include <map>
#include <set>
#include <string>

#include "support.hpp"
#include "systems/pipeline.hpp"

using namespace perifx;

namespace {

// The component that owns each mutable array; arrays not listed are set up once and must never
// change during a step.
Component owner_of(const std::string& array) {
  static const std::map<std::string, Component> owners = {
      {"particles.position", Component::position},
      {"particles.velocity", Component::velocity},
      {"particles.acceleration", Component::acceleration},
      {"particles.flags", Component::flags},
      {"state.dilatation", Component::dilatation},
      {"state.dilatation_coupling", Component::dilatation},
      {"bonds.plastic_extension", Component::plastic_extension},
      {"bonds.plastic_extension_mirror", Component::plastic_extension},
      {"bonds.alive", Component::bond_alive},
      {"state.damage", Component::damage},
      {"state.broken_bonds", Component::damage},
      {"state.break_extension", Component::fracture_threshold},
      {"state.internal_force", Component::internal_force},
      {"fem.corner_force", Component::internal_force},  // the FEM force's per-corner partial sums
      {"state.external_force", Component::external_force},
      {"state.contact_force", Component::contact_force},
      {"state.bond_end", Component::bond_end},
      {"state.surface_frame", Component::surface_frames},
      {"state.open_faces", Component::surface_frames},
      {"state.collider_contact", Component::collider_contact},
  };
  if (auto it = owners.find(array); it != owners.end()) return it->second;
  if (array.rfind("projectiles.", 0) == 0) return Component::projectiles;
  if (array.rfind("embedded.", 0) == 0) return Component::mesh;
  if (array.rfind("contact.", 0) == 0 && array != "contact.size") return Component::contact_list;
  return Component::count_;  // constant
}

struct Snapshot {
  std::vector<std::string> names;
  std::vector<std::string> bytes;
};

Snapshot snapshot(const WorldState& w) {
  Snapshot s;
  for_each_array(w, [&](ArrayKind, const char* name, const auto& array) {
    s.names.emplace_back(name);
    s.bytes.emplace_back(reinterpret_cast<const char*>(array.data()), array.size() * sizeof(array[0]));
  });
  return s;
}

// Runs each system of the world's pipeline alone and checks what it changed.
void check_declarations(World& world, std::set<std::string>& seen, systems::PipelineOptions options = {}) {
  WorldState& w = world.state_mutable();
  for (auto& system : systems::step_pipeline(w, options)) {
    CAPTURE(system.name);
    seen.insert(system.name);
    const Snapshot before = snapshot(w);
    system.run();
    const Snapshot after = snapshot(w);
    REQUIRE(before.names == after.names);
    const std::set<Component> declared(system.writes.begin(), system.writes.end());
    for (std::size_t a = 0; a < before.names.size(); ++a) {
      if (before.bytes[a] == after.bytes[a]) continue;
      const Component owner = owner_of(before.names[a]);
      INFO("array " << before.names[a] << " changed; owner " << (owner == Component::count_ ? "none (constant)" : component_name(owner)));
      CHECK(declared.count(owner) == 1);
    }
  }
}

scene::Scene busy_scene() {
  // Two breakable, plastic bodies (contact), one pressed by a moving boundary, a ground collider, a
  // projectile flying into them, gravity and split-mesh output: every system of the step runs.
  auto sc = test::box_scene(Vec3(0.3, 0.1, 0.1), 0.025, 2e6, 1e6);
  sc.gravity = Vec3(0, -9.81, 0);
  sc.time.dt = 2e-5;
  sc.materials[0].yield_energy = 1e-3;
  sc.materials[0].plastic_cap_ratio = 0.5;
  sc.materials[0].critical_stretch = 0.02;
  sc.materials[0].damage_alpha = 1.0;
  sc.materials[0].anisotropy = Vec3(1.5, 1.0, 1.0).asDiagonal();
  scene::Body second = sc.bodies[0];
  second.name = "second";
  second.transform.translation = Vec3(0, 0.11, 0);
  sc.bodies.push_back(second);
  scene::BoundaryCondition pull;
  pull.kind = scene::BoundaryCondition::Kind::velocity;
  pull.region.kind = scene::Region::Kind::halfspace;
  pull.region.point = Vec3(0.12, 0, 0);
  pull.region.normal = Vec3(1, 0, 0);
  pull.velocity = Vec3(3.0, 0, 0);
  sc.boundary_conditions.push_back(pull);
  scene::Collider ground;
  ground.point = Vec3(0, -0.06, 0);
  sc.colliders.push_back(ground);
  scene::Projectile ball;
  ball.center = Vec3(-0.05, 0.2, 0);
  ball.radius = 0.03;
  ball.mass = 0.5;
  ball.velocity = Vec3(0, -20, 0);
  sc.projectiles.push_back(ball);
  sc.output.obj = true;
  // Loads of every kind that reads the moving state (positions, velocities, time).
  scene::Load wind;
  wind.kind = scene::Load::Kind::directional;
  wind.vector = Vec3(0, 0, -5);
  wind.drag = 2.0;
  scene::Load noise;
  noise.kind = scene::Load::Kind::noise;
  noise.magnitude = 50.0;
  noise.feature_size = 0.05;
  noise.speed = 1.0;
  scene::Load blast;
  blast.kind = scene::Load::Kind::blast;
  blast.center = Vec3(0, 0.3, 0);
  blast.radius = 0.05;
  blast.magnitude = 1e4;
  blast.duration = 1.0;
  blast.front_speed = 300.0;
  sc.loads = {wind, noise, blast};
  return sc;
}

}  // namespace

TEST_CASE("every system changes only the components it declares as written") {
  std::set<std::string> seen;
  World busy(busy_scene());
  busy.step(150);  // bonds break, plasticity and contact are active, the projectile has arrived
  REQUIRE(busy.alive_bond_count() < busy.bond_count());
  check_declarations(busy, seen);

  auto fem_scene = test::box_scene(Vec3(0.2, 0.05, 0.05), 0.025, 2e6, 1e6);
  fem_scene.solver = scene::Solver::fem_corotated;
  fem_scene.gravity = Vec3(0, -9.81, 0);
  World fem(fem_scene);
  fem.step(5);
  check_declarations(fem, seen);

  // The oracle's separate bond systems too.
  World separate(busy_scene());
  separate.step(150);
  systems::PipelineOptions options;
  options.separate_bond_systems = true;
  check_declarations(separate, seen, options);
  // Every system of the pipeline was exercised.
  for (const char* name : {"kick_begin", "boundary_conditions", "drift", "projectile_drift", "colliders", "contact",
                           "dilatation", "bond_pass", "external_loads", "projectile_contact", "kick_end",
                           "fracture_threshold", "crack_faces", "mesh_split", "mesh_vertices", "fem_force",
                           "plasticity", "elastic_force", "fracture", "damage"}) {
    CAPTURE(name);
    CHECK(seen.count(name) == 1);
  }
}
