// Scene loader: a full scene converts to the expected typed values, defaults are filled, and every
// class of error names the file, the JSON pointer, the bad value and what was expected.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include "perifx/scene.hpp"
#include "scene/schema.hpp"

namespace fs = std::filesystem;
using namespace perifx;
using namespace perifx::scene;
using Json = nlohmann::ordered_json;

#define CHECK_HAS(text, part) \
  CHECK_MESSAGE((text).find(part) != std::string::npos, "message: " << (text) << "\n  lacks: " << (part))

namespace {

// A fresh folder for scene and mesh files, removed afterwards.
struct TempDir {
  fs::path path = fs::temp_directory_path() / ("perifx-scene-test-" + std::to_string(std::random_device{}()));
  TempDir() { fs::create_directories(path); }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  void write(const std::string& name, const std::string& text) const {
    fs::create_directories((path / name).parent_path());
    std::ofstream(path / name) << text;
  }
};

// The smallest valid scene; error tests break one thing in it.
Json minimal() {
  return Json::parse(R"({
    "time": { "dt": 1e-4 },
    "materials": { "steel": { "youngs_modulus": 2e11, "poisson_ratio": 0.3 },
                   "rubber": { "bulk_modulus": 2e7, "shear_modulus": 1e6 } },
    "bodies": [ { "material": "steel", "geometry": { "type": "box", "size": [1, 0.1, 0.1] } } ]
  })");
}

// what() of the SceneError the scene raises, or "<no error>".
std::string error_of(const std::string& text, const fs::path& file = "cases.json") {
  try {
    load_scene_text(text, file);
  } catch (const SceneError& e) {
    return e.what();
  }
  return "<no error>";
}
std::string error_in(const Json& j, const fs::path& file = "cases.json") { return error_of(j.dump(2), file); }

}  // namespace

