// Scene loading: parse (with line:column errors and duplicate-key detection), validate against the
// spec (schema.cpp), then convert the validated JSON into the typed Scene. The converter only
// performs checks the per-key spec cannot express: cross-key relations, name references, files.
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <sstream>
#include <unordered_set>
#include <utility>

#include "perifx/scene.hpp"
#include "systems/field_registry.hpp"
#include "scene/presets.hpp"
#include "scene/schema.hpp"

namespace fs = std::filesystem;

namespace perifx::scene {

namespace {

using detail::Json;
using detail::child_pointer;
using detail::show;

// nlohmann reports a byte offset (1-based, the offending byte); people want line and column.
std::pair<std::size_t, std::size_t> line_column(const std::string& text, std::size_t byte) {
  const std::size_t at = std::min(byte > 0 ? byte - 1 : 0, text.size());
  std::size_t line = 1, line_start = 0;
  for (std::size_t i = 0; i < at; ++i)
    if (text[i] == '\n') ++line, line_start = i + 1;
  return {line, at - line_start + 1};
}

// Checks nlohmann's recursive parser cannot be driven into a stack overflow, and that nothing but
// whitespace follows the document: a scan of the raw text (strings skipped) for nesting deeper than
// kMaxDepth, for more than kMaxMembers object keys in all, and for NUL bytes (nlohmann stops at a NUL as if the text ended there).
constexpr int kMaxDepth = 64;
constexpr std::size_t kMaxMembers = 20000;

void prescan(const std::string& text, const std::string& file) {
  int depth = 0;
  std::size_t members = 0;
  bool in_string = false, escaped = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    auto at = [&] {
      const auto [line, column] = line_column(text, i + 1);
      return "line " + std::to_string(line) + ", column " + std::to_string(column) + ": ";
    };
    if (c == '\0')
      throw SceneError(file, "", at() + "NUL byte in the scene file (got byte 0; expected a text file holding one "
                                        "JSON document)");
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
      continue;
    }
    if (c == '"') in_string = true;
    else if (c == ':' && ++members > kMaxMembers)
      // nlohmann's ordered objects find keys linearly: a huge object would take minutes to read.
      throw SceneError(file, "", at() + "too many object keys (got more than " + std::to_string(kMaxMembers) +
                                     "; expected a scene, which needs a few hundred)");
    else if (c == '[' || c == '{') {
      if (++depth > kMaxDepth)
        throw SceneError(file, "", at() + "JSON nested too deeply (got more than " + std::to_string(kMaxDepth) +
                                       " levels of arrays/objects; expected a scene, which needs fewer than 10)");
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
}

Json parse(const std::string& text, const std::string& file) {
  prescan(text, file);
  // Duplicate keys are legal JSON but nlohmann silently keeps the last one, which would hide
  // e.g. two materials of the same name. A parser callback tracks the path to report them.
  struct Frame {
    bool array;
    std::size_t index = 0;  // array: the element being parsed
    std::string key;        // object: the member being parsed
    std::unordered_set<std::string> seen;
  };
  std::vector<Frame> stack;
  const auto pointer = [&] {
    std::string p;
    for (std::size_t i = 0; i + 1 < stack.size(); ++i)
      p = stack[i].array ? p + "/" + std::to_string(stack[i].index) : child_pointer(p, stack[i].key);
    return p;
  };
  const Json::parser_callback_t callback = [&](int, Json::parse_event_t event, Json& parsed) {
    switch (event) {
      case Json::parse_event_t::object_start: stack.push_back({false, 0, {}, {}}); break;
      case Json::parse_event_t::array_start: stack.push_back({true, 0, {}, {}}); break;
      case Json::parse_event_t::key: {
        Frame& f = stack.back();
        f.key = parsed.get<std::string>();
        if (!f.seen.insert(f.key).second)
          throw SceneError(file, child_pointer(pointer(), f.key),
                           "duplicate key '" + detail::cut(f.key) + "' (expected each key once per object)");
        break;
      }
      case Json::parse_event_t::object_end:
      case Json::parse_event_t::array_end:
        stack.pop_back();
        if (!stack.empty() && stack.back().array) ++stack.back().index;
        break;
      case Json::parse_event_t::value:
        if (!stack.empty() && stack.back().array) ++stack.back().index;
        break;
    }
    return true;
  };
  try {
    return Json::parse(text, callback);
  } catch (const Json::parse_error& e) {
    const auto [line, column] = line_column(text, e.byte);
    // what() is "[json.exception.parse_error.101] parse error at line L, column C: <reason>";
    // keep only the reason, the position is ours.
    std::string reason = e.what();
    if (const auto at = reason.find("column"); at != std::string::npos) {
      if (const auto colon = reason.find(": ", at); colon != std::string::npos) reason = reason.substr(colon + 2);
    }
    const std::size_t at = e.byte > 0 ? e.byte - 1 : 0;
    const bool comment = at < text.size() && text[at] == '/';
    throw SceneError(file, "",
                     "line " + std::to_string(line) + ", column " + std::to_string(column) +
                         ": invalid JSON: " + reason +
                         (comment ? " (comments are not allowed in JSON; use a \"_comment\" key)" : ""));
  } catch (const Json::out_of_range& e) {
    // Number literals beyond the double range (1e999); nlohmann gives no position for these.
    std::string reason = e.what();
    if (const auto at = reason.find("] "); at != std::string::npos) reason = reason.substr(at + 2);
    throw SceneError(file, "", "invalid JSON: " + reason + " (expected finite numbers)");
  }
}

class Converter {
 public:
  Converter(std::string file, fs::path folder) : file_(std::move(file)), folder_(std::move(folder)) {}

