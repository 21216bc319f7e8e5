// `perifx render` orchestration (see render_run.hpp): scan the run, frame the camera once for the
// whole sequence, build each frame's scene, render it with POV-Ray (as a program) or the built-in
// rasterizer, write frame.NNNN.png, and optionally encode movie.mp4 with ffmpeg.
#include "tools/render/render_run.hpp"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <tbb/task_arena.h>

#include "io/atomic.hpp"
#include "tools/render/png.hpp"
#include "perifx/scene.hpp"

namespace perifx::render {

namespace fs = std::filesystem;

namespace {

// Runs argv with cwd `dir`, stdout and stderr appended to `log`; returns the exit status (-1 when it
// could not start or was killed). fork/exec rather than system(): no shell quoting of paths.
int run_program(const std::vector<std::string>& argv, const fs::path& dir, const fs::path& log) {
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (fd >= 0) {
      ::dup2(fd, STDOUT_FILENO);
      ::dup2(fd, STDERR_FILENO);
    }
    const int devnull = ::open("/dev/null", O_RDONLY);
    if (devnull >= 0) ::dup2(devnull, STDIN_FILENO);
    if (!dir.empty() && ::chdir(dir.c_str()) != 0) ::_exit(127);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return -1;
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string log_tail(const fs::path& log) {
  std::ifstream in(log);
  std::ostringstream s;
  s << in.rdbuf();
  std::string text = s.str();
  if (text.size() > 1500) text = "..." + text.substr(text.size() - 1500);
  return text;
}

std::string frame_png_name(std::uint64_t k) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "frame.%04llu.png", static_cast<unsigned long long>(k));
  return buf;
}

double particle_radius(const ParticleFrame& p, std::size_t i, const FrameStyle& style) {
  if (i < p.volume.size() && p.volume[i] > 0) return style.particle_scale * std::cbrt(p.volume[i]);
  return style.fallback_radius;
}

struct Bounds {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = Vec3::Constant(-std::numeric_limits<double>::infinity());
  void add(const Vec3& p, double r) {
    lo = lo.cwiseMin(p - Vec3::Constant(r));
    hi = hi.cwiseMax(p + Vec3::Constant(r));
  }
  bool valid() const { return lo.x() <= hi.x(); }
  // Adds the box that holds the points (each with its radius) except the outermost `trim` fraction
  // on each side of each axis, so a few far-flung pieces (single particles shot off by a fracture,
  // stray vertices of tiny fragments) do not shrink the subject to a dot. Few points: all are kept.
  void add_trimmed(const std::vector<Vec3>& points, const std::vector<double>& radius, double trim) {
    const std::size_t n = points.size();
    if (n == 0) return;
    const std::size_t k = static_cast<std::size_t>(std::floor(trim * double(n)));
    std::vector<double> a(n), b(n);
    for (int c = 0; c < 3; ++c) {
      for (std::size_t i = 0; i < n; ++i) {
        const double r = i < radius.size() ? radius[i] : 0.0;
        a[i] = points[i][c] - r;
        b[i] = points[i][c] + r;
      }
      std::nth_element(a.begin(), a.begin() + std::ptrdiff_t(k), a.end());
      std::nth_element(b.begin(), b.begin() + std::ptrdiff_t(n - 1 - k), b.end());
      lo[c] = std::min(lo[c], a[k]);
      hi[c] = std::max(hi[c], b[n - 1 - k]);
    }
  }
};

// Fraction of the points per side and axis that the camera framing may leave out (see add_trimmed).
constexpr double kFramingTrim = 0.005;

}  // namespace

fs::path find_program(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (!path) return {};
  std::stringstream dirs(path);
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    if (dir.empty()) continue;
    const fs::path candidate = fs::path(dir) / name;
    if (::access(candidate.c_str(), X_OK) == 0 && !fs::is_directory(candidate)) return candidate;
  }
  return {};
}