TEST_CASE("scene: a full scene converts to the expected typed values") {
  TempDir dir;
  dir.write("meshes/beam.node", "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n");
  dir.write("meshes/beam.ele", "1 4 0\n1 1 2 3 4\n");
  dir.write("full.json", R"({
    "name": "everything",
    "description": "exercises every key",
    "_comment": "ignored",
    "threads": 3,
    "gravity": [0, -3.7, 0],
    "time": { "dt": 2e-4, "duration": 2.5, "frame_rate": 30 },
    "model": { "normalization": "discrete", "family": "distance" },
    "materials": {
      "steel": { "density": 7850, "youngs_modulus": 2e11, "poisson_ratio": 0.3,
                 "yield_energy": 5e4, "plastic_cap_ratio": 0.1, "critical_stretch": "infinity",
                 "damage_alpha": 0.5, "damping": 2,
                 "anisotropy": { "axis": [1, 1, 0], "ratio_along": 3, "ratio_across": 0.5 } },
      "_note": "comment keys are not materials",
      "rubber": { "bulk_modulus": 2e7, "shear_modulus": 1e6, "critical_stretch": 0.2,
                  "anisotropy": { "matrix": [[2, 0, 0], [0, 1, 0], [0, 0, 1]] } }
    },
    "bodies": [
      { "name": "beam", "material": "rubber",
        "geometry": { "type": "box", "size": [1, 0.2, 0.3], "edge_length": 0.05 },
        "transform": { "translate": [1, 2, 3], "rotate": { "axis": [0, 0, 5], "degrees": 90 }, "scale": 2 },
        "velocity": [1, 0, 0], "angular_velocity": [0, 0, 1], "horizon": { "length": 0.02 } },
      { "material": "steel", "geometry": { "type": "sphere", "radius": 0.5 }, "horizon": 2 },
      { "name": "rod", "material": "steel",
        "geometry": { "type": "cylinder", "radius": 0.1, "height": 1, "axis": "x", "resolution": 8 },
        "horizon": { "factor": 1.6 } },
      { "name": "mesh", "material": "steel", "geometry": { "type": "tetgen", "path": "meshes/beam.node" } }
    ],
    "boundary_conditions": [
      { "type": "anchor", "region": { "type": "box", "min": [-1, -1, -1], "max": [0, 1, 1], "body": "beam" } },
      { "type": "velocity", "region": { "type": "halfspace", "point": [0, 0, 0], "normal": [0, 0, 2] },
        "velocity": [0, 1, 0], "angular_velocity": [1, 0, 0], "center": [0, 1, 0],
        "start": 0.5, "ramp": 0.25, "end": 2, "axes": ["z", "x"] },
      { "type": "displacement", "region": { "type": "sphere", "center": [1, 1, 1], "radius": 0.5, "body": "rod" },
        "displacement": [0, 0, 0.1], "rotation": { "axis": [0, 3, 0], "degrees": 180 }, "end": "inf" }
    ],
    "colliders": [
      { "type": "plane", "normal": [0, 2, 0], "friction": 0.3, "restitution": 0.5 },
      { "type": "sphere", "center": [0, 5, 0], "radius": 0.25, "velocity": [0, -1, 0] },
      { "type": "box", "center": [1, 0, 0], "size": [2, 4, 6], "rotate": { "axis": [1, 0, 0], "degrees": 90 },
        "angular_velocity": [0, 1, 0] }
    ],
    "output": { "directory": "results/run1", "formats": ["ply"], "fields": ["damage", "velocity"] }
  })");

  const Scene s = load_scene_file(dir.path / "full.json");
  CHECK(s.name == "everything");
  CHECK(s.source == dir.path / "full.json");
  CHECK(s.threads == 3);
  CHECK(s.gravity == Vec3(0, -3.7, 0));
  CHECK(s.time.dt == 2e-4);
  CHECK(s.time.duration == 2.5);
  CHECK(s.time.frame_rate == 30);
  CHECK(s.normalization == Normalization::discrete);
  CHECK(s.family == FamilyRule::distance);

  // Materials keep file order; comment keys are skipped.
  REQUIRE(s.materials.size() == 2);
  const Material& steel = s.materials[0];
  CHECK(steel.name == "steel");
  CHECK(steel.density == 7850);
  const double E = 2e11, nu = 0.3;
  CHECK(steel.bulk_modulus == doctest::Approx(E / (3 * (1 - 2 * nu))).epsilon(1e-14));
  CHECK(steel.shear_modulus == doctest::Approx(E / (2 * (1 + nu))).epsilon(1e-14));
  CHECK(steel.bulk_modulus == doctest::Approx(1.0e11 / 0.6));  // 2e11 / 1.2
  CHECK(steel.shear_modulus == doctest::Approx(2e11 / 2.6));
  CHECK(steel.yield_energy == 5e4);
  CHECK(steel.plastic_cap_ratio == 0.1);
  CHECK(std::isinf(steel.critical_stretch));
  CHECK(steel.damage_alpha == 0.5);
  CHECK(steel.damping == 2);
  // G = 3 a aᵀ + 0.5 (I − a aᵀ), a = (1, 1, 0)/√2: a aᵀ has 0.5 in the top-left 2x2 block.
  Mat3 G;
  G << 1.75, 1.25, 0, 1.25, 1.75, 0, 0, 0, 0.5;
  CHECK((steel.anisotropy - G).norm() < 1e-14);
  const Material& rubber = s.materials[1];
  CHECK(rubber.name == "rubber");
  CHECK(rubber.bulk_modulus == 2e7);
  CHECK(rubber.shear_modulus == 1e6);
  CHECK(rubber.critical_stretch == 0.2);
  CHECK(std::isinf(rubber.yield_energy));
  CHECK(rubber.anisotropy == Vec3(2, 1, 1).asDiagonal().toDenseMatrix());

  REQUIRE(s.bodies.size() == 4);
  const Body& beam = s.bodies[0];
  CHECK(beam.name == "beam");
  CHECK(beam.material == 1);
  CHECK(beam.geometry.kind == Geometry::Kind::box);
  CHECK(beam.geometry.size == Vec3(1, 0.2, 0.3));
  CHECK(beam.geometry.edge_length == 0.05);
  CHECK(beam.geometry.resolution == 0);
  CHECK(beam.transform.translation == Vec3(1, 2, 3));
  CHECK((beam.transform.rotation * Vec3::UnitX() - Vec3::UnitY()).norm() < 1e-15);
  CHECK(beam.transform.scale == 2);
  CHECK(beam.velocity == Vec3(1, 0, 0));
  CHECK(beam.angular_velocity == Vec3(0, 0, 1));
  CHECK(beam.horizon_length == 0.02);
  const Body& ball = s.bodies[1];
  CHECK(ball.name == "body1");
  CHECK(ball.material == 0);
  CHECK(ball.geometry.kind == Geometry::Kind::sphere);
  CHECK(ball.geometry.radius == 0.5);
  CHECK(ball.geometry.resolution == 20);
  CHECK(ball.horizon_factor == 2);
  CHECK(ball.horizon_length == 0);
  const Body& rod = s.bodies[2];
  CHECK(rod.geometry.kind == Geometry::Kind::cylinder);
  CHECK(rod.geometry.axis == 0);
  CHECK(rod.geometry.height == 1);
  CHECK(rod.geometry.resolution == 8);
  CHECK(rod.horizon_factor == 1.6);
  const Body& mesh = s.bodies[3];
  CHECK(mesh.geometry.kind == Geometry::Kind::tetgen);
  CHECK(mesh.geometry.path == fs::absolute(dir.path / "meshes" / "beam.node").lexically_normal());
  CHECK(mesh.geometry.path.is_absolute());

  REQUIRE(s.boundary_conditions.size() == 3);
  const BoundaryCondition& anchor = s.boundary_conditions[0];
  CHECK(anchor.kind == BoundaryCondition::Kind::anchor);
  CHECK(anchor.region.kind == Region::Kind::box);
  CHECK(anchor.region.min == Vec3(-1, -1, -1));
  CHECK(anchor.region.max == Vec3(0, 1, 1));
  CHECK(anchor.region.body == 0);
  CHECK(anchor.window.start == 0);
  CHECK(std::isinf(anchor.window.end));
  CHECK(anchor.axes == std::array<bool, 3>{true, true, true});  // default: every axis
  const BoundaryCondition& push = s.boundary_conditions[1];
  CHECK(push.kind == BoundaryCondition::Kind::velocity);
  CHECK(push.region.kind == Region::Kind::halfspace);
  CHECK(push.region.normal == Vec3(0, 0, 1));
  CHECK(push.region.body == -1);
  CHECK(push.velocity == Vec3(0, 1, 0));
  CHECK(push.angular_velocity == Vec3(1, 0, 0));
  CHECK(push.center == Vec3(0, 1, 0));
  CHECK(push.window.start == 0.5);
  CHECK(push.window.ramp == 0.25);
  CHECK(push.window.end == 2);
  CHECK(push.axes == std::array<bool, 3>{true, false, true});
  const BoundaryCondition& twist = s.boundary_conditions[2];
  CHECK(twist.kind == BoundaryCondition::Kind::displacement);
  CHECK(twist.region.kind == Region::Kind::sphere);
  CHECK(twist.region.center == Vec3(1, 1, 1));
  CHECK(twist.region.radius == 0.5);
  CHECK(twist.region.body == 2);
  CHECK(twist.displacement == Vec3(0, 0, 0.1));
  CHECK(twist.rotation_axis == Vec3(0, 1, 0));
  CHECK(twist.rotation_angle == doctest::Approx(kPi));
  CHECK(std::isinf(twist.window.end));

  REQUIRE(s.colliders.size() == 3);
  CHECK(s.colliders[0].kind == Collider::Kind::plane);
  CHECK(s.colliders[0].point == Vec3::Zero());
  CHECK(s.colliders[0].normal == Vec3(0, 1, 0));
  CHECK(s.colliders[0].friction == 0.3);
  CHECK(s.colliders[0].restitution == 0.5);
  CHECK(s.colliders[1].kind == Collider::Kind::sphere);
  CHECK(s.colliders[1].center == Vec3(0, 5, 0));
  CHECK(s.colliders[1].radius == 0.25);
  CHECK(s.colliders[1].velocity == Vec3(0, -1, 0));
  CHECK(s.colliders[2].kind == Collider::Kind::box);
  CHECK(s.colliders[2].half_extents == Vec3(1, 2, 3));
  CHECK((s.colliders[2].orientation * Vec3::UnitY() - Vec3::UnitZ()).norm() < 1e-15);
  CHECK(s.colliders[2].angular_velocity == Vec3(0, 1, 0));

  CHECK(s.output.directory == (fs::current_path() / "results" / "run1"));
  CHECK_FALSE(s.output.vtu);
  CHECK(s.output.ply);
  CHECK(s.output.fields == std::vector<std::string>{"damage", "velocity"});
}