  Scene run(const Json& j, const fs::path& source) {
    Scene s;
    s.source = source;
    s.name = j.contains("name") ? j["name"].get<std::string>() : source.stem().string();
    s.threads = j["threads"].get<int>();
    s.gravity = vec(j["gravity"]);

    const Json& t = j["time"];
    s.time.auto_dt = t["dt"].is_string();  // "auto" (the validator let no other string through)
    s.time.dt = s.time.auto_dt ? 0.0 : num(t["dt"]);
    s.time.duration = num(t["duration"]);
    s.time.frame_rate = num(t["frame_rate"]);
    if (!s.time.auto_dt && s.time.dt > s.time.duration)
      fail("/time/dt", "time step longer than the duration (got " + show(t["dt"]) +
                           "; expected at most duration = " + show(t["duration"]) + ")");
    check_time(s);

    s.normalization = j["model"]["normalization"] == "paper"      ? Normalization::paper
                      : j["model"]["normalization"] == "discrete" ? Normalization::discrete
                                                                  : Normalization::corrected;
    s.family = j["model"]["family"] == "mesh" ? FamilyRule::mesh : FamilyRule::distance;
    {
      const std::string solver = j["model"]["solver"].get<std::string>();
      s.solver = solver == "fem_linear"      ? Solver::fem_linear
                 : solver == "fem_corotated" ? Solver::fem_corotated
                                             : Solver::peridynamics;
    }

    for (const auto& [name, m] : j["materials"].items())
      if (name.front() != '_') s.materials.push_back(material(name, m, child_pointer("/materials", name)));
    for (const auto& m : s.materials) material_names_.push_back(m.name);

    const Json& bodies = j["bodies"];
    for (std::size_t i = 0; i < bodies.size(); ++i) {
      const std::string p = "/bodies/" + std::to_string(i);
      s.bodies.push_back(body(bodies[i], p, i));
      const std::string& name = s.bodies.back().name;
      if (std::find(body_names_.begin(), body_names_.end(), name) != body_names_.end())
        fail(p + "/name", "duplicate body name (got " + show(Json(name)) + "; expected a name not used by another body)");
      body_names_.push_back(name);
    }
    {
      std::size_t index = 0;
      for (const auto& [name, m] : j["materials"].items()) {
        if (name.front() == '_') continue;
        if (m.contains("strength"))
          s.materials[index].strength = strength(m["strength"], child_pointer("/materials", name) + "/strength");
        ++index;
      }
    }

    const Json& conditions = j["boundary_conditions"];
    for (std::size_t i = 0; i < conditions.size(); ++i)
      s.boundary_conditions.push_back(condition(conditions[i], "/boundary_conditions/" + std::to_string(i)));
    const Json& loads = j["loads"];
    for (std::size_t i = 0; i < loads.size(); ++i) s.loads.push_back(load(loads[i], "/loads/" + std::to_string(i)));
    const Json& colliders = j["colliders"];
    for (std::size_t i = 0; i < colliders.size(); ++i) s.colliders.push_back(collider(colliders[i]));
    const Json& dj = j["distributed"];
    s.distributed.rebalance_drift = num(dj["rebalance_drift"]);
    s.distributed.rebalance_interval = dj["rebalance_interval"].get<std::uint64_t>();
    const Json& ct = j["contact"];
    if (ct.contains("enabled")) s.contact.mode = ct["enabled"].get<bool>() ? Contact::Mode::on : Contact::Mode::off;
    s.contact.distance_factor = num(ct["distance_factor"]);
    s.contact.stiffness_factor = num(ct["stiffness_factor"]);
    s.contact.time_scale = ct["time_scale"].is_string() ? 0.0 : num(ct["time_scale"]);  // "auto" → 0
    s.contact.damping_ratio = num(ct["damping_ratio"]);
    s.contact.friction = num(ct["friction"]);
    for (const Json& pj : j["projectiles"]) {
      Projectile pr;
      pr.center = vec(pj["center"]);
      pr.radius = num(pj["radius"]);
      pr.mass = pj.contains("mass") ? num(pj["mass"])
                                    : num(pj["density"]) * 4.0 / 3.0 * kPi * pr.radius * pr.radius * pr.radius;
      pr.velocity = vec(pj["velocity"]);
      pr.angular_velocity = vec(pj["angular_velocity"]);
      pr.friction = num(pj["friction"]);
      s.projectiles.push_back(pr);
    }
    const Json& cracks = j["cracks"];
    for (std::size_t i = 0; i < cracks.size(); ++i)
      s.cracks.push_back(crack(cracks[i], "/cracks/" + std::to_string(i) + "/polygon"));

    const Json& o = j["output"];
    s.output.directory = fs::absolute(fs::path(o["directory"].get<std::string>())).lexically_normal();
    const auto& formats = o["formats"];
    s.output.vtu = std::find(formats.begin(), formats.end(), "vtu") != formats.end();
    s.output.ply = std::find(formats.begin(), formats.end(), "ply") != formats.end();
    auto has_format = [&](const char* f) { return std::find(formats.begin(), formats.end(), f) != formats.end(); };
    s.output.obj = has_format("obj");
    s.output.surface_ply = has_format("surface_ply");
    s.output.surface_vtp = has_format("surface_vtp");
    s.output.tets_vtu = has_format("tets_vtu");
    s.output.cache = has_format("cache");
    s.output.gltf = has_format("gltf");
    s.output.fields = o["fields"].get<std::vector<std::string>>();
    s.output.smooth_cracks = o["smooth_cracks"].get<int>();
    s.output.checkpoint_every = o["checkpoint_every"].get<std::uint64_t>();
    s.output.min_piece_tets = o["min_piece_tets"].get<std::uint32_t>();
    s.output.dust_points = o["dust"].get<std::string>() == "points";
    // Field names come from the systems' registry (systems/field_registry.hpp): checked here, once,
    // so `perifx check` catches a misspelt field before any meshing.
    const auto known = systems::step_fields();
    for (std::size_t k = 0; k < s.output.fields.size(); ++k) {
      const std::string& name = s.output.fields[k];
      const bool found = std::any_of(known.begin(), known.end(), [&](const auto& f) { return f.info.name == name; });
      if (!found) {
        std::string names;
        for (const auto& f : known) names += (names.empty() ? "" : ", ") + f.info.name;
        fail("/output/fields/" + std::to_string(k), "unknown particle field (got \"" + name.substr(0, 64) +
                                                        "\"; expected one of " + names + ")");
      }
    }
    return s;
  }

