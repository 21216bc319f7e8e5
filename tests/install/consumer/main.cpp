// Example host program: builds a world from a scene file, steps it 20 times and prints a summary.
// Only the installed public headers (perifx/...) are used.
#include <cstdio>

#include "perifx/world.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: consumer SCENE.json\n");
    return 1;
  }
  try {
    perifx::World world = perifx::World::from_file(argv[1]);
    world.step(20);
    const perifx::FieldView damage = world.field("damage");
    std::printf("consumer: %zu particles, %zu bonds, t = %g s after %llu steps, field '%s' has %zu values, y0 = %.6f\n",
                world.particle_count(), world.bond_count(), world.time(),
                static_cast<unsigned long long>(world.step_count()), damage.name.c_str(), damage.count,
                world.positions()[0].y());
  } catch (const perifx::Error& e) {
    std::fprintf(stderr, "consumer: %s\n", e.what());
    return 2;
  }
  return 0;
}
