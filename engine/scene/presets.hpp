// Internal to engine/scene: the material presets (`"preset": "glass"`, …), one table shared by the
// loader (fills the keys a material does not give) and the generated reference (FORMAT.md lists the
// values and where they come from).
#pragma once
#include <string>
#include <vector>

namespace perifx::scene::detail {

struct MaterialPreset {
  const char* name;
  double density;          // kg/m³
  double youngs_modulus;   // Pa
  double poisson_ratio;
  double fracture_energy;  // G_c, J/m² (+∞: unbreakable)
  double yield_stress;     // Pa (+∞: elastic up to fracture): the 0.2 % offset yield stress when
                           // yield_is_offset (a datasheet's yield strength), else the flow stress σ_y
  bool yield_is_offset;
  double grain_ratio;      // anisotropy along the grain (x axis): ratio_along = grain_ratio, across = 1; 1 = isotropic
  const char* source;      // where the numbers come from (markdown)
};

const std::vector<MaterialPreset>& material_presets();
const MaterialPreset* find_preset(const std::string& name);
std::vector<std::string> preset_names();

}  // namespace perifx::scene::detail
