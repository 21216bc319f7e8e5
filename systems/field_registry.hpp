// The fields a world can write or hand to a host, registered by the systems that produce them (each
// system file has a register_*_fields function; pipeline.cpp calls them in output order). Writers,
// World::field, `perifx info` and the scene format's list of output fields all read this registry.
#pragma once
#include <cstdint>
#include <functional>
#include <vector>

#include "components/world_state.hpp"
#include "perifx/fields.hpp"

namespace perifx::systems {

struct FieldEntry {
  FieldView info;  // name, type, components, location, unit, doc (data and count filled by bind)
  // Points view.data / view.count at the field's array for the world's current state. A derived
  // field (derived = true) first computes its array into WorldState::derived, so the world calls it
  // only when the field is asked for and the state changed since the last call.
  std::function<void(WorldState&, FieldView&)> bind;
  bool derived = false;
};

using FieldRegistry = std::vector<FieldEntry>;

// A registry entry; `bind` as above.
inline FieldEntry make_field(const char* name, FieldType type, int components, const char* unit, const char* doc,
                             std::function<void(WorldState&, FieldView&)> bind, bool derived = false) {
  return FieldEntry{FieldView{name, type, components, FieldLocation::particle, nullptr, 0, unit, doc}, std::move(bind),
                    derived};
}

// Points a view at a whole per-particle array.
template <class T>
void view_array(FieldView& view, const std::vector<T>& array) {
  view.data = array.data();
  view.count = array.size();
}

// Registration, one function per producing system (in the order fields are written):
void register_integration_fields(FieldRegistry& r);  // integration.cpp: position, velocity, displacement, acceleration
void register_dilatation_fields(FieldRegistry& r);   // dilatation.cpp: dilatation
void register_damage_fields(FieldRegistry& r);       // damage.cpp: damage, alive_bonds, broken_bonds
void register_plasticity_fields(FieldRegistry& r);   // plasticity.cpp: plastic_strain
void register_fragment_fields(FieldRegistry& r);     // fragments.cpp: fragment_id
// pipeline.cpp: all of the above, then the particles' own constants (volume, mass, material_id, body_id).
FieldRegistry step_fields();

}  // namespace perifx::systems
