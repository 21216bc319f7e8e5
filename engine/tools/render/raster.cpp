// The built-in software backend (see render.hpp) and the backend-neutral pieces: camera framing,
// lights, projection and colour maps.
//
// Rasterizer: a G-buffer pass (per pixel: distance along the view ray, normal, base colour, kind)
// draws spheres as ray-exact impostors over their screen bounding squares and triangles by edge
// functions with the exact ray-plane distance; a shadow map rendered orthographically along the key
// light gives hard shadows softened by 3x3 percentage-closer filtering; a shading pass adds a
// sky/ground hemisphere ambient, Lambert from each light and a Blinn highlight, then the image is
// 2x2 supersampled down and gamma-encoded.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "tools/render/render.hpp"

namespace perifx::render {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();

struct Basis {
  Vec3 u, v, w;  // right, up, forward
};

Basis camera_basis(const Camera& c) {
  Basis b;
  b.w = (c.target - c.position).normalized();
  Vec3 up = c.up;
  if (std::abs(b.w.dot(up.normalized())) > 0.999) up = Vec3::UnitZ();  // looking straight up or down
  b.u = b.w.cross(up).normalized();
  b.v = b.u.cross(b.w);
  return b;
}

// Sky gradient, linear RGB, for a unit direction.
Vec3 sky(const Vec3& dir) {
  const double t = std::clamp(dir.y(), 0.0, 1.0);
  const Vec3 horizon(0.78, 0.82, 0.88), zenith(0.30, 0.42, 0.62);
  return horizon + (zenith - horizon) * std::sqrt(t);
}

// Smallest positive t with |o + t d - c| = r (d unit), or inf.
double hit_sphere(const Vec3& o, const Vec3& d, const Vec3& c, double r) {
  const Vec3 oc = o - c;
  const double b = oc.dot(d), cc = oc.squaredNorm() - r * r;
  const double disc = b * b - cc;
  if (disc < 0) return kInf;
  const double s = std::sqrt(disc);
  const double t0 = -b - s;
  if (t0 > 1e-9) return t0;
  const double t1 = -b + s;
  return t1 > 1e-9 ? t1 : kInf;
}

enum Kind : std::uint8_t { kSky = 0, kMatte, kMetal, kGround };

struct GBuffer {
  int w = 0, h = 0;
  std::vector<double> t;
  std::vector<Vec3> n, color;
  std::vector<std::uint8_t> kind;
  GBuffer(int width, int height)
      : w(width), h(height), t(std::size_t(width) * std::size_t(height), kInf), n(t.size(), Vec3::UnitY()),
        color(t.size(), Vec3::Zero()), kind(t.size(), kSky) {}
};

// Orthographic depth map along the key light.
struct ShadowMap {
  bool enabled = false;
  Vec3 u, v, w, origin;
  double texel = 1.0;
  int size = 0;
  std::vector<double> depth;

  bool shadowed(const Vec3& p, const Vec3& normal) const {
    if (!enabled) return false;
    const Vec3 q = p - origin;
    const double x = q.dot(u) / texel + size * 0.5, y = q.dot(v) / texel + size * 0.5;
    const double d = q.dot(w);
    // Bias grows at grazing angles so lit surfaces do not shadow themselves.
    const double bias = texel * (1.5 + 2.0 * std::sqrt(std::max(0.0, 1.0 - std::pow(std::abs(normal.dot(w)), 2))));
    int hidden = 0, total = 0;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int ix = int(std::floor(x)) + dx, iy = int(std::floor(y)) + dy;
        ++total;
        if (ix < 0 || iy < 0 || ix >= size || iy >= size) continue;
        if (d > depth[std::size_t(iy) * std::size_t(size) + std::size_t(ix)] + bias) ++hidden;
      }
    return hidden * 2 > total;  // majority vote; softened further by supersampling
  }
  double visibility(const Vec3& p, const Vec3& normal) const { return shadowed(p, normal) ? 0.0 : 1.0; }
};

double edge(double ax, double ay, double bx, double by, double px, double py) {
  return (bx - ax) * (py - ay) - (by - ay) * (px - ax);
}