RenderScene frame_scene(const ParticleFrame* particles, const SurfaceFrame* surface,
                        const std::vector<ProjectileState>& projectiles, const FrameStyle& style) {
  RenderScene s;
  auto hidden = [&](const Vec3& p) { return style.cut && style.cut->normal.dot(p) > style.cut->offset; };
  if (surface && !surface->triangle.empty()) {
    const Vec3 neutral(0.66, 0.67, 0.70), crack(0.95, 0.42, 0.08);
    s.triangles.reserve(surface->triangle.size());
    for (std::size_t k = 0; k < surface->triangle.size(); ++k) {
      const auto& t = surface->triangle[k];
      Triangle tri;
      tri.a = surface->vertex[t[0]];
      tri.b = surface->vertex[t[1]];
      tri.c = surface->vertex[t[2]];
      if (hidden((tri.a + tri.b + tri.c) / 3.0)) continue;
      const bool is_crack = k < surface->crack.size() && surface->crack[k] != 0;
      if (is_crack) tri.color = crack;
      else if (style.color_by == ColorBy::damage && surface->damage.size() == surface->vertex.size())
        tri.color = damage_color((surface->damage[t[0]] + surface->damage[t[1]] + surface->damage[t[2]]) / 3.0);
      else tri.color = neutral;
      s.triangles.push_back(tri);
    }
  } else if (particles) {
    s.spheres.reserve(particles->position.size());
    const bool by_damage = style.color_by == ColorBy::damage && particles->damage.size() == particles->position.size();
    const bool by_material =
        style.color_by == ColorBy::material && particles->material.size() == particles->position.size();
    for (std::size_t i = 0; i < particles->position.size(); ++i) {
      if (hidden(particles->position[i])) continue;
      Sphere sp;
      sp.center = particles->position[i];
      sp.radius = particle_radius(*particles, i, style);
      sp.color = by_damage ? damage_color(particles->damage[i])
                 : by_material ? material_color(particles->material[i])
                               : material_color(0);
      s.spheres.push_back(sp);
    }
  }
  for (const auto& p : projectiles) {
    if (hidden(p.center)) continue;
    Sphere sp;
    sp.center = p.center;
    sp.radius = p.radius > 0 ? p.radius : style.projectile_radius;
    sp.color = Vec3(0.72, 0.73, 0.76);
    s.metal.push_back(sp);
  }
  return s;
}