 private:
  [[noreturn]] void fail(const std::string& ptr, const std::string& message) const {
    throw SceneError(file_, ptr, message);
  }

  static double num(const Json& v) { return v.get<double>(); }
  static Vec3 vec(const Json& v) { return {num(v[0]), num(v[1]), num(v[2])}; }
  static Mat3 rotation(const Json& r) {
    return Eigen::AngleAxisd(num(r["degrees"]) * kPi / 180.0, vec(r["axis"]).normalized()).toRotationMatrix();
  }

  // Index of `name` in `names`, or a SceneError listing the names that do exist.
  int lookup(const Json& name_json, const std::vector<std::string>& names, const std::string& what,
             const std::string& ptr) const {  // `what`: "material" or "body"
    const std::string name = name_json.get<std::string>();
    const auto it = std::find(names.begin(), names.end(), name);
    if (it != names.end()) return static_cast<int>(it - names.begin());
    const std::string guess = detail::closest(name, names);
    fail(ptr, "unknown " + what + (guess.empty() ? "" : "; did you mean '" + guess + "'?") + " (got " +
                  show(name_json) + "; expected one of the defined " +
                  (what == "body" ? "bodies" : what + "s") + ": " + detail::join(names) + ")");
  }

  Material material(const std::string& name, const Json& m, const std::string& p) const {
    Material out;
    out.name = name;
    const detail::MaterialPreset* preset = nullptr;
    if (m.contains("preset")) {
      out.preset = m["preset"].get<std::string>();
      preset = detail::find_preset(out.preset);  // the spec's choice list guarantees it exists
    }
    out.density = m.contains("density") ? num(m["density"]) : preset ? preset->density : 1000.0;
    if (m.contains("bulk_modulus")) {
      out.bulk_modulus = num(m["bulk_modulus"]);
      out.shear_modulus = num(m["shear_modulus"]);
    } else {
      if (!m.contains("youngs_modulus") && !preset)
        fail(p, "missing keys (got " + show(original_ ? original_->at("materials").at(name) : m) + "; expected either 'bulk_modulus' + 'shear_modulus' or 'youngs_modulus' + "
                "'poisson_ratio', or a 'preset')");
      const double E = m.contains("youngs_modulus") ? num(m["youngs_modulus"]) : preset->youngs_modulus;
      const double nu = m.contains("poisson_ratio") ? num(m["poisson_ratio"]) : preset->poisson_ratio;
      out.bulk_modulus = bulk_modulus(E, nu);
      out.shear_modulus = shear_modulus(E, nu);
    }
    // Real solids carry waves at up to ~20 km/s; far beyond it the stable step is meaningless.
    const double wave = std::sqrt((out.bulk_modulus + 4.0 / 3.0 * out.shear_modulus) / out.density);
    if (!(wave <= kMaxWaveSpeed))
      fail(p, "moduli too stiff for the density (got a wave speed sqrt((K + 4G/3)/density) of " +
                  std::to_string(wave) + " m/s; expected at most 1e6 m/s)");
    // Fracture and yield each come as a model value or a physical one (converted per horizon), not
    // both: critical_stretch or fracture_energy (J/m²), yield_energy or yield_stress (Pa). With
    // neither, a preset gives its physical value; ∞ or 0 leaves the default (unbreakable / elastic).
    auto model_or_physical = [&](const char* model_key, const char* physical_key, double preset_value,
                                 double& model_out, double& physical_out) {
      if (m.contains(model_key) && m.contains(physical_key))
        fail(p + "/" + physical_key, std::string("given together with ") + model_key + " (got " +
                                         show(m[physical_key]) + "; expected either " + model_key + " or " +
                                         physical_key + ", not both)");
      if (m.contains(model_key)) {
        model_out = num(m[model_key]);
        return;
      }
      const double physical = m.contains(physical_key) ? num(m[physical_key]) : preset ? preset_value : 0.0;
      if (std::isfinite(physical) && physical > 0.0) physical_out = physical;
    };
    model_or_physical("critical_stretch", "fracture_energy", preset ? preset->fracture_energy : 0.0,
                      out.critical_stretch, out.fracture_energy);
    // The yield comes from one of three keys: yield_energy (model units), yield_stress (the flow
    // stress) or offset_yield_stress (a datasheet's 0.2 % proof stress, converted at set-up).
    if (m.contains("offset_yield_stress")) {
      for (const char* other : {"yield_energy", "yield_stress"})
        if (m.contains(other))
          fail(p + "/offset_yield_stress", std::string("given together with ") + other + " (got " +
                                               show(m["offset_yield_stress"]) +
                                               "; expected one of yield_energy, yield_stress or offset_yield_stress)");
      const double offset = num(m["offset_yield_stress"]);
      if (std::isfinite(offset) && offset > 0.0) out.offset_yield_stress = offset;
    } else {
      const bool preset_offset = preset && preset->yield_is_offset && !m.contains("yield_energy") && !m.contains("yield_stress");
      model_or_physical("yield_energy", "yield_stress", preset && !preset->yield_is_offset ? preset->yield_stress : 0.0,
                        out.yield_energy, out.yield_stress);
      if (preset_offset && std::isfinite(preset->yield_stress)) out.offset_yield_stress = preset->yield_stress;
    }
    // A physical yield stress means perfect plasticity unless the scene caps it.
    out.plastic_cap_ratio = m.contains("plastic_cap_ratio")                       ? num(m["plastic_cap_ratio"])
                            : out.yield_stress > 0.0 || out.offset_yield_stress > 0.0 ? kInfinity
                                                                                   : 0.0;
    out.damage_alpha = num(m["damage_alpha"]);
    out.damping = num(m["damping"]);
    if (m.contains("anisotropy")) {
      const Json& a = m["anisotropy"];
      if (a.contains("matrix")) {
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) out.anisotropy(r, c) = num(a["matrix"][r][c]);
        // Scale-free test: |det G| against ‖G‖³, so tiny but well-conditioned G still passes.
        const double scale = out.anisotropy.norm();
        if (!(std::abs(out.anisotropy.determinant()) > 1e-12 * scale * scale * scale))
          fail(p + "/anisotropy/matrix",
               "singular matrix (got " + show(a["matrix"]) + "; expected an invertible 3x3 matrix)");
      } else if (a.contains("axis")) {
        const Vec3 axis = vec(a["axis"]).normalized();
        const Mat3 along = axis * axis.transpose();
        const double ratio_along = num(a["ratio_along"]), ratio_across = num(a["ratio_across"]);
        // Equal ratios are exactly ratio·I (the sum below can miss I by an ulp); ratios 1 and 1 then
        // give G = I, i.e. the isotropic run bit for bit.
        out.anisotropy = ratio_along == ratio_across
                             ? Mat3(ratio_along * Mat3::Identity())
                             : Mat3(ratio_along * along + ratio_across * (Mat3::Identity() - along));
      }
    } else if (preset && preset->grain_ratio != 1.0) {  // wood: the grain along x
      const Mat3 along = Vec3::UnitX() * Vec3::UnitX().transpose();
      out.anisotropy = preset->grain_ratio * along + (Mat3::Identity() - along);
    }
    return out;
  }

