#include "system.hpp"

namespace perifx {

const char* component_name(Component c) {
  switch (c) {
    case Component::time: return "time";
    case Component::position: return "position";
    case Component::velocity: return "velocity";
    case Component::acceleration: return "acceleration";
    case Component::flags: return "flags";
    case Component::dilatation: return "dilatation";
    case Component::plastic_extension: return "plastic_extension";
    case Component::bond_alive: return "bond_alive";
    case Component::damage: return "damage";
    case Component::fracture_threshold: return "fracture_threshold";
    case Component::internal_force: return "internal_force";
    case Component::external_force: return "external_force";
    case Component::contact_force: return "contact_force";
    case Component::projectiles: return "projectiles";
    case Component::mesh: return "mesh";
    case Component::bond_end: return "bond_end";
    case Component::contact_list: return "contact_list";
    case Component::surface_frames: return "surface_frames";
    case Component::collider_contact: return "collider_contact";
    case Component::count_: break;
  }
  return "?";
}

}  // namespace perifx