TEST_CASE("scene: omitted keys take their documented defaults") {
  const Scene s = load_scene_text(minimal().dump(), "some/dir/minimal.json");
  CHECK(s.name == "minimal");  // the file stem
  CHECK(s.threads == 0);
  CHECK(s.gravity == Vec3(0, -9.81, 0));
  CHECK(s.time.duration == 1.0);
  CHECK(s.time.frame_rate == 24.0);
  CHECK(s.normalization == Normalization::corrected);
  CHECK(s.family == FamilyRule::mesh);
  const Material& m = s.materials[0];
  CHECK(m.density == 1000);
  CHECK(std::isinf(m.yield_energy));
  CHECK(std::isinf(m.critical_stretch));
  CHECK(m.plastic_cap_ratio == 0);
  CHECK(m.damage_alpha == 0);
  CHECK(m.damping == 0);
  CHECK(m.anisotropy == Mat3::Identity());
  const Body& b = s.bodies[0];
  CHECK(b.name == "body0");
  CHECK(b.geometry.resolution == 20);
  CHECK(b.geometry.edge_length == 0);
  CHECK(b.transform.translation == Vec3::Zero());
  CHECK(b.transform.rotation == Mat3::Identity());
  CHECK(b.transform.scale == 1);
  CHECK(b.velocity == Vec3::Zero());
  CHECK(b.horizon_factor == 1.45);
  CHECK(b.horizon_length == 0);
  CHECK(s.boundary_conditions.empty());
  CHECK(s.colliders.empty());
  CHECK(s.output.directory == fs::current_path() / "out");
  CHECK(s.output.vtu);
  CHECK(s.output.ply);
  CHECK(s.output.fields.empty());

  Json j = minimal();
  j["bodies"][0]["geometry"] = Json::parse(R"({"type": "cylinder", "radius": 1, "height": 2})");
  j["colliders"] = Json::parse(R"([{"type": "plane"}])");
  const Scene c = load_scene_text(j.dump(), "c.json");
  CHECK(c.bodies[0].geometry.axis == 1);  // "y"
  CHECK(c.colliders[0].normal == Vec3::UnitY());
  CHECK(c.colliders[0].restitution == 0);
}