  // /materials/<name>/strength; read after the bodies, whose names its regions may use.
  StrengthField strength(const Json& st, const std::string& p) const {
    StrengthField out;
    const Json& regions = st["regions"];
    for (std::size_t i = 0; i < regions.size(); ++i) {
      const std::string rp = p + "/regions/" + std::to_string(i);
      out.regions.push_back({region(regions[i]["region"], rp + "/region"), num(regions[i]["factor"])});
    }
    if (st.contains("noise")) {
      out.noise_amplitude = num(st["noise"]["amplitude"]);
      out.noise_feature_size = num(st["noise"]["feature_size"]);
      out.noise_seed = st["noise"]["seed"].get<std::uint64_t>();
    }
    const Json& planes = st["weak_planes"];
    for (std::size_t i = 0; i < planes.size(); ++i) {
      const std::string wp = p + "/weak_planes/" + std::to_string(i);
      out.weak_planes.push_back({crack(planes[i], wp + "/polygon").polygon, num(planes[i]["factor"])});
    }
    return out;
  }

  Body body(const Json& b, const std::string& p, std::size_t index) const {
    Body out;
    out.name = b.contains("name") ? b["name"].get<std::string>() : "body" + std::to_string(index);
    out.material = lookup(b["material"], material_names_, "material", p + "/material");

    const Json& g = b["geometry"];
    const std::string type = g["type"].get<std::string>();
    Geometry& geo = out.geometry;
    if (type == "box") {
      geo.kind = Geometry::Kind::box;
      geo.size = vec(g["size"]);
    } else if (type == "sphere") {
      geo.kind = Geometry::Kind::sphere;
      geo.radius = num(g["radius"]);
    } else if (type == "cylinder") {
      geo.kind = Geometry::Kind::cylinder;
      geo.radius = num(g["radius"]);
      geo.height = num(g["height"]);
      geo.axis = g["axis"].get<std::string>()[0] - 'x';
    } else if (type == "tetgen") {
      geo.kind = Geometry::Kind::tetgen;
      geo.path = tetgen_file(g["path"], p + "/geometry/path");
    } else {
      geo.kind = type == "gmsh" ? Geometry::Kind::gmsh : Geometry::Kind::surface;
      geo.path = mesh_file(g["path"], p + "/geometry/path", geo.kind == Geometry::Kind::gmsh);
    }
    if (geo.kind != Geometry::Kind::tetgen && geo.kind != Geometry::Kind::gmsh) {
      // Exactly one is set, so downstream can test edge_length > 0, then particles > 0.
      if (g.contains("edge_length")) geo.edge_length = num(g["edge_length"]);
      else if (g.contains("particles")) geo.particles = g["particles"].get<int>();
      else geo.resolution = g["resolution"].get<int>();
    }
    if (geo.kind == Geometry::Kind::box || geo.kind == Geometry::Kind::sphere || geo.kind == Geometry::Kind::cylinder) {
      geo.seed = g["seed"].get<long long>();
      for (const auto& axis : g["mirror"]) geo.mirror[static_cast<std::size_t>(axis.get<std::string>()[0] - 'x')] = true;
      // Breakable bodies get a jittered mesh unless the scene says otherwise (FORMAT.md, geometry.jitter).
      geo.jitter = g.contains("jitter") ? num(g["jitter"]) : -1.0;  // −1: decided below, once materials are known
    }

    const Json& tr = b["transform"];
    out.transform.translation = vec(tr["translate"]);
    if (tr.contains("rotate")) out.transform.rotation = rotation(tr["rotate"]);
    out.transform.scale = num(tr["scale"]);
    out.velocity = vec(b["velocity"]);
    out.angular_velocity = vec(b["angular_velocity"]);
    if (!(out.velocity.norm() < kMaxSpeed))
      fail(p + "/velocity", "speed too high (got " + show(b["velocity"]) + "; expected |velocity| below 3e8 m/s)");
    if (!(out.transform.translation.cwiseAbs().maxCoeff() <= kMaxCoordinate))
      fail(p + "/transform/translate", "too far away (got " + show(tr["translate"]) +
                                           "; expected coordinates within 1e9 m)");

    const Json& h = b["horizon"];
    if (h.is_number()) out.horizon_factor = num(h);
    else if (h.contains("factor")) out.horizon_factor = num(h["factor"]);
    else out.horizon_length = num(h["length"]);
    return out;
  }

