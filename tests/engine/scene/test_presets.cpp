// Material presets and the physical fracture / yield keys of the scene format (issue 12).
#include <doctest/doctest.h>

#include <cmath>

#include "perifx/scene.hpp"
#include "scene/presets.hpp"
#include "scene/schema.hpp"

using namespace perifx;
using namespace perifx::scene;
using Json = nlohmann::ordered_json;

namespace {

Json with_material(const Json& material) {
  Json j = Json::parse(R"({
    "time": { "dt": 1e-6 },
    "materials": {},
    "bodies": [ { "material": "m", "geometry": { "type": "box", "size": [0.1, 0.1, 0.1] } } ]
  })");
  j["materials"]["m"] = material;
  return j;
}

std::string error_in(const Json& j) {
  try {
    load_scene_text(j.dump(), "presets.json");
  } catch (const SceneError& e) {
    return e.what();
  }
  return "<no error>";
}

}  // namespace

TEST_CASE("presets: every preset loads with its table values") {
  for (const auto& p : detail::material_presets()) {
    CAPTURE(p.name);
    const Scene s = load_scene_text(with_material({{"preset", p.name}}).dump(), "presets.json");
    const Material& m = s.materials[0];
    const double E = p.youngs_modulus, nu = p.poisson_ratio;
    CHECK(m.preset == p.name);
    CHECK(m.density == p.density);
    CHECK(m.bulk_modulus == doctest::Approx(E / (3 * (1 - 2 * nu))).epsilon(1e-14));
    CHECK(m.shear_modulus == doctest::Approx(E / (2 * (1 + nu))).epsilon(1e-14));
    CHECK(m.fracture_energy == p.fracture_energy);
    CHECK(std::isinf(m.critical_stretch));  // derived from G_c per horizon at setup
    if (std::isfinite(p.yield_stress)) {
      // The metals' datasheet yield strength is an offset (proof) stress; clay's is a flow stress.
      CHECK(m.yield_stress == (p.yield_is_offset ? 0.0 : p.yield_stress));
      CHECK(m.offset_yield_stress == (p.yield_is_offset ? p.yield_stress : 0.0));
      CHECK(std::isinf(m.plastic_cap_ratio));  // perfect plasticity unless capped
    } else {
      CHECK(m.yield_stress == 0.0);
      CHECK(m.offset_yield_stress == 0.0);
      CHECK(m.plastic_cap_ratio == 0.0);
    }
    CHECK(std::isinf(m.yield_energy));
    CHECK((m.anisotropy == Mat3::Identity()) == (p.grain_ratio == 1.0));
    CHECK(!std::string(p.source).empty());
  }
  // Breakable presets get the jittered mesh like any breakable material.
  const Scene glass = load_scene_text(with_material({{"preset", "glass"}}).dump(), "presets.json");
  CHECK(glass.bodies[0].geometry.jitter == 0.3);
}

TEST_CASE("presets: keys given beside a preset override it") {
  const Scene s = load_scene_text(
      with_material(Json::parse(R"({"preset": "steel", "density": 7000, "youngs_modulus": 1e11, "poisson_ratio": 0.25,
                                    "critical_stretch": 0.01, "yield_energy": 1e20, "plastic_cap_ratio": 0.1,
                                    "anisotropy": {"axis": [0, 1, 0], "ratio_along": 2, "ratio_across": 2}})"))
          .dump(),
      "presets.json");
  const Material& m = s.materials[0];
  CHECK(m.density == 7000);
  CHECK(m.bulk_modulus == doctest::Approx(1e11 / 1.5));
  CHECK(m.critical_stretch == 0.01);
  CHECK(m.fracture_energy == 0.0);
  CHECK(m.yield_energy == 1e20);
  CHECK(m.yield_stress == 0.0);
  CHECK(m.offset_yield_stress == 0.0);  // the preset's yield strength is replaced, not kept beside it
  CHECK(m.plastic_cap_ratio == 0.1);
  CHECK(m.anisotropy == Mat3(2.0 * Mat3::Identity()));
  const Scene g = load_scene_text(
      with_material(Json::parse(R"({"preset": "glass", "fracture_energy": 4, "yield_stress": 1e8})")).dump(),
      "presets.json");
  CHECK(g.materials[0].fracture_energy == 4);
  CHECK(g.materials[0].yield_stress == 1e8);
  // Either physical yield key replaces the preset's yield: a flow stress, or another offset stress.
  for (const char* key : {"yield_stress", "offset_yield_stress"}) {
    Json material = Json::parse(R"({"preset": "aluminium"})");
    material[key] = 1.5e8;
    const Material& al = load_scene_text(with_material(material).dump(), "presets.json").materials[0];
    CHECK(al.yield_stress == (std::string(key) == "yield_stress" ? 1.5e8 : 0.0));
    CHECK(al.offset_yield_stress == (std::string(key) == "offset_yield_stress" ? 1.5e8 : 0.0));
  }
  const Scene w = load_scene_text(with_material(Json::parse(R"({"preset": "wood"})")).dump(), "presets.json");
  CHECK(w.materials[0].anisotropy(0, 0) == 0.5);
  CHECK(w.materials[0].anisotropy(1, 1) == 1.0);
}