TEST_CASE("scene: \"inf\" spellings and comment keys") {
  Json j = minimal();
  j["materials"]["steel"]["yield_energy"] = "Infinity";
  j["materials"]["steel"]["critical_stretch"] = "inf";
  j["materials"]["steel"]["_why"] = "notes are allowed anywhere";
  j["bodies"][0]["geometry"]["_note"] = 1;
  const Scene s = load_scene_text(j.dump(), "inf.json");
  CHECK(std::isinf(s.materials[0].yield_energy));
  CHECK(std::isinf(s.materials[0].critical_stretch));

  j["materials"]["steel"]["critical_stretch"] = "huge";
  CHECK(error_in(j) == "cases.json: /materials/steel/critical_stretch: wrong type "
                       "(got \"huge\"; expected a number > 0 or \"inf\")");
}

TEST_CASE("scene: malformed JSON names line and column") {
  const std::string text = "{\n  \"time\": { \"dt\": 1e-4 },\n  \"materials\": {,}\n}";
  const std::string e = error_of(text, "broken.json");
  CHECK_HAS(e, "broken.json: line 3, column 17: invalid JSON: ");
  CHECK_HAS(e, "unexpected ','");
  // Our line/column come from the byte offset; nlohmann's own report must agree.
  try {
    const Json parsed = Json::parse(text);
    FAIL("nlohmann accepted it: " << parsed.dump());
  } catch (const Json::parse_error& p) {
    CHECK_HAS(std::string(p.what()), "line 3, column 17");
  }
  const std::string c = error_of("{\n  // a comment\n  \"a\": 1\n}", "c.json");
  CHECK_HAS(c, "c.json: line 2, column 3: invalid JSON");
  CHECK_HAS(c, "comments are not allowed in JSON; use a \"_comment\" key");
  CHECK_HAS(error_of("{\"a\": 1e999}", "o.json"), "o.json: invalid JSON: number overflow parsing '1e999'");
}

TEST_CASE("scene: wrong types") {
  Json j = minimal();
  j["materials"]["steel"]["density"] = "abc";
  CHECK(error_in(j) == "cases.json: /materials/steel/density: wrong type (got \"abc\"; expected a number in [0.001, 1000000])");
  j = minimal();
  j["gravity"] = Json::array({0, -9.81});
  CHECK(error_in(j) == "cases.json: /gravity: wrong type (got [0,-9.81]; expected an array of 3 numbers)");
  j = minimal();
  j["threads"] = 2.5;
  CHECK(error_in(j) == "cases.json: /threads: wrong type (got 2.5; expected an integer >= 0)");
  j = minimal();
  j["bodies"][0]["horizon"] = true;
  CHECK(error_in(j) == "cases.json: /bodies/0/horizon: wrong type (got true; expected a number in (0, 20] or an "
                       "object with either 'factor' or 'length')");
  j = minimal();
  j["bodies"][0]["geometry"]["type"] = "cube";
  CHECK_HAS(error_in(j), "cases.json: /bodies/0/geometry/type: invalid value (got \"cube\"; expected one of "
                         "\"box\", \"sphere\", \"cylinder\", \"tetgen\", \"gmsh\", \"surface\")");
  CHECK(error_of("[1, 2]", "arr.json") == "arr.json: the scene must be a JSON object (got [1,2]; expected an object)");
}

TEST_CASE("scene: out of range") {
  Json j = minimal();
  j["materials"]["steel"]["density"] = -5;
  CHECK(error_in(j) == "cases.json: /materials/steel/density: out of range (got -5; expected a number in [0.001, 1000000])");
  j = minimal();
  j["materials"]["steel"]["poisson_ratio"] = 0.5;
  CHECK(error_in(j) == "cases.json: /materials/steel/poisson_ratio: out of range (got 0.5; expected a number "
                       "in (-1, 0.5))");
  j = minimal();
  j["bodies"][0]["geometry"]["size"] = Json::array({1, 0, 1});
  CHECK(error_in(j) == "cases.json: /bodies/0/geometry/size: out of range (got [1,0,1]; expected an array of 3 "
                       "numbers, each > 0)");
  j = minimal();
  j["colliders"] = Json::parse(R"([{"type": "plane", "restitution": 1.5}])");
  CHECK(error_in(j) == "cases.json: /colliders/0/restitution: out of range (got 1.5; expected a number in [0, 1])");
  j = minimal();
  j["colliders"] = Json::parse(R"([{"type": "plane", "normal": [0, 0, 0]}])");
  CHECK_HAS(error_in(j), "/colliders/0/normal: zero vector (got [0,0,0]; expected an array of 3 numbers, not all zero)");
  j = minimal();
  j["time"]["dt"] = 2;
  CHECK(error_in(j) == "cases.json: /time/dt: time step longer than the duration (got 2; expected at most "
                       "duration = 1)");
}

