// Rendering of perifx runs: a backend-neutral scene (spheres, triangles, camera, lights, ground),
// the default camera framing, a built-in software rasterizer and a POV-Ray scene writer.
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "components/math.hpp"

namespace perifx::render {

struct Sphere {
  Vec3 center = Vec3::Zero();
  double radius = 0.0;
  Vec3 color = Vec3::Ones();  // linear RGB in [0, 1]
};

struct Triangle {
  Vec3 a = Vec3::Zero(), b = Vec3::Zero(), c = Vec3::Zero();
  Vec3 color = Vec3::Ones();
};

struct Camera {
  Vec3 position = Vec3(0, 0, 5);
  Vec3 target = Vec3::Zero();
  Vec3 up = Vec3::UnitY();
  double vertical_fov_degrees = 35.0;
};

struct Light {
  Vec3 position = Vec3::Zero();
  double intensity = 1.0;
  bool shadows = true;
};

struct RenderScene {
  std::vector<Sphere> spheres;      // particles (matte)
  std::vector<Triangle> triangles;  // surfaces (matte, two-sided)
  std::vector<Sphere> metal;        // rigid projectiles (metallic)
  std::optional<double> ground_y;   // a ground plane y = ground_y, when set
  double ground_tile = 0.1;         // checker size on the ground, m
  Camera camera;
  std::vector<Light> lights;
};

struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  // 8-bit sRGB, rows top to bottom
};

// A camera that looks at the box's center from a 3/4 elevated direction (`toward_camera`, from the
// center; Y up), at the smallest distance that keeps all 8 corners inside the image with a margin.
Camera frame_box(const Vec3& lo, const Vec3& hi, double aspect, double vertical_fov_degrees = 35.0,
                 const Vec3& toward_camera = Vec3(0.75, 0.55, 1.3), double margin = 1.08);

// A key light (shadows) and a fill light (no shadows) placed relative to the camera and the box.
std::vector<Light> default_lights(const Camera& camera, const Vec3& lo, const Vec3& hi);

// Where a world point lands in the image: pixel coordinates (x right, y down) and the depth along
// the view direction (positive in front of the camera).
Vec3 project(const Camera& camera, int width, int height, const Vec3& p);

// Built-in backend: ray-exact sphere impostors and triangles, z-buffered, Lambert + Blinn shading,
// a shadow map for the key light, sky gradient and checkered ground.
Image rasterize(const RenderScene& scene, int width, int height);

// POV-Ray backend: the scene file (includes `data_include`, given by file name) and the data.
// Coordinates are mirrored in z because POV-Ray is left-handed.
struct PovrayFiles {
  std::string scene, data;
};
PovrayFiles povray_scene(const RenderScene& scene, int width, int height, const std::string& data_include);

// Colour maps (linear RGB): damage 0 -> blue, 0.5 -> light grey, 1 -> red (cool-warm, as in the
// paper's Fig. 6), and a qualitative palette for material or body ids.
Vec3 damage_color(double phi);
Vec3 material_color(std::uint32_t id);

}  // namespace perifx::render