// Rasterizes a screen-space triangle; calls f(x, y, l0, l1, l2) for covered pixel centers.
template <class F>
void scan_triangle(const Vec3& p0, const Vec3& p1, const Vec3& p2, int w, int h, F&& f) {
  const double area = edge(p0.x(), p0.y(), p1.x(), p1.y(), p2.x(), p2.y());
  if (std::abs(area) < 1e-12) return;
  const int x0 = std::max(0, int(std::floor(std::min({p0.x(), p1.x(), p2.x()}))));
  const int x1 = std::min(w - 1, int(std::ceil(std::max({p0.x(), p1.x(), p2.x()}))));
  const int y0 = std::max(0, int(std::floor(std::min({p0.y(), p1.y(), p2.y()}))));
  const int y1 = std::min(h - 1, int(std::ceil(std::max({p0.y(), p1.y(), p2.y()}))));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double px = x + 0.5, py = y + 0.5;
      const double l0 = edge(p1.x(), p1.y(), p2.x(), p2.y(), px, py) / area;
      const double l1 = edge(p2.x(), p2.y(), p0.x(), p0.y(), px, py) / area;
      const double l2 = 1.0 - l0 - l1;
      if (l0 >= 0 && l1 >= 0 && l2 >= 0) f(x, y, l0, l1, l2);
    }
}

ShadowMap build_shadow_map(const RenderScene& s) {
  ShadowMap m;
  const Light* key = nullptr;
  for (const auto& l : s.lights)
    if (l.shadows) {
      key = &l;
      break;
    }
  if (!key) return m;
  Vec3 lo = Vec3::Constant(kInf), hi = Vec3::Constant(-kInf);
  auto grow = [&](const Vec3& p, double r) {
    lo = lo.cwiseMin(p - Vec3::Constant(r));
    hi = hi.cwiseMax(p + Vec3::Constant(r));
  };
  for (const auto& sp : s.spheres) grow(sp.center, sp.radius);
  for (const auto& sp : s.metal) grow(sp.center, sp.radius);
  for (const auto& t : s.triangles) grow(t.a, 0), grow(t.b, 0), grow(t.c, 0);
  if (!(lo.x() <= hi.x())) return m;
  m.enabled = true;
  m.origin = 0.5 * (lo + hi);
  const double radius = std::max(0.5 * (hi - lo).norm(), 1e-6);
  m.w = (m.origin - key->position).normalized();
  const Vec3 up = std::abs(m.w.y()) > 0.99 ? Vec3::UnitZ() : Vec3::UnitY();
  m.u = m.w.cross(up).normalized();
  m.v = m.u.cross(m.w);
  m.size = 2048;
  m.texel = 2.0 * radius * 1.05 / m.size;
  m.depth.assign(std::size_t(m.size) * std::size_t(m.size), kInf);
  auto splat = [&](const Sphere& sp) {
    const Vec3 q = sp.center - m.origin;
    const double cx = q.dot(m.u) / m.texel + m.size * 0.5, cy = q.dot(m.v) / m.texel + m.size * 0.5, cz = q.dot(m.w);
    const double rp = sp.radius / m.texel;
    for (int y = std::max(0, int(cy - rp)); y <= std::min(m.size - 1, int(cy + rp) + 1); ++y)
      for (int x = std::max(0, int(cx - rp)); x <= std::min(m.size - 1, int(cx + rp) + 1); ++x) {
        const double dx = (x + 0.5 - cx) * m.texel, dy = (y + 0.5 - cy) * m.texel;
        const double rr = sp.radius * sp.radius - dx * dx - dy * dy;
        if (rr < 0) continue;
        double& d = m.depth[std::size_t(y) * std::size_t(m.size) + std::size_t(x)];
        d = std::min(d, cz - std::sqrt(rr));
      }
  };
  for (const auto& sp : s.spheres) splat(sp);
  for (const auto& sp : s.metal) splat(sp);
  auto light_space = [&](const Vec3& p) {
    const Vec3 q = p - m.origin;
    return Vec3(q.dot(m.u) / m.texel + m.size * 0.5, q.dot(m.v) / m.texel + m.size * 0.5, q.dot(m.w));
  };
  for (const auto& t : s.triangles) {
    const Vec3 a = light_space(t.a), b = light_space(t.b), c = light_space(t.c);
    scan_triangle(a, b, c, m.size, m.size, [&](int x, int y, double l0, double l1, double l2) {
      double& d = m.depth[std::size_t(y) * std::size_t(m.size) + std::size_t(x)];
      d = std::min(d, l0 * a.z() + l1 * b.z() + l2 * c.z());
    });
  }
  return m;
}

}  // namespace