TEST_CASE("scene: unknown and misplaced keys") {
  Json j = minimal();
  j["materials"]["steel"]["densty"] = 1000;
  CHECK(error_in(j) == "cases.json: /materials/steel/densty: unknown key 'densty'; did you mean 'density'?");
  j = minimal();
  j["time"]["xyzzy"] = 1;
  CHECK(error_in(j) == "cases.json: /time/xyzzy: unknown key 'xyzzy' (expected one of: dt, duration, frame_rate)");
  j = minimal();
  j["bodies"][0]["geometry"]["radius"] = 1;
  CHECK(error_in(j) == "cases.json: /bodies/0/geometry/radius: key 'radius' is not used by geometry type 'box' "
                       "(used by: sphere, cylinder)");
  j = minimal();
  j["boundary_conditions"] = Json::parse(R"([{"type": "anchor", "region": {"type": "all"}, "velocity": [0, 1, 0]}])");
  CHECK_HAS(error_in(j), "/boundary_conditions/0/velocity: key 'velocity' is not used by boundary condition type "
                         "'anchor' (used by: velocity)");
  j = minimal();
  j["boundary_conditions"] = Json::parse(R"([{"type": "anchor", "region": {"type": "all"}, "axes": ["x", "w"]}])");
  CHECK_HAS(error_in(j), "/boundary_conditions/0/axes: invalid entry 'w'");
  j["boundary_conditions"][0]["axes"] = Json::array();
  CHECK_HAS(error_in(j), "/boundary_conditions/0/axes: too few entries");
  j["boundary_conditions"][0]["axes"] = Json::parse(R"(["y", "y"])");
  CHECK_HAS(error_in(j), "/boundary_conditions/0/axes: duplicate entry 'y'");
  CHECK_HAS(error_of(R"({"a": 1, "a": 2})", "dup.json"), "dup.json: /a: duplicate key 'a'");
  j = minimal();
  const std::string text = j.dump();  // splice a second "steel" into the materials object
  const std::string twice = text.substr(0, text.find("\"rubber\"")) + R"("steel": {"density": 1}, )" +
                            text.substr(text.find("\"rubber\""));
  CHECK_HAS(error_of(twice), "cases.json: /materials/steel: duplicate key 'steel'");
}

TEST_CASE("scene: the time step is \"auto\" when not given, and only a number or \"auto\" otherwise") {
  Json j = minimal();
  CHECK(!load_scene_text(j.dump(), "cases.json").time.auto_dt);
  for (const Json& dt : {Json("auto"), Json("AUTO"), Json()}) {  // given (any letter case) or left out
    j = minimal();
    if (dt.is_null()) j["time"].erase("dt");
    else j["time"]["dt"] = dt;
    const Scene s = load_scene_text(j.dump(), "cases.json");
    CHECK(s.time.auto_dt);
    CHECK(s.time.dt == 0.0);  // a World picks it (test_world.cpp)
  }
  j = minimal();
  j.erase("time");  // every time key has a default now
  const Scene s = load_scene_text(j.dump(), "cases.json");
  CHECK(s.time.auto_dt);
  CHECK(s.time.duration == 1.0);
  CHECK(s.time.frame_rate == 24.0);
  j = minimal();
  j["time"]["dt"] = "fast";
  CHECK(error_in(j) == "cases.json: /time/dt: wrong type (got \"fast\"; expected a number > 0 or \"auto\")");
  j = minimal();  // an automatic step still needs frames that fit in the duration
  j["time"] = Json::parse(R"({"dt": "auto", "duration": 0.01, "frame_rate": 24})");
  CHECK_HAS(error_in(j), "cases.json: /time/frame_rate: no frame in the duration");
}

TEST_CASE("scene: the contact time scale is \"auto\" (0 until set-up) or seconds > 0") {
  Json j = minimal();
  CHECK(load_scene_text(j.dump(), "cases.json").contact.time_scale == 0.0);
  j["contact"] = Json::parse(R"({"time_scale": "auto"})");
  CHECK(load_scene_text(j.dump(), "cases.json").contact.time_scale == 0.0);
  j["contact"]["time_scale"] = 2.5e-5;
  CHECK(load_scene_text(j.dump(), "cases.json").contact.time_scale == 2.5e-5);
  j["contact"]["time_scale"] = 0;
  CHECK(error_in(j) == "cases.json: /contact/time_scale: out of range (got 0; expected a number > 0 or \"auto\")");
}