  fs::path tetgen_file(const Json& path_json, const std::string& ptr) const {
    const fs::path node = (folder_ / path_json.get<std::string>()).lexically_normal();
    const fs::path ele = fs::path(node).replace_extension(".ele");
    for (const fs::path& f : {node, ele}) {
      std::error_code ec;
      if (!fs::is_regular_file(f, ec))
        fail(ptr, "mesh file not found: " + f.string() + " (got " + show(path_json) +
                      "; expected a TetGen .node file, with its .ele beside it, relative to " +
                      folder_.string() + ")");
    }
    return node;
  }

  // A Gmsh .msh or a closed surface file: exists, and a surface has an extension we can read.
  fs::path mesh_file(const Json& path_json, const std::string& ptr, bool gmsh) const {
    const fs::path file = (folder_ / path_json.get<std::string>()).lexically_normal();
    std::string ext = file.extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    const char* expected = gmsh ? "a Gmsh .msh file" : "a closed surface mesh: .obj, .ply, .stl or .off";
    if (!gmsh && ext != ".obj" && ext != ".ply" && ext != ".stl" && ext != ".off")
      fail(ptr, "unknown surface format '" + ext + "' (got " + show(path_json) + "; expected " + expected + ")");
    std::error_code ec;
    if (fs::exists(file, ec) && !fs::is_regular_file(file, ec))
      fail(ptr, "mesh file is not a regular file (got " + show(path_json) + "; expected " + expected +
                    ", not a directory, FIFO or device)");
    if (!fs::is_regular_file(file, ec))
      fail(ptr, "mesh file not found: " + file.string() + " (got " + show(path_json) + "; expected " + expected +
                    ", relative to " + folder_.string() + ")");
    return file;
  }

