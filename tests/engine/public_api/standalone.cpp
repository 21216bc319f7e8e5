// Compiled (never run) by the perifx_public_api_check target with only engine/include and Eigen on
// the include path: the public headers must stand on their own. Uses each header's main types so a
// missing include or an internal type leaking into the API fails the build.
#include "perifx/errors.hpp"
#include "perifx/fields.hpp"
#include "perifx/math.hpp"
#include "perifx/mesh.hpp"
#include "perifx/scene.hpp"
#include "perifx/world.hpp"

double public_api_use(perifx::World& world) {
  perifx::scene::Scene scene;
  scene.bodies.emplace_back();
  try {
    world.step(2);
    const perifx::FieldView damage = world.field("damage");
    const perifx::SurfaceMesh surface = world.surface();
    const perifx::MemoryUse memory = world.memory();
    return double(damage.count + surface.triangles.size() + memory.total_bytes) + world.positions()[0].norm();
  } catch (const perifx::Error& e) {
    return -1.0;
  }
}