TEST_CASE("scene: missing keys") {
  Json j = minimal();
  j["bodies"][0]["geometry"].erase("size");
  CHECK(error_in(j) == "cases.json: /bodies/0/geometry/size: missing required key 'size' for geometry type 'box' "
                       "(expected an array of 3 numbers, each > 0)");
  j = minimal();
  j.erase("bodies");
  CHECK(error_in(j) == "cases.json: /bodies: missing required key 'bodies' (expected an array of body objects, at "
                       "least 1)");
  j = minimal();
  j["materials"]["steel"].erase("poisson_ratio");
  CHECK(error_in(j) == "cases.json: /materials/steel/poisson_ratio: missing key 'poisson_ratio', which goes with "
                       "'youngs_modulus' (expected either 'bulk_modulus' + 'shear_modulus' or 'youngs_modulus' + "
                       "'poisson_ratio')");
  j = minimal();
  j["materials"]["steel"] = Json::parse(R"({"density": 1})");
  CHECK_HAS(error_in(j), "cases.json: /materials/steel: missing keys (got {\"density\":1}; expected either");
}

TEST_CASE("scene: both (kappa, mu) and (E, nu)") {
  Json j = minimal();
  j["materials"]["steel"]["bulk_modulus"] = 1e9;
  j["materials"]["steel"]["shear_modulus"] = 1e9;
  CHECK(error_in(j) == "cases.json: /materials/steel/youngs_modulus: 'bulk_modulus' and 'youngs_modulus' cannot "
                       "both be given (expected either 'bulk_modulus' + 'shear_modulus' or 'youngs_modulus' + "
                       "'poisson_ratio')");
}

TEST_CASE("scene: references and files") {
  Json j = minimal();
  j["bodies"][0]["material"] = "stel";
  CHECK(error_in(j) == "cases.json: /bodies/0/material: unknown material; did you mean 'steel'? (got \"stel\"; "
                       "expected one of the defined materials: steel, rubber)");
  j = minimal();
  j["boundary_conditions"] = Json::parse(R"([{"type": "anchor", "region": {"type": "all", "body": "wall"}}])");
  CHECK(error_in(j) == "cases.json: /boundary_conditions/0/region/body: unknown body (got \"wall\"; expected one "
                       "of the defined bodies: body0)");
  j = minimal();
  const Json first = j["bodies"][0];
  j["bodies"].push_back(first);
  j["bodies"][0]["name"] = "body1";  // the second one defaults to "body1" too
  CHECK_HAS(error_in(j), "cases.json: /bodies/1/name: duplicate body name (got \"body1\"");

  TempDir dir;
  const fs::path file = dir.path / "scene.json";
  j = minimal();
  j["bodies"][0]["geometry"] = Json::parse(R"({"type": "tetgen", "path": "meshes/part.node"})");
  const std::string node = (dir.path / "meshes" / "part.node").string();
  CHECK(error_in(j, file) == file.string() + ": /bodies/0/geometry/path: mesh file not found: " + node +
                                 " (got \"meshes/part.node\"; expected a TetGen .node file, with its .ele beside it, "
                                 "relative to " + dir.path.string() + ")");
  dir.write("meshes/part.node", "0 3 0 0\n");
  CHECK_HAS(error_in(j, file), "mesh file not found: " + (dir.path / "meshes" / "part.ele").string());
  dir.write("meshes/part.ele", "0 4 0\n");
  CHECK(error_in(j, file) == "<no error>");

  CHECK_HAS(error_in(j, dir.path / "absent.json"), "<no error>");  // text given, file need not exist
  try {
    load_scene_file(dir.path / "absent.json");
    FAIL("no error");
  } catch (const SceneError& e) {
    CHECK_HAS(std::string(e.what()), "absent.json: cannot open the scene file");
  }
}

TEST_CASE("scene: cross-key checks") {
  Json j = minimal();
  j["materials"]["steel"]["anisotropy"] = Json::parse(R"({"matrix": [[1, 2, 3], [2, 4, 6], [0, 0, 1]]})");
  CHECK(error_in(j) == "cases.json: /materials/steel/anisotropy/matrix: singular matrix (got [[1,2,3],[2,4,6],"
                       "[0,0,1]]; expected an invertible 3x3 matrix)");
  j = minimal();
  j["materials"]["steel"]["anisotropy"] = Json::parse(R"({"matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "axis": [1, 0, 0]})");
  CHECK_HAS(error_in(j), "/materials/steel/anisotropy/axis: 'matrix' and 'axis' cannot both be given");
  j = minimal();
  j["boundary_conditions"] = Json::parse(
      R"([{"type": "anchor", "region": {"type": "box", "min": [0, 0, 0], "max": [1, 0, 1]}}])");
  CHECK(error_in(j) == "cases.json: /boundary_conditions/0/region/max: empty box (got [1,0,1]; expected greater "
                       "than min = [0,0,0] in every component)");
  j = minimal();
  j["boundary_conditions"] = Json::parse(R"([{"type": "anchor", "region": {"type": "all"}, "start": 2, "end": 1}])");
  CHECK(error_in(j) == "cases.json: /boundary_conditions/0/end: ends before it starts (got 1; expected a time "
                       "after start = 2)");
}