  Region region(const Json& r, const std::string& p) const {
    Region out;
    const std::string type = r["type"].get<std::string>();
    if (type == "all") {
      out.kind = Region::Kind::all;
    } else if (type == "box") {
      out.kind = Region::Kind::box;
      out.min = vec(r["min"]);
      out.max = vec(r["max"]);
      if (!(out.max.array() > out.min.array()).all())
        fail(p + "/max", "empty box (got " + show(r["max"]) + "; expected greater than min = " +
                             show(r["min"]) + " in every component)");
    } else if (type == "sphere") {
      out.kind = Region::Kind::sphere;
      out.center = vec(r["center"]);
      out.radius = num(r["radius"]);
    } else {
      out.kind = Region::Kind::halfspace;
      out.point = vec(r["point"]);
      out.normal = vec(r["normal"]).normalized();
    }
    if (r.contains("body")) out.body = lookup(r["body"], body_names_, "body", p + "/body");
    return out;
  }

  BoundaryCondition condition(const Json& c, const std::string& p) const {
    BoundaryCondition out;
    const std::string type = c["type"].get<std::string>();
    out.kind = type == "anchor"     ? BoundaryCondition::Kind::anchor
               : type == "velocity" ? BoundaryCondition::Kind::velocity
                                    : BoundaryCondition::Kind::displacement;
    out.region = region(c["region"], p + "/region");
    out.window = {num(c["start"]), num(c["ramp"]), num(c["end"])};
    out.axes = {false, false, false};
    for (const Json& a : c["axes"]) out.axes[static_cast<std::size_t>(a.get_ref<const std::string&>()[0] - 'x')] = true;
    if (!(out.window.end > out.window.start))
      fail(p + "/end", "ends before it starts (got " + show(c["end"]) + "; expected a time after start = " +
                           show(c["start"]) + ")");
    if (out.kind == BoundaryCondition::Kind::velocity) {
      out.velocity = vec(c["velocity"]);
      out.angular_velocity = vec(c["angular_velocity"]);
      out.center = vec(c["center"]);
    } else if (out.kind == BoundaryCondition::Kind::displacement) {
      out.displacement = vec(c["displacement"]);
      out.center = vec(c["center"]);
      if (c.contains("rotation")) {
        out.rotation_axis = vec(c["rotation"]["axis"]).normalized();
        out.rotation_angle = num(c["rotation"]["degrees"]) * kPi / 180.0;
      }
    }
    return out;
  }

