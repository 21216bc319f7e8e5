// The system interface: what a system declares (name, the components it reads and writes) and the
// function the scheduler calls once per step. The scheduler (engine/scheduler.hpp) derives the oneTBB
// flow graph from the declarations; tests/systems/test_declarations.cpp holds every system to them.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace perifx {

// Every piece of mutable world data a system may declare. Constant setup data (reference positions,
// volumes, model constants, bond geometry) is not listed: nothing writes it during a step.
enum class Component : std::uint8_t {
  time,
  position,
  velocity,
  acceleration,
  flags,
  dilatation,
  plastic_extension,
  bond_alive,
  damage,
  fracture_threshold,
  internal_force,
  external_force,
  contact_force,
  projectiles,
  mesh,  // the embedded (cracking) tet mesh: WorldState::embedded
  bond_end,      // ParticleState::bond_end, the packed far-end copy the bond pass refreshes and reads
  contact_list,  // ContactState's grid and Verlet pair list (systems/contact.cpp)
  surface_frames,  // ParticleState::surface_frame, which places the boundary faces the colliders meet
  collider_contact,  // ParticleState::collider_contact, the collider that held each particle this step
  count_  // number of components
};
const char* component_name(Component c);

struct SystemDecl {
  std::string name;
  std::vector<Component> reads;
  std::vector<Component> writes;
  std::function<void()> run;  // called once per step, inside the world's task arena
};

}  // namespace perifx