RenderSummary render_run(const RenderOptions& opt) {
  using clock = std::chrono::steady_clock;
  auto note = [&](const std::string& text) {
    if (opt.on_note) opt.on_note(text);
  };
  if (opt.width < 16 || opt.height < 16) throw std::invalid_argument("image size must be at least 16x16");
  const RunDirectory run = io::scan_run_directory(opt.run_directory);

  std::vector<FrameFiles> frames;
  for (const auto& f : run.frames)
    if ((!opt.first_frame || f.index >= *opt.first_frame) && (!opt.last_frame || f.index <= *opt.last_frame))
      frames.push_back(f);
  if (frames.empty())
    throw RunDirError("no frames of '" + run.path.string() + "' are in the requested range (it has frames " +
                       std::to_string(run.frames.front().index) + " to " + std::to_string(run.frames.back().index) + ")");

  RenderSummary summary;
  summary.output_directory = opt.output_directory ? *opt.output_directory : run.path / "render";

  // Backend.
  const fs::path povray = find_program("povray");
  summary.backend = opt.backend == Backend::automatic ? (povray.empty() ? Backend::builtin : Backend::povray) : opt.backend;
  if (summary.backend == Backend::povray && povray.empty())
    throw std::runtime_error("--backend povray: 'povray' is not on PATH (Debian: apt-get install povray)");
  if (opt.backend == Backend::automatic && povray.empty())
    note("povray not found: using the built-in rasterizer (install povray for ray-traced frames)");

  // Scene file (optional): projectile radii and a ground collider.
  std::vector<double> scene_radii;
  std::optional<double> scene_ground;
  if (opt.scene_file) {
    const auto sc = scene::load_scene_file(*opt.scene_file);
    for (const auto& p : sc.projectiles) scene_radii.push_back(p.radius);
    for (const auto& c : sc.colliders)
      if (c.kind == scene::Collider::Kind::plane && c.normal.normalized().y() > 0.999)
        scene_ground = scene_ground ? std::max(*scene_ground, c.point.y()) : c.point.y();
  }

  // Surface or particles. The surface PLY/OBJ carries no damage, so an explicit --color-by damage
  // draws the particles unless --draw surface insists.
  const bool any_surface = std::any_of(frames.begin(), frames.end(), [](const FrameFiles& f) { return !f.surface.empty(); });
  const bool any_particles =
      std::any_of(frames.begin(), frames.end(), [](const FrameFiles& f) { return !f.particles.empty(); });
  if (opt.draw == Draw::surface && !any_surface)
    throw RunDirError("--draw surface: '" + run.path.string() +
                       "' has no surface.NNNN.ply/.obj frames in the range (add \"surface_ply\" or \"obj\" to "
                       "the scene's output.formats)");
  if (opt.draw == Draw::particles && !any_particles)
    throw RunDirError("--draw particles: '" + run.path.string() + "' has no particles.NNNN.vtu/.ply frames in the range");
  bool draw_surface = opt.draw == Draw::surface;
  if (opt.draw == Draw::automatic && any_surface) {
    draw_surface = true;
    if (opt.color_by == ColorBy::damage && any_particles) {
      const auto first = std::find_if(frames.begin(), frames.end(), [](const FrameFiles& f) { return !f.surface.empty(); });
      const SurfaceFrame probe = io::read_surface_frame(first->surface);
      if (probe.damage.size() != probe.vertex.size()) {
        draw_surface = false;
        note("--color-by damage: the surface files have no damage, drawing the particles (--draw surface to keep the "
             "surface, with crack faces highlighted)");
      }
    }
  }
  // A frame without the chosen kind of file is drawn from the other one.
  auto use_surface = [&](const FrameFiles& f) { return f.particles.empty() || (draw_surface && !f.surface.empty()); };

  ColorBy color_by = opt.color_by;
  FrameStyle style;
  style.particle_scale = opt.particle_scale;
  style.cut = opt.cut;

  // Framing: the bounds of up to five frames spread over the range (first and last included), each
  // without its outermost 0.5% of points per side (add_trimmed). The range is the rendered frames, or
  // --fit-frames (e.g. the intact object before it shatters, so flying debris may leave the picture).
  std::vector<FrameFiles> fit = frames;
  if (opt.fit_first || opt.fit_last) {
    fit.clear();
    for (const auto& f : run.frames)
      if ((!opt.fit_first || f.index >= *opt.fit_first) && (!opt.fit_last || f.index <= *opt.fit_last)) fit.push_back(f);
    if (fit.empty())
      throw RunDirError("no frames of '" + run.path.string() + "' are in the --fit-frames range (it has frames " +
                         std::to_string(run.frames.front().index) + " to " + std::to_string(run.frames.back().index) + ")");
  }
  Bounds bounds;
  double ground = std::numeric_limits<double>::infinity();
  bool need_projectile_radius = false;
  std::size_t samples = std::min<std::size_t>(5, fit.size());
  for (std::size_t s = 0; s < samples; ++s) {
    const std::size_t k = samples == 1 ? 0 : s * (fit.size() - 1) / (samples - 1);
    const FrameFiles& f = fit[k];
    if (use_surface(f)) {
      const auto surf = io::read_surface_frame(f.surface);
      Bounds b;
      b.add_trimmed(surf.vertex, {}, kFramingTrim);
      if (b.valid()) bounds.add(b.lo, 0.0), bounds.add(b.hi, 0.0), ground = std::min(ground, b.lo.y());
    } else if (!f.particles.empty()) {
      const auto p = io::read_particle_frame(f.particles);
      if (p.volume.size() != p.position.size() && !p.position.empty() && s == 0) {
        Bounds b;
        for (const auto& x : p.position) b.add(x, 0.0);
        const Vec3 e = (b.hi - b.lo).cwiseMax(Vec3::Constant(1e-6));
        style.fallback_radius = 0.5 * std::cbrt(e.prod() / double(p.position.size()));
        note("no volume field: drawing particles with radius " + std::to_string(style.fallback_radius) + " m");
      }
      std::vector<double> radius(p.position.size());
      for (std::size_t i = 0; i < p.position.size(); ++i) radius[i] = particle_radius(p, i, style);
      Bounds b;
      b.add_trimmed(p.position, radius, kFramingTrim);
      if (b.valid()) bounds.add(b.lo, 0.0), bounds.add(b.hi, 0.0), ground = std::min(ground, b.lo.y());
    }
    for (const auto& pr : io::projectiles_at(run, f)) {
      if (pr.radius <= 0 && pr.id >= scene_radii.size()) need_projectile_radius = true;
      bounds.add(pr.center, 0.0);
    }
  }
  if (!bounds.valid()) throw RunDirError("the frames of '" + run.path.string() + "' hold no particles or triangles");
  const double diag = std::max((bounds.hi - bounds.lo).norm(), 1e-6);
  style.projectile_radius = opt.projectile_radius ? *opt.projectile_radius : 0.08 * diag;
  if (need_projectile_radius && !opt.projectile_radius)
    note("projectiles.csv has no radius column: drawing projectiles with radius " + std::to_string(style.projectile_radius) +
         " m (pass --scene SCENE.json or --projectile-radius R)");
  // Projectile extents at the sampled frames (their radius is known now).
  for (std::size_t s = 0; s < samples; ++s) {
    const std::size_t k = samples == 1 ? 0 : s * (fit.size() - 1) / (samples - 1);
    for (const auto& pr : io::projectiles_at(run, fit[k])) {
      const double r = pr.radius > 0 ? pr.radius : pr.id < scene_radii.size() ? scene_radii[pr.id] : style.projectile_radius;
      bounds.add(pr.center, r);
      ground = std::min(ground, pr.center.y() - r);
    }
  }
  if (scene_ground) ground = *scene_ground;
  if (color_by == ColorBy::automatic) {
    // Damage colours only say something once something is damaged: look at the last rendered frame.
    bool damaged = false;
    if (!frames.back().particles.empty()) {
      const auto last = io::read_particle_frame(frames.back().particles);
      damaged = std::any_of(last.damage.begin(), last.damage.end(), [](double d) { return d > 0.0; });
    }
    color_by = damaged ? ColorBy::damage : ColorBy::material;
  }
  style.color_by = color_by;

  const double aspect = double(opt.width) / double(opt.height);
  // Frame the box including the ground line under it, so the contact with the ground is in view.
  Vec3 frame_lo = bounds.lo;
  frame_lo.y() = std::min(frame_lo.y(), ground);
  if (!(opt.view.norm() > 0) || !opt.view.allFinite()) throw std::invalid_argument("the view direction must be a non-zero vector");
  if (!(opt.zoom > 0) || !std::isfinite(opt.zoom)) throw std::invalid_argument("the zoom must be a positive number");
  Camera camera = frame_box(frame_lo, bounds.hi, aspect, 35.0, opt.view);
  camera.position = camera.target + (camera.position - camera.target) / opt.zoom;
  const auto lights = default_lights(camera, frame_lo, bounds.hi);
  const double tile = std::pow(10.0, std::round(std::log10(diag / 8.0)));

  fs::path temp;
  if (summary.backend == Backend::povray) {
    temp = fs::temp_directory_path() / ("perifx-render-" + std::to_string(::getpid()));
    fs::create_directories(temp);
  }
  struct TempCleanup {
    fs::path dir;
    ~TempCleanup() {
      std::error_code ec;
      if (!dir.empty()) fs::remove_all(dir, ec);
    }
  } cleanup{temp};

  const auto start = clock::now();
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const FrameFiles& f = frames[k];
    std::optional<ParticleFrame> particles;
    std::optional<SurfaceFrame> surface;
    if (use_surface(f)) surface = io::read_surface_frame(f.surface);
    else particles = io::read_particle_frame(f.particles);
    auto projectiles = io::projectiles_at(run, f);
    for (auto& pr : projectiles)
      if (pr.radius <= 0 && pr.id < scene_radii.size()) pr.radius = scene_radii[pr.id];
    RenderScene scene = frame_scene(particles ? &*particles : nullptr, surface ? &*surface : nullptr, projectiles, style);
    scene.camera = camera;
    scene.lights = lights;
    scene.ground_y = ground;
    scene.ground_tile = tile;

    const fs::path target = summary.output_directory / frame_png_name(f.index);
    if (summary.backend == Backend::builtin) {
      Image img;
      if (opt.threads > 0) {
        tbb::task_arena arena(opt.threads);
        arena.execute([&] { img = rasterize(scene, opt.width, opt.height); });
      } else {
        img = rasterize(scene, opt.width, opt.height);
      }
      write_png(target, img.width, img.height, img.rgb);
    } else {
      const auto files = povray_scene(scene, opt.width, opt.height, "frame_data.inc");
      io::write_atomic(temp / "frame.pov", [&](std::ostream& os) { os << files.scene; });
      io::write_atomic(temp / "frame_data.inc", [&](std::ostream& os) { os << files.data; });
      const fs::path log = temp / "povray.log";
      std::error_code ec;
      fs::remove(log, ec);
      fs::remove(temp / "frame.png", ec);
      // Run inside the temp directory with relative names: Debian's povray.conf restricts file I/O
      // to the current directory.
      std::vector<std::string> args = {povray.string(), "+Iframe.pov", "+Oframe.png", "+W" + std::to_string(opt.width),
                                       "+H" + std::to_string(opt.height), "+A0.3", "+AM2", "+R3", "-D", "+FN", "-V", "-GA"};
      if (opt.threads > 0) args.push_back("+WT" + std::to_string(opt.threads));  // POV-Ray's work threads
      const int rc = run_program(args, temp, log);
      if (rc != 0 || !fs::exists(temp / "frame.png"))
        throw std::runtime_error("povray failed on frame " + std::to_string(f.index) + " (exit " + std::to_string(rc) +
                                 "); its output:\n" + log_tail(log));
      std::ifstream in(temp / "frame.png", std::ios::binary);
      std::ostringstream png;
      png << in.rdbuf();
      const std::string bytes = png.str();
      io::write_atomic(target, [&](std::ostream& os) { os.write(bytes.data(), std::streamsize(bytes.size())); });
    }
    ++summary.frames;
    if (opt.on_frame) {
      RenderProgress p;
      p.frame = k + 1;
      p.frames = frames.size();
      p.index = f.index;
      p.wall_seconds = std::chrono::duration<double>(clock::now() - start).count();
      p.eta_seconds = p.wall_seconds / double(p.frame) * double(p.frames - p.frame);
      opt.on_frame(p);
    }
  }

  if (opt.mp4) {
    const fs::path ffmpeg = find_program("ffmpeg");
    if (ffmpeg.empty()) {
      note("ffmpeg not found: no movie written (Debian: apt-get install ffmpeg)");
    } else {
      const fs::path movie = summary.output_directory / "movie.mp4";
      const fs::path log = summary.output_directory / "ffmpeg.log";
      std::error_code ec;
      fs::remove(log, ec);
      char rate[32];
      std::snprintf(rate, sizeof rate, "%.6g", run.frame_rate);
      const int rc = run_program(
          {ffmpeg.string(), "-y", "-loglevel", "error", "-framerate", rate, "-start_number",
           std::to_string(frames.front().index), "-i", (summary.output_directory / "frame.%04d.png").string(),
           "-frames:v", std::to_string(frames.size()), "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-c:v", "libx264",
           "-pix_fmt", "yuv420p", "-crf", "18", movie.string()},
          {}, log);
      if (rc != 0) throw std::runtime_error("ffmpeg failed (exit " + std::to_string(rc) + "); its output:\n" + log_tail(log));
      fs::remove(log, ec);
      summary.movie = movie;
    }
  }
  return summary;
}

}  // namespace perifx::render