  Load load(const Json& l, const std::string& p) const {
    Load out;
    const std::string type = l["type"].get<std::string>();
    using K = Load::Kind;
    out.kind = type == "traction"         ? K::traction
               : type == "body_force"     ? K::body_force
               : type == "blast"          ? K::blast
               : type == "radial_impulse" ? K::radial_impulse
               : type == "directional"    ? K::directional
                                          : K::noise;
    if (l.contains("region")) out.region = region(l["region"], p + "/region");
    if (l.contains("body")) {
      const int b = lookup(l["body"], body_names_, "body", p + "/body");
      if (out.region.body >= 0 && out.region.body != b)
        fail(p + "/body", "contradicts region.body (got " + show(l["body"]) + "; expected the body of the region, " +
                              show(l["region"]["body"]) + ", or no `body`)");
      out.region.body = b;
    }
    out.window = {num(l["start"]), num(l["ramp"]), num(l["end"])};
    if (!(out.window.end > out.window.start))
      fail(p + "/end", "ends before it starts (got " + show(l["end"]) + "; expected a time after start = " +
                           show(l["start"]) + ")");
    switch (out.kind) {
      case K::traction:
        out.magnitude = num(l["traction"]);
        out.depth = num(l["depth"]);
        out.along_normal = !l.contains("direction");
        if (!out.along_normal) out.direction = vec(l["direction"]).normalized();
        break;
      case K::body_force:
        if (l.contains("acceleration") == l.contains("force_density"))
          fail(p, "body force needs exactly one of 'acceleration' (m/s²) and 'force_density' (N/m³) (got " +
                      std::string(l.contains("acceleration") ? "both" : "neither") + ")");
        out.per_volume = l.contains("force_density");
        out.vector = vec(out.per_volume ? l["force_density"] : l["acceleration"]);
        break;
      case K::blast:
      case K::radial_impulse:
        out.center = vec(l["center"]);
        out.radius = num(l["radius"]);
        out.falloff = num(l["falloff"]);
        out.cutoff = num(l["cutoff"]);
        out.duration = num(l["duration"]);
        out.front_speed = num(l["front_speed"]);
        if (out.kind == K::blast) {
          out.magnitude = num(l["pressure"]);
          if (!(out.duration > 0.0))
            fail(p + "/duration", "a blast needs a pulse length (got " + show(l.value("duration", Json(0))) +
                                      "; expected a duration > 0 s, or use radial_impulse for an instantaneous one)");
        } else {
          out.magnitude = num(l["impulse"]);
        }
        break;
      case K::directional:
        out.vector = vec(l["velocity"]);
        out.drag = num(l["drag"]);
        out.quadratic_drag = num(l["quadratic_drag"]);
        if (!(out.drag > 0.0 || out.quadratic_drag > 0.0))
          fail(p + "/drag", "no drag (got drag = " + show(l["drag"]) + " and quadratic_drag = " +
                                show(l["quadratic_drag"]) + "; expected at least one > 0)");
        break;
      case K::noise:
        out.magnitude = num(l["amplitude"]);
        out.per_volume = l["units"] == "force_density";
        out.feature_size = num(l["feature_size"]);
        out.speed = num(l["speed"]);
        out.direction = l.contains("direction") ? Vec3(vec(l["direction"]).normalized()) : Vec3(Vec3::UnitX());
        out.seed = l["seed"].get<std::uint64_t>();
        break;
    }
    return out;
  }

  // Planar within 1e-6 of the polygon's size, and with a non-zero area (Newell normal).
  Crack crack(const Json& c, const std::string& ptr) const {
    Crack out;
    for (const Json& v : c["polygon"]) out.polygon.push_back(vec(v));
    const auto& poly = out.polygon;
    Vec3 normal = Vec3::Zero(), centroid = Vec3::Zero();
    double size = 0.0;
    for (std::size_t a = 0; a < poly.size(); ++a) {
      const Vec3& p = poly[a];
      const Vec3& q = poly[(a + 1) % poly.size()];
      normal += Vec3((p.y() - q.y()) * (p.z() + q.z()), (p.z() - q.z()) * (p.x() + q.x()),
                     (p.x() - q.x()) * (p.y() + q.y()));
      centroid += p;
      size = std::max(size, (q - p).norm());
    }
    centroid /= double(poly.size());
    const double area = 0.5 * normal.norm();
    if (!(size > 0.0) || !(area > 1e-12 * size * size))
      fail(ptr, "degenerate polygon (got zero area; expected at least 3 non-collinear vertices)");
    normal.normalize();
    for (std::size_t a = 0; a < poly.size(); ++a) {
      const double off = std::abs((poly[a] - centroid).dot(normal));
      if (off > 1e-6 * size)
        fail(ptr + "/" + std::to_string(a), "polygon not planar (got a vertex " + std::to_string(off) +
                                                " m off its plane; expected all vertices in one plane)");
    }
    return out;
  }

  static Collider collider(const Json& c) {
    Collider out;
    const std::string type = c["type"].get<std::string>();
    if (type == "plane") {
      out.kind = Collider::Kind::plane;
      out.point = vec(c["point"]);
      out.normal = vec(c["normal"]).normalized();
    } else if (type == "sphere") {
      out.kind = Collider::Kind::sphere;
      out.center = vec(c["center"]);
      out.radius = num(c["radius"]);
    } else {
      out.kind = Collider::Kind::box;
      out.center = vec(c["center"]);
      out.half_extents = 0.5 * vec(c["size"]);
      if (c.contains("rotate")) out.orientation = rotation(c["rotate"]);
    }
    out.velocity = vec(c["velocity"]);
    out.angular_velocity = vec(c["angular_velocity"]);
    out.friction = num(c["friction"]);
    out.restitution = num(c["restitution"]);
    return out;
  }

