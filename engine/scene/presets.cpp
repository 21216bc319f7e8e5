// Material presets: room-temperature, quasi-static handbook values, rounded; each row names its
// sources. They are typical values of a material class, not of a particular grade: a scene that
// matters should give its own numbers (every key given beside `preset` overrides the preset's).
#include "scene/presets.hpp"

#include <limits>

namespace perifx::scene::detail {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}

const std::vector<MaterialPreset>& material_presets() {
  static const std::vector<MaterialPreset> table = {
      {"glass", 2500, 70e9, 0.22, 8.0, kInf, false, 1.0,
       "soda-lime glass: E ≈ 70 GPa, ν ≈ 0.22, K_IC ≈ 0.75 MPa·√m (Ashby & Jones, *Engineering Materials 1*, "
       "property tables); G_c = K_IC²/E ≈ 8 J/m²"},
      {"ceramic", 3900, 370e9, 0.22, 40.0, kInf, false, 1.0,
       "alumina (Al₂O₃, 96–99.5 %): E ≈ 370 GPa, ν ≈ 0.22, K_IC ≈ 3.5–4 MPa·√m (Ashby & Jones; "
       "Munro, J. Am. Ceram. Soc. 80 (1997) 1919); G_c = K_IC²/E ≈ 40 J/m²"},
      {"concrete", 2400, 30e9, 0.2, 100.0, kInf, false, 1.0,
       "normal-strength concrete (f_cm ≈ 30 MPa): E_cm ≈ 30 GPa, ν = 0.2 and fracture energy G_F ≈ 100–140 J/m² "
       "(fib Model Code 2010, §5.1.5 and §5.1.7); G_c = 100 J/m²"},
      {"stone", 2650, 50e9, 0.25, 45.0, kInf, false, 1.0,
       "granite: E ≈ 50 GPa, ν ≈ 0.25, K_IC ≈ 1.5 MPa·√m (Atkinson, *Fracture Mechanics of Rock*, 1987, "
       "data tables); G_c = K_IC²/E ≈ 45 J/m²"},
      {"wood", 500, 11e9, 0.35, 250.0, kInf, false, 0.5,
       "softwood (spruce/pine, ~12 % moisture) along the grain: ρ ≈ 450–500 kg/m³, E_L ≈ 10–12 GPa "
       "(USDA FPL *Wood Handbook*, FPL-GTR-190, ch. 5); mode I G_c ≈ 200–300 J/m² for a crack "
       "along the grain (Wood Handbook ch. 5, fracture toughness). The model is isotropic in κ, μ: the grain "
       "is Eq 17's anisotropy, bonds along x weighted ×2 (ratio_along 0.5), which makes cracks run along it"},
      {"steel", 7850, 200e9, 0.3, 1.0e5, 250e6, true, 1.0,
       "mild structural steel (ASTM A36 / S235–S275): E = 200 GPa, ν = 0.3, yield strength (0.2 % offset) ≈ 250 MPa (ASM / MatWeb "
       "A36 datasheet); ductile J_IC ≈ 50–200 kJ/m² (Anderson, *Fracture Mechanics*, "
       "3rd ed., ch. 7): G_c = 100 kJ/m²"},
      {"aluminium", 2700, 69e9, 0.33, 1.2e4, 275e6, true, 1.0,
       "aluminium alloy 6061-T6: E = 68.9 GPa, ν = 0.33, yield strength (0.2 % offset) 276 MPa, K_IC ≈ 29 MPa·√m (ASM Handbook vol. 2 / "
       "MatWeb 6061-T6); G_c = K_IC²/E ≈ 12 kJ/m²"},
      {"rubber", 1100, 2.0e6, 0.48, 1.0e4, kInf, false, 1.0,
       "natural rubber (unfilled vulcanizate): E ≈ 1–3 MPa (Gent, *Engineering with Rubber*, 3rd ed., ch. 1); "
       "tearing energy ≈ 10 kJ/m² (Rivlin & Thomas, J. Polym. Sci. 10 (1953) 291). Real rubber has ν ≈ 0.4999; "
       "0.48 keeps κ (and with it the stable time step) usable, at the price of some compressibility"},
      {"jello", 1050, 10e3, 0.45, 1.0, kInf, false, 1.0,
       "gelatin gel (dessert to ~10 % w/w): compressive stiffness 4–280 kPa with concentration (Bonavia, "
       "arXiv:2512.20502, 2025), E = 10 kPa chosen; wire-cutting G_c ≈ 1.1 J/m² at 10 % w/w (Forte, D'Amico, "
       "Charalambides, Dini & Williams, 2015, rate-dependent fracture of gelatine gels). ν = 0.45 (nearly incompressible gel, "
       "relaxed for the time step)"},
      {"clay", 1800, 2.0e6, 0.45, 1.0e3, 50e3, false, 1.0,
       "oil-based modelling clay (plasticine, Roma Plastilina): ρ ≈ 1.6–1.8 t/m³, initial modulus of order "
       "1–5 MPa and flow stress of order 20–100 kPa at room temperature (plasticine studies in Mechanics of Materials, "
       "2009, and Roma Plastilina No. 1 characterizations, 2023). Order-of-magnitude "
       "values; G_c = 1 kJ/m² is a ductile-tearing guess, not a measurement"},
  };
  return table;
}

const MaterialPreset* find_preset(const std::string& name) {
  for (const auto& p : material_presets())
    if (name == p.name) return &p;
  return nullptr;
}

std::vector<std::string> preset_names() {
  std::vector<std::string> out;
  for (const auto& p : material_presets()) out.push_back(p.name);
  return out;
}

}  // namespace perifx::scene::detail