TEST_CASE("physical keys: one line errors for mixed or missing keys") {
  CHECK(error_in(with_material(Json::parse(R"({"preset": "glas"})"))).find("/materials/m/preset") != std::string::npos);
  CHECK(error_in(with_material(Json::parse(R"({"bulk_modulus": 1e6, "shear_modulus": 1e6, "critical_stretch": 0.1,
                                               "fracture_energy": 10})"))) ==
        "presets.json: /materials/m/fracture_energy: given together with critical_stretch (got 10; expected either "
        "critical_stretch or fracture_energy, not both)");
  CHECK(error_in(with_material(Json::parse(R"({"bulk_modulus": 1e6, "shear_modulus": 1e6, "yield_energy": 1e9,
                                               "yield_stress": 1e5})"))) ==
        "presets.json: /materials/m/yield_stress: given together with yield_energy (got 100000.0; expected either "
        "yield_energy or yield_stress, not both)");
  CHECK(error_in(with_material(Json::parse(R"({"bulk_modulus": 1e6, "shear_modulus": 1e6, "yield_stress": 1e5,
                                               "offset_yield_stress": 9e4})"))) ==
        "presets.json: /materials/m/offset_yield_stress: given together with yield_stress (got 90000.0; expected one of "
        "yield_energy, yield_stress or offset_yield_stress)");
  CHECK(error_in(with_material(Json::parse(R"({"preset": "steel", "yield_energy": 1, "offset_yield_stress": 9e4})")))
            .find("/materials/m/offset_yield_stress: given together with yield_energy") != std::string::npos);
  CHECK(error_in(with_material(Json::parse(R"({"bulk_modulus": 1e6, "shear_modulus": 1e6, "offset_yield_stress": 0})")))
            .find("/materials/m/offset_yield_stress") != std::string::npos);
  CHECK(error_in(with_material(Json::parse(R"({"density": 5})"))).find(
            "presets.json: /materials/m: missing keys (got {\"density\":5}; expected either") == 0);
  CHECK(error_in(with_material(Json::parse(R"({"bulk_modulus": 1e6, "shear_modulus": 1e6, "fracture_energy": -1})")))
            .find("/materials/m/fracture_energy") != std::string::npos);
  // Physical keys on their own, and "inf".
  const Scene s = load_scene_text(
      with_material(Json::parse(R"({"bulk_modulus": 1e6, "shear_modulus": 1e6, "fracture_energy": 10,
                                    "yield_stress": "inf"})"))
          .dump(),
      "presets.json");
  CHECK(s.materials[0].fracture_energy == 10);
  CHECK(s.materials[0].yield_stress == 0.0);
  CHECK(std::isinf(s.materials[0].yield_energy));
  const Scene o = load_scene_text(
      with_material(Json::parse(R"({"bulk_modulus": 1e6, "shear_modulus": 1e6, "offset_yield_stress": 2e4})")).dump(),
      "presets.json");
  CHECK(o.materials[0].offset_yield_stress == 2e4);
  CHECK(o.materials[0].yield_stress == 0.0);               // converted at set-up, not here
  CHECK(std::isinf(o.materials[0].plastic_cap_ratio));     // perfect plasticity, as with yield_stress
}

TEST_CASE("strength: the scene keys convert, with region bodies resolved after the bodies") {
  Json j = with_material(Json::parse(R"({"preset": "concrete", "strength": {
      "regions": [ { "region": { "type": "sphere", "center": [0, 0, 0], "radius": 0.02, "body": "block" }, "factor": 0.3 } ],
      "noise": { "amplitude": 0.2, "feature_size": 0.01, "seed": 4 },
      "weak_planes": [ { "polygon": [[0, -1, -1], [0, 1, -1], [0, 1, 1], [0, -1, 1]], "factor": 0.5 } ] }})"));
  j["bodies"][0]["name"] = "block";
  const Scene s = load_scene_text(j.dump(), "presets.json");
  const auto& st = s.materials[0].strength;
  REQUIRE(st.regions.size() == 1);
  CHECK(st.regions[0].factor == 0.3);
  CHECK(st.regions[0].region.body == 0);
  CHECK(st.noise_amplitude == 0.2);
  CHECK(st.noise_seed == 4);
  REQUIRE(st.weak_planes.size() == 1);
  CHECK(st.weak_planes[0].factor == 0.5);
  j["materials"]["m"]["strength"]["weak_planes"][0]["polygon"][3] = Json::array({0.5, -1, 1});
  CHECK(error_in(j).find("/materials/m/strength/weak_planes/0/polygon") != std::string::npos);
  j = with_material(Json::parse(R"({"preset": "glass", "strength": {"noise": {"amplitude": 1.5, "feature_size": 1}}})"));
  CHECK(error_in(j).find("/materials/m/strength/noise/amplitude") != std::string::npos);
}