TEST_CASE("scene: SceneError keeps its parts") {
  Json j = minimal();
  j["materials"]["steel"]["density"] = -5;
  try {
    load_scene_text(j.dump(), "parts.json");
    FAIL("no error");
  } catch (const SceneError& e) {
    CHECK(e.file() == "parts.json");
    CHECK(e.pointer() == "/materials/steel/density");
    CHECK(e.message() == "out of range (got -5; expected a number in [0.001, 1000000])");
  }
}

TEST_CASE("scene: the documented example loads") {
  const Scene s = load_scene_text(detail::example_scene(), "example.json");
  CHECK(s.name == "cantilever");
  CHECK(s.bodies.size() == 2);
  CHECK(s.bodies[1].geometry.edge_length == 0.01);
  CHECK(s.materials[1].anisotropy == Vec3(2, 1, 1).asDiagonal().toDenseMatrix());
}

TEST_CASE("scene: assets/scenes/FORMAT.md is the generated reference") {
  const fs::path path = fs::path(PERIFX_SOURCE_DIR) / "assets" / "scenes" / "FORMAT.md";
  std::ifstream in(path, std::ios::binary);
  REQUIRE_MESSAGE(in, "cannot read " << path);
  std::ostringstream text;
  text << in.rdbuf();
  // On failure, regenerate the file from scene_format_markdown() (e.g. `perifx spec`).
  CHECK(text.str() == scene_format_markdown());
  for (const char* word : {"/materials/<name>/critical_stretch", "\"inf\"", "_comment", "Y is up"})
    CHECK_HAS(text.str(), word);
}

namespace {
// Invariants the validator relies on: group members and only_for types name real keys and choices.
void check_spec(const detail::Key& k, const std::string& path) {
  const auto find = [&](const std::string& name) -> const detail::Key* {
    for (const auto& c : k.keys)
      if (c.name == name) return &c;
    return nullptr;
  };
  for (const auto& group : k.groups)
    for (const auto& name : group) CHECK_MESSAGE(find(name), path << ": group member '" << name << "' is not a key");
  const detail::Key* type = find("type");
  for (const auto& c : k.keys) {
    for (const auto& t : c.only_for) {
      REQUIRE_MESSAGE(type, path << "/" << c.name << ": only_for without a 'type' key");
      CHECK_MESSAGE(std::count(type->choices.begin(), type->choices.end(), t) == 1,
                    path << "/" << c.name << ": only_for '" << t << "' is not a type");
    }
    CHECK_MESSAGE(!(c.required && !c.default_value.is_null()), path << "/" << c.name << ": required with a default");
    check_spec(c, path + "/" + c.name);
  }
}
}  // namespace

TEST_CASE("scene: the spec table is self-consistent") { check_spec(detail::scene_spec(), ""); }

TEST_CASE("scene: output field names are checked against the systems' field registry") {
  Json j = minimal();
  j["output"]["fields"] = Json::array({"velocity", "damag"});
  const std::string msg = error_in(j);
  CHECK_HAS(msg, "cases.json: /output/fields/1: unknown particle field (got \"damag\"");
  CHECK_HAS(msg, "expected one of position, velocity, displacement");
  CHECK(msg.find('\n') == std::string::npos);
  j["output"]["fields"] = Json::array({"velocity", "damage", "fragment_id"});
  CHECK(error_in(j) == "<no error>");
}