Camera frame_box(const Vec3& lo, const Vec3& hi, double aspect, double vertical_fov_degrees, const Vec3& toward_camera,
                 double margin) {
  Camera cam;
  cam.vertical_fov_degrees = vertical_fov_degrees;
  const Vec3 c = 0.5 * (lo + hi);
  const Vec3 d = toward_camera.normalized();
  cam.target = c;
  cam.position = c + d;  // provisional, for the basis
  const Basis b = camera_basis(cam);
  const double tan_v = std::tan(0.5 * vertical_fov_degrees * kPi / 180.0), tan_h = tan_v * aspect;
  double dist = 1e-3 + 0.5 * (hi - lo).norm() * 1e-3;
  for (int k = 0; k < 8; ++k) {
    const Vec3 corner((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(), (k & 4) ? hi.z() : lo.z());
    const Vec3 p = corner - c;
    // Depth of p is dist + p.w; it must satisfy |p.u| <= tan_h depth / margin and likewise for v.
    dist = std::max(dist, margin * std::abs(p.dot(b.u)) / tan_h - p.dot(b.w));
    dist = std::max(dist, margin * std::abs(p.dot(b.v)) / tan_v - p.dot(b.w));
    dist = std::max(dist, 1.5 * std::abs(p.dot(b.w)));  // keep the near side well in front
  }
  cam.position = c + d * dist;
  return cam;
}

std::vector<Light> default_lights(const Camera& camera, const Vec3& lo, const Vec3& hi) {
  const Vec3 c = 0.5 * (lo + hi);
  const Basis b = camera_basis(camera);
  const double dist = std::max((camera.position - c).norm(), 1e-3);
  Vec3 back = -b.w;
  back.y() = 0;
  back = back.norm() > 1e-6 ? back.normalized() : Vec3::UnitZ();
  std::vector<Light> lights(2);
  lights[0].position = c + dist * (0.7 * back - 0.6 * b.u + 1.3 * Vec3::UnitY());  // key: high, camera-left
  lights[0].intensity = 0.85;
  lights[0].shadows = true;
  lights[1].position = c + dist * (0.6 * back + 1.0 * b.u + 0.3 * Vec3::UnitY());  // fill: low, camera-right
  lights[1].intensity = 0.3;
  lights[1].shadows = false;
  return lights;
}

Vec3 project(const Camera& camera, int width, int height, const Vec3& p) {
  const Basis b = camera_basis(camera);
  const double tan_v = std::tan(0.5 * camera.vertical_fov_degrees * kPi / 180.0);
  const double tan_h = tan_v * double(width) / double(height);
  const Vec3 q = p - camera.position;
  const double z = q.dot(b.w);
  const double x = q.dot(b.u) / (z * tan_h), y = q.dot(b.v) / (z * tan_v);
  return Vec3((x + 1.0) * 0.5 * width, (1.0 - y) * 0.5 * height, z);
}

Vec3 damage_color(double phi) {
  const double t = std::clamp(std::isfinite(phi) ? phi : 0.0, 0.0, 1.0);
  const Vec3 blue(0.05, 0.20, 0.75), mid(0.75, 0.75, 0.75), red(0.80, 0.04, 0.03);
  return t < 0.5 ? blue + (mid - blue) * (2 * t) : mid + (red - mid) * (2 * t - 1);
}

Vec3 material_color(std::uint32_t id) {
  static const Vec3 palette[] = {{0.62, 0.64, 0.68}, {0.10, 0.35, 0.65}, {0.75, 0.35, 0.08},
                                 {0.15, 0.50, 0.20}, {0.55, 0.12, 0.45}, {0.70, 0.60, 0.10},
                                 {0.10, 0.55, 0.55}, {0.60, 0.15, 0.12}};
  return palette[id % (sizeof palette / sizeof palette[0])];
}

Image rasterize(const RenderScene& s, int width, int height) {
  constexpr int kSuper = 2;
  const int W = width * kSuper, H = height * kSuper;
  GBuffer g(W, H);
  const Basis b = camera_basis(s.camera);
  const double tan_v = std::tan(0.5 * s.camera.vertical_fov_degrees * kPi / 180.0);
  const double tan_h = tan_v * double(W) / double(H);
  const Vec3 eye = s.camera.position;
  auto ray = [&](double px, double py) {
    const double sx = (2.0 * px / W - 1.0) * tan_h, sy = (1.0 - 2.0 * py / H) * tan_v;
    return Vec3(b.w + sx * b.u + sy * b.v).normalized();
  };

  auto draw_sphere = [&](const Sphere& sp, Kind kind) {
    const Vec3 q = sp.center - eye;
    const double z = q.dot(b.w);
    if (z <= sp.radius) return;  // behind or around the camera
    const Vec3 c = project(s.camera, W, H, sp.center);
    // Generous screen radius: a sphere's silhouette is an ellipse slightly larger off-axis.
    const double rpix = sp.radius / std::sqrt(std::max(z * z - sp.radius * sp.radius, 1e-30)) / tan_v * 0.5 * H *
                        (1.0 + 0.5 * (std::pow(q.dot(b.u) / z, 2) + std::pow(q.dot(b.v) / z, 2))) + 1.0;
    const int x0 = std::max(0, int(c.x() - rpix)), x1 = std::min(W - 1, int(c.x() + rpix));
    const int y0 = std::max(0, int(c.y() - rpix)), y1 = std::min(H - 1, int(c.y() + rpix));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const Vec3 d = ray(x + 0.5, y + 0.5);
        const double t = hit_sphere(eye, d, sp.center, sp.radius);
        const std::size_t i = std::size_t(y) * std::size_t(W) + std::size_t(x);
        if (t < g.t[i]) {
          g.t[i] = t;
          g.n[i] = (eye + t * d - sp.center) / sp.radius;
          g.color[i] = sp.color;
          g.kind[i] = kind;
        }
      }
  };
  for (const auto& sp : s.spheres) draw_sphere(sp, kMatte);
  for (const auto& sp : s.metal) draw_sphere(sp, kMetal);

  for (const auto& tri : s.triangles) {
    const Vec3 pa = project(s.camera, W, H, tri.a), pb = project(s.camera, W, H, tri.b), pc = project(s.camera, W, H, tri.c);
    if (pa.z() <= 1e-6 || pb.z() <= 1e-6 || pc.z() <= 1e-6) continue;  // no near-plane clipping: skip
    Vec3 n = (tri.b - tri.a).cross(tri.c - tri.a);
    if (n.norm() < 1e-300) continue;
    n.normalize();
    scan_triangle(pa, pb, pc, W, H, [&](int x, int y, double, double, double) {
      const Vec3 d = ray(x + 0.5, y + 0.5);
      const double den = n.dot(d);
      if (std::abs(den) < 1e-12) return;
      const double t = n.dot(tri.a - eye) / den;
      const std::size_t i = std::size_t(y) * std::size_t(W) + std::size_t(x);
      if (t > 0 && t < g.t[i]) {
        g.t[i] = t;
        g.n[i] = den < 0 ? n : Vec3(-n);  // two-sided: face the viewer
        g.color[i] = tri.color;
        g.kind[i] = kMatte;
      }
    });
  }

  const ShadowMap shadow = build_shadow_map(s);
  const double extent = [&] {
    double r = 1.0;
    if (s.ground_y) r = std::max(1e-3, (s.camera.target - s.camera.position).norm());
    return r;
  }();

  std::vector<Vec3> hdr(std::size_t(W) * std::size_t(H));
  tbb::parallel_for(0, H, [&](int y) {
    for (int x = 0; x < W; ++x) {
      const std::size_t i = std::size_t(y) * std::size_t(W) + std::size_t(x);
      const Vec3 d = ray(x + 0.5, y + 0.5);
      std::uint8_t kind = g.kind[i];
      double t = g.t[i];
      Vec3 n = g.n[i], base = g.color[i];
      if (s.ground_y && std::abs(d.y()) > 1e-12) {
        const double tg = (*s.ground_y - eye.y()) / d.y();
        if (tg > 0 && tg < t) {
          t = tg;
          kind = kGround;
          n = Vec3::UnitY();
          const Vec3 p = eye + t * d;
          const long cx = long(std::floor(p.x() / s.ground_tile)), cz = long(std::floor(p.z() / s.ground_tile));
          base = ((cx + cz) & 1) ? Vec3(0.50, 0.50, 0.48) : Vec3(0.42, 0.42, 0.40);
        }
      }
      if (kind == kSky) {
        hdr[i] = sky(d);
        continue;
      }
      const Vec3 p = eye + t * d;
      const Vec3 v = -d;
      // Hemisphere ambient: sky above, warm ground bounce below.
      const double up = 0.5 * (n.y() + 1.0);
      const Vec3 ambient = (Vec3(0.20, 0.19, 0.17) * (1.0 - up) + Vec3(0.32, 0.36, 0.42) * up);
      Vec3 diffuse = ambient, spec = Vec3::Zero();
      const double shininess = kind == kMetal ? 120.0 : 30.0, ks = kind == kMetal ? 0.9 : (kind == kGround ? 0.0 : 0.12);
      for (const auto& l : s.lights) {
        const Vec3 ld = (l.position - p).normalized();
        const double ndl = n.dot(ld);
        if (ndl <= 0) continue;
        const double vis = l.shadows ? shadow.visibility(p, n) : 1.0;
        diffuse += Vec3::Constant(l.intensity * ndl * vis);
        const Vec3 h = (ld + v).normalized();
        spec += Vec3::Constant(ks * l.intensity * vis * std::pow(std::max(0.0, n.dot(h)), shininess));
      }
      Vec3 c;
      if (kind == kMetal) {
        const Vec3 r = d - 2.0 * d.dot(n) * n;  // mirror the environment: sky above, dark ground below
        const Vec3 env = r.y() > 0 ? sky(r) : Vec3(0.18, 0.18, 0.17);
        c = 0.25 * base.cwiseProduct(diffuse) + 0.65 * base.cwiseProduct(env) + spec;
      } else {
        c = base.cwiseProduct(diffuse) + spec;
      }
      if (kind == kGround) {  // fade the ground into the horizon haze far from the subject
        const double fog = std::clamp((t / extent - 1.5) / 4.0, 0.0, 1.0);
        c = c * (1.0 - fog) + sky(Vec3(d.x(), 0.0, d.z()).normalized()) * fog;
      }
      hdr[i] = c;
    }
  });

  Image img;
  img.width = width;
  img.height = height;
  img.rgb.resize(std::size_t(width) * std::size_t(height) * 3);
  tbb::parallel_for(0, height, [&](int y) {
    for (int x = 0; x < width; ++x) {
      Vec3 sum = Vec3::Zero();
      for (int sy = 0; sy < kSuper; ++sy)
        for (int sx = 0; sx < kSuper; ++sx)
          sum += hdr[std::size_t(y * kSuper + sy) * std::size_t(W) + std::size_t(x * kSuper + sx)];
      sum /= double(kSuper * kSuper);
      for (int k = 0; k < 3; ++k) {
        const double lin = std::clamp(sum[k], 0.0, 1.0);
        const double srgb = lin <= 0.0031308 ? 12.92 * lin : 1.055 * std::pow(lin, 1.0 / 2.4) - 0.055;
        img.rgb[(std::size_t(y) * std::size_t(width) + std::size_t(x)) * 3 + std::size_t(k)] =
            static_cast<std::uint8_t>(std::lround(srgb * 255.0));
      }
    }
  });
  return img;
}

}  // namespace perifx::render