  const Json* original_ = nullptr;  // the scene before validation filled defaults, for messages

 public:
  void set_original(const Json* j) { original_ = j; }

 private:
  std::string file_;
  fs::path folder_;  // absolute folder of the scene file, for relative mesh paths
  std::vector<std::string> material_names_, body_names_;
};

}  // namespace

void check_time(const Scene& s, std::uint64_t frames_override) {
  const std::string file = s.source.string();
  const auto& t = s.time;
  auto g = [](double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", x);
    return std::string(buf);
  };
  const double frames = frames_override ? double(frames_override) : std::floor(t.duration * t.frame_rate + 1e-9);
  const double duration = frames_override ? double(frames_override) / t.frame_rate : t.duration;
  if (!(frames >= 1.0))
    throw SceneError(file, "/time/frame_rate", "no frame in the duration (got duration × frame_rate = " + g(frames) +
                                                   "; expected at least 1 frame after the initial one)");
  if (!(frames <= kMaxFrames))
    throw SceneError(file, "/time/frame_rate", "too many frames (got duration × frame_rate = " + g(frames) +
                                                   "; expected at most 1e6 frames)");
  // An automatic step unresolved (a scene before a World picks it) has nothing more to check; a World
  // checks the step it picks here too (setup/world_setup.cpp).
  if (t.auto_dt && t.dt == 0.0) return;
  if (!(t.dt > 0.0) || !std::isfinite(t.dt))
    throw SceneError(file, "/time/dt", "not a time step (got " + g(t.dt) + "; expected a positive number of seconds)");
  if (!(t.frame_rate * t.dt <= 1.0))
    throw SceneError(file, "/time/frame_rate", "frames closer together than one step (got " + g(t.frame_rate) +
                                                   " frames/s; expected at most 1/dt = " + g(1.0 / t.dt) + ")");
  if (!(duration / t.dt <= kMaxSteps))
    throw SceneError(file, "/time/dt", "too many steps: time step too small for the duration (got dt = " + g(t.dt) +
                                           " s for " + g(duration) + " s, " + g(duration / t.dt) +
                                           " steps; expected at most 1e9 steps, dt >= " + g(duration / kMaxSteps) +
                                           " s)");
}

bool can_break(const Material& m) {
  return std::isfinite(m.critical_stretch) || (m.fracture_energy > 0.0 && std::isfinite(m.fracture_energy));
}

Scene load_scene_text(const std::string& text, const fs::path& file) {
  const std::string name = file.string();
  Json j = parse(text, name);
  const bool formats_given = j.is_object() && j.contains("output") && j["output"].is_object() &&
                             j["output"].contains("formats");
  const Json original = j;
  detail::validate(j, name);
  Converter converter(name, fs::absolute(file).parent_path());
  converter.set_original(&original);
  Scene s = converter.run(j, file);
  s.text = text;
  // Every body is a tet mesh, so scenes write its surface (OBJ + PLY) unless they list their formats:
  // what a renderer draws is the body, not its particles. (FEM runs have no embedded mesh: the
  // runner leaves defaulted surfaces out there.)
  if (!formats_given && s.solver == Solver::peridynamics) {
    s.output.obj = s.output.surface_ply = s.output.cache = true;
    s.output.surfaces_by_default = true;
  }
  for (Body& b : s.bodies)
    if (b.geometry.jitter < 0.0)
      b.geometry.jitter = can_break(s.materials[static_cast<std::size_t>(b.material)]) ? 0.3 : 0.0;
  return s;
}

Scene load_scene_file(const fs::path& file) {
  // A FIFO or device would block or never end; a huge file is no scene.
  std::error_code ec;
  const auto status = fs::status(file, ec);
  if (!ec && fs::exists(status) && !fs::is_regular_file(status))
    throw SceneError(file.string(), "", "not a regular file (got " + detail::cut(fs::absolute(file).string()) +
                                            "; expected a JSON file, not a directory, FIFO or device)");
  constexpr std::uintmax_t kMaxSceneBytes = 64u << 20;
  if (const auto size = fs::file_size(file, ec); !ec && size > kMaxSceneBytes)
    throw SceneError(file.string(), "", "scene file too large (got " + std::to_string(size) +
                                            " bytes; expected at most 64 MiB)");
  std::ifstream in(file, std::ios::binary);
  if (!in)
    throw SceneError(file.string(), "", "cannot open the scene file (got " + fs::absolute(file).string() +
                                            "; expected a readable JSON file)");
  std::ostringstream text;
  text << in.rdbuf();
  return load_scene_text(text.str(), file);
}

}  // namespace perifx::scene