TEST_CASE("scene: loads convert, and their errors name the pointer, the value and the expectation") {
  Json j = minimal();
  j["loads"] = Json::parse(R"([
    {"type": "traction", "traction": 2e5, "region": {"type": "halfspace", "point": [0.5, 0, 0], "normal": [1, 0, 0]},
     "ramp": 0.01, "end": 0.2},
    {"type": "traction", "traction": 1e3, "direction": [0, 2, 0], "body": "body0"},
    {"type": "body_force", "force_density": [0, 10, 0], "start": 0.1},
    {"type": "blast", "center": [0, 1, 0], "pressure": 1e6, "radius": 0.1, "duration": 1e-3, "front_speed": 340},
    {"type": "radial_impulse", "center": [0, 1, 0], "impulse": 50, "radius": 0.2},
    {"type": "directional", "velocity": [20, 0, 0], "quadratic_drag": 0.6},
    {"type": "noise", "amplitude": 4, "feature_size": 0.3, "speed": 2, "direction": [0, 0, 3], "seed": 9}
  ])");
  const Scene s = load_scene_text(j.dump(), "loads.json");
  REQUIRE(s.loads.size() == 7);
  using K = Load::Kind;
  CHECK(s.loads[0].kind == K::traction);
  CHECK(s.loads[0].along_normal);
  CHECK(s.loads[0].region.kind == Region::Kind::halfspace);
  CHECK(s.loads[0].window.ramp == 0.01);
  CHECK(s.loads[0].window.end == 0.2);
  CHECK(!s.loads[1].along_normal);
  CHECK(s.loads[1].direction == Vec3(0, 1, 0));
  CHECK(s.loads[1].region.body == 0);
  CHECK(s.loads[2].per_volume);
  CHECK(s.loads[2].window.end == kInfinity);
  CHECK(s.loads[3].falloff == 2.0);
  CHECK(s.loads[3].front_speed == 340);
  CHECK(s.loads[4].kind == K::radial_impulse);
  CHECK(s.loads[4].duration == 0.0);
  CHECK(s.loads[4].front_speed == kInfinity);
  CHECK(s.loads[5].drag == 0.0);
  CHECK(s.loads[5].quadratic_drag == 0.6);
  CHECK(s.loads[6].direction == Vec3(0, 0, 1));
  CHECK(s.loads[6].seed == 9);
  CHECK(!s.loads[6].per_volume);

  const auto with = [&](const char* load) {
    Json k = minimal();
    k["loads"] = Json::array({Json::parse(load)});
    return error_in(k);
  };
  CHECK(with(R"({"type": "traction", "traction": 1, "start": 2, "end": 1})") ==
        "cases.json: /loads/0/end: ends before it starts (got 1; expected a time after start = 2)");
  CHECK(with(R"({"type": "body_force", "acceleration": [0, 1, 0], "force_density": [0, 1, 0]})") ==
        "cases.json: /loads/0: body force needs exactly one of 'acceleration' (m/s²) and 'force_density' (N/m³) "
        "(got both)");
  CHECK_HAS(with(R"({"type": "body_force"})"), "/loads/0: body force needs exactly one of");
  CHECK(with(R"({"type": "blast", "center": [0, 0, 0], "pressure": 1, "radius": 1})") ==
        "cases.json: /loads/0/duration: a blast needs a pulse length (got 0; expected a duration > 0 s, or use "
        "radial_impulse for an instantaneous one)");
  CHECK_HAS(with(R"({"type": "noise", "amplitude": 1, "feature_size": 1, "pressure": 3})"),
            "/loads/0/pressure: key 'pressure' is not used by load type 'noise'");
  CHECK_HAS(with(R"({"type": "directional", "velocity": [1, 0, 0]})"), "/loads/0/drag: no drag");
  CHECK_HAS(with(R"({"type": "traction", "traction": 1, "body": "nobody"})"), "/loads/0/body: unknown body");
  CHECK_HAS(with(R"({"type": "wind", "velocity": [1, 0, 0]})"), "/loads/0/type:");
  CHECK_HAS(with(R"({"type": "noise", "amplitude": -1, "feature_size": 1})"), "/loads/0/amplitude: out of range");
}

TEST_CASE("elastic moduli: (E, nu) and (bulk, shear) convert into each other") {
  // Steel by hand: κ = E / (3 (1 − 2ν)) = 2e11 / 1.2, μ = E / (2 (1 + ν)) = 2e11 / 2.6.
  CHECK(perifx::bulk_modulus(2e11, 0.3) == doctest::Approx(2e11 / 1.2).epsilon(1e-15));
  CHECK(perifx::shear_modulus(2e11, 0.3) == doctest::Approx(2e11 / 2.6).epsilon(1e-15));
  // κ = μ: E = 9μ/4 and ν = 1/8 (9κμ/(3κ+μ) and (3κ−2μ)/(2(3κ+μ)) with κ = μ = 1).
  static_assert(perifx::youngs_modulus(1.0, 1.0) == 2.25);
  static_assert(perifx::poisson_ratio(1.0, 1.0) == 0.125);
  // Round trips over the whole admissible range of ν, to a few ulps.
  for (const double nu : {-0.9, -0.3, 0.0, 0.1, 0.25, 0.4, 0.49}) {
    const double E = 3.7e7, kappa = perifx::bulk_modulus(E, nu), mu = perifx::shear_modulus(E, nu);
    CHECK(perifx::youngs_modulus(kappa, mu) == doctest::Approx(E).epsilon(1e-14));
    CHECK(perifx::poisson_ratio(kappa, mu) == doctest::Approx(nu).epsilon(1e-13).scale(1.0));
  }
}
