// POV-Ray scene writer (see render.hpp). POV-Ray is left-handed (x right, y up, z into the screen);
// mirroring every z (geometry, camera, lights) renders the right-handed perifx world unmirrored.
// Colours are quantized to 8 bits per channel and declared once as textures, so a frame of 10^5
// particles stays one short line per sphere.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "tools/render/render.hpp"

namespace perifx::render {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.7g", std::abs(v) < 1e-300 ? 0.0 : v);
  return buf;
}

// A POV-Ray vector with z mirrored. (snprintf rather than string concatenation: g++ 12 reports a
// false -Wrestrict on chains of operator+ with short literals.)
std::string vec(const Vec3& p) {
  char buf[112];
  auto z = [](double v) { return std::abs(v) < 1e-300 ? 0.0 : v; };
  std::snprintf(buf, sizeof buf, "<%.7g,%.7g,%.7g>", z(p.x()), z(p.y()), z(-p.z()));
  return buf;
}

class TexturePalette {
 public:
  // Index of the texture for colour c (quantized), declaring it on first use.
  int index(const Vec3& c) {
    const auto q = [](double v) { return int(std::lround(std::clamp(v, 0.0, 1.0) * 255.0)); };
    const int key = q(c.x()) << 16 | q(c.y()) << 8 | q(c.z());
    const auto [it, inserted] = ids_.emplace(key, int(ids_.size()));
    if (inserted)
      decl_ += "#declare PT" + std::to_string(it->second) + " = texture { pigment { rgb <" + num(q(c.x()) / 255.0) +
               "," + num(q(c.y()) / 255.0) + "," + num(q(c.z()) / 255.0) + "> } finish { PFX_Matte } }\n";
    return it->second;
  }
  const std::string& declarations() const { return decl_; }

 private:
  std::map<int, int> ids_;
  std::string decl_;
};

}  // namespace

PovrayFiles povray_scene(const RenderScene& s, int width, int height, const std::string& data_include) {
  PovrayFiles f;
  const double aspect = double(width) / double(height);
  const double hfov = 2.0 * std::atan(std::tan(0.5 * s.camera.vertical_fov_degrees * kPi / 180.0) * aspect) * 180.0 / kPi;
  const Vec3 c = s.camera.target;
  const double dist = (s.camera.position - c).norm();

  std::string& p = f.scene;
  p += "// perifx render: generated scene (POV-Ray 3.7). Right-handed perifx data, z mirrored.\n";
  p += "#version 3.7;\n";
  p += "global_settings { assumed_gamma 1.0 max_trace_level 6 ambient_light rgb <1,1,1> }\n";
  p += "#declare PFX_Matte = finish { ambient rgb <0.16,0.17,0.19> diffuse 0.8 specular 0.15 roughness 0.04 }\n";
  p += "#declare PFX_Metal = texture { pigment { rgb <0.72,0.73,0.76> } finish { ambient 0.04 diffuse 0.25 "
       "specular 0.9 roughness 0.005 metallic reflection { 0.55 metallic } } }\n";
  p += "camera { perspective location " + vec(s.camera.position) + " sky <0,1,0> right x*" + num(aspect) +
       " up y angle " + num(hfov) + " look_at " + vec(c) + " }\n";
  p += "sky_sphere { pigment { gradient y color_map { [0.0 rgb <0.30,0.30,0.29>] [0.5 rgb <0.78,0.82,0.88>] "
       "[1.0 rgb <0.30,0.42,0.62>] } scale 2 translate -1 } }\n";
  for (const auto& l : s.lights) {
    p += "light_source { " + vec(l.position) + " color rgb " + num(l.intensity);
    if (l.shadows) {
      // A soft key light: area size ~4% of its distance gives short penumbrae at contact.
      const double a = 0.08 * dist;
      p += " area_light <" + num(a) + ",0,0>, <0,0," + num(a) + ">, 5, 5 adaptive 1 jitter circular orient";
    } else {
      p += " shadowless";
    }
    p += " }\n";
  }
  if (s.ground_y) {
    // Checker near the subject fading into the horizon colour far away (no fog on the subject, and
    // no moire at the horizon).
    char fade[256];
    const Vec3 center(c.x(), *s.ground_y, c.z());
    std::snprintf(fade, sizeof fade, " ] } scale %.7g translate %s } }\n", 6.0 * dist, vec(center).c_str());
    p += "plane { y, " + num(*s.ground_y) + " finish { ambient rgb <0.12,0.12,0.12> diffuse 0.75 } "
         "pigment { spherical pigment_map { [0.0 rgb <0.78,0.82,0.88>] [0.75 checker rgb <0.50,0.50,0.48> "
         "rgb <0.42,0.42,0.40> scale " + num(s.ground_tile / (6.0 * dist)) + "] [1.0 checker rgb <0.50,0.50,0.48> "
         "rgb <0.42,0.42,0.40> scale " + num(s.ground_tile / (6.0 * dist)) + fade;
  }
  p += "#include \"" + data_include + "\"\n";

  TexturePalette palette;
  std::string body;
  body.reserve(64 * (s.spheres.size() + s.triangles.size()) + 1024);
  if (!s.spheres.empty()) {
    body += "union {\n";
    for (const auto& sp : s.spheres) {
      const int t = palette.index(sp.color);
      body += " sphere{" + vec(sp.center) + "," + num(sp.radius) + " texture{PT" + std::to_string(t) + "}}\n";
    }
    body += "}\n";
  }
  if (!s.triangles.empty()) {
    std::vector<int> tex(s.triangles.size());
    for (std::size_t k = 0; k < s.triangles.size(); ++k) tex[k] = palette.index(s.triangles[k].color);
    int count = 0;  // texture_list must hold every index the faces use
    for (const int t : tex) count = std::max(count, t + 1);
    body += "mesh2 {\n vertex_vectors { " + std::to_string(3 * s.triangles.size()) + ",\n";
    for (const auto& t : s.triangles) body += "  " + vec(t.a) + "," + vec(t.b) + "," + vec(t.c) + "\n";
    std::string list = " }\n texture_list { " + std::to_string(count) + ",";
    for (int k = 0; k < count; ++k) list += " texture{PT" + std::to_string(k) + "}";
    body += list + " }\n face_indices { " + std::to_string(s.triangles.size()) + ",\n";
    for (std::size_t k = 0; k < s.triangles.size(); ++k)
      body += "  <" + std::to_string(3 * k) + "," + std::to_string(3 * k + 1) + "," + std::to_string(3 * k + 2) + ">," +
              std::to_string(tex[k]) + "\n";
    body += " }\n}\n";
  }
  for (const auto& sp : s.metal) body += "sphere{" + vec(sp.center) + "," + num(sp.radius) + " texture{PFX_Metal}}\n";
  f.data = "// perifx render: frame data\n" + palette.declarations() + body;
  return f;
}

}  // namespace perifx::render
