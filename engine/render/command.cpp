// `perifx render` command line: see command.hpp.
#include "render/command.hpp"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "io/io.hpp"
#include "render/render_run.hpp"
#include "perifx/scene.hpp"

namespace perifx::render {
namespace {

struct UsageError {
  std::string message;
};

std::string clock_text(double seconds) {
  const long s = std::lround(std::max(0.0, seconds));
  char buf[32];
  std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  return buf;
}

long long to_integer(const std::string& flag, const std::string& v, long long min) {
  std::size_t used = 0;
  long long x = 0;
  try {
    x = std::stoll(v, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != v.size() || x < min)
    throw UsageError{flag + " expects an integer >= " + std::to_string(min) + ", got '" + v + "'"};
  return x;
}

double to_positive(const std::string& flag, const std::string& v) {
  char* end = nullptr;
  const double x = std::strtod(v.c_str(), &end);
  if (v.empty() || *end != '\0' || !(x > 0) || !std::isfinite(x))
    throw UsageError{flag + " expects a positive number, got '" + v + "'"};
  return x;
}

// `count` comma-separated finite numbers.
std::vector<double> to_numbers(const std::string& flag, const std::string& v, int count, const char* form) {
  std::vector<double> out;
  std::size_t at = 0;
  for (int j = 0; j < count; ++j) {
    const auto comma = j + 1 < count ? v.find(',', at) : v.size();
    if (comma == std::string::npos) throw UsageError{flag + " expects " + form + ", got '" + v + "'"};
    const std::string item = v.substr(at, comma - at);
    char* end = nullptr;
    const double x = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0' || !std::isfinite(x)) throw UsageError{flag + " expects " + form + ", got '" + v + "'"};
    out.push_back(x);
    at = comma + 1;
  }
  return out;
}

}  // namespace

int render_command(int argc, char** argv) {
  RenderOptions opt;
  bool quiet = false;
  try {
    for (int k = 2; k < argc; ++k) {
      const std::string arg = argv[k];
      auto value = [&]() -> std::string {
        if (k + 1 >= argc) throw UsageError{arg + " needs a value"};
        return argv[++k];
      };
      if (arg == "--out") opt.output_directory = value();
      else if (arg == "--width") opt.width = int(to_integer(arg, value(), 16));
      else if (arg == "--height") opt.height = int(to_integer(arg, value(), 16));
      else if (arg == "--mp4") opt.mp4 = true;
      else if (arg == "--quiet") quiet = true;
      else if (arg == "--scene") opt.scene_file = value();
      else if (arg == "--projectile-radius") opt.projectile_radius = to_positive(arg, value());
      else if (arg == "--particle-scale") opt.particle_scale = to_positive(arg, value());
      else if (arg == "--threads") opt.threads = int(to_integer(arg, value(), 1));
      else if (arg == "--zoom") opt.zoom = to_positive(arg, value());
      else if (arg == "--view") {
        // X,Y,Z: the direction from the subject to the camera (Y up), e.g. 0,0,1 looks along -z.
        const auto c = to_numbers(arg, value(), 3, "X,Y,Z");
        opt.view = Vec3(c[0], c[1], c[2]);
        if (!(opt.view.norm() > 0)) throw UsageError{"--view needs a non-zero direction"};
      } else if (arg == "--cut") {
        // NX,NY,NZ,D: hide what lies on the side n·x > D of the plane (n is normalized here).
        const auto c = to_numbers(arg, value(), 4, "NX,NY,NZ,D");
        const Vec3 n(c[0], c[1], c[2]);
        if (!(n.norm() > 0)) throw UsageError{"--cut needs a non-zero normal"};
        opt.cut = CutPlane{n.normalized(), c[3] / n.norm()};
      }
      else if (arg == "--draw") {
        const std::string v = value();
        if (v == "auto") opt.draw = Draw::automatic;
        else if (v == "particles") opt.draw = Draw::particles;
        else if (v == "surface") opt.draw = Draw::surface;
        else throw UsageError{"--draw expects auto, particles or surface, got '" + v + "'"};
      }
      else if (arg == "--color-by") {
        const std::string v = value();
        if (v == "damage") opt.color_by = ColorBy::damage;
        else if (v == "material") opt.color_by = ColorBy::material;
        else if (v == "none") opt.color_by = ColorBy::none;
        else throw UsageError{"--color-by expects damage, material or none, got '" + v + "'"};
      } else if (arg == "--backend") {
        const std::string v = value();
        if (v == "povray") opt.backend = Backend::povray;
        else if (v == "builtin") opt.backend = Backend::builtin;
        else throw UsageError{"--backend expects povray or builtin, got '" + v + "'"};
      } else if (arg == "--frames" || arg == "--fit-frames") {
        // A:B (inclusive), A: (from A), :B (up to B) or A (just A).
        const std::string v = value();
        const auto colon = v.find(':');
        const std::string a = v.substr(0, colon), b = colon == std::string::npos ? a : v.substr(colon + 1);
        auto& first = arg == "--frames" ? opt.first_frame : opt.fit_first;
        auto& last = arg == "--frames" ? opt.last_frame : opt.fit_last;
        if (!a.empty()) first = std::uint64_t(to_integer(arg, a, 0));
        if (!b.empty()) last = std::uint64_t(to_integer(arg, b, 0));
        if (first && last && *last < *first) throw UsageError{arg + " A:B needs A <= B, got '" + v + "'"};
      } else if (!arg.empty() && arg[0] == '-') {
        throw UsageError{"unknown option '" + arg + "'"};
      } else if (opt.run_directory.empty()) {
        opt.run_directory = arg;
      } else {
        throw UsageError{"unexpected argument '" + arg + "'"};
      }
    }
    if (opt.run_directory.empty()) throw UsageError{"'render' needs a run directory"};
  } catch (const UsageError& e) {
    std::cerr << "perifx: " << e.message << "\nusage: perifx\n" << kRenderUsage;
    return 1;
  }

  const bool tty = ::isatty(STDERR_FILENO) && !quiet;
  auto last_print = std::chrono::steady_clock::now();
  opt.on_note = [&](const std::string& text) { std::cerr << "perifx: note: " << text << "\n"; };
  if (!quiet)
    opt.on_frame = [&](const RenderProgress& p) {
      const auto now = std::chrono::steady_clock::now();
      const bool last = p.frame == p.frames;
      if (!tty && !last && std::chrono::duration<double>(now - last_print).count() < 10.0) return;
      last_print = now;
      char buf[200];
      std::snprintf(buf, sizeof buf, "render frame %zu/%zu (#%llu)  elapsed %s  ETA %s", p.frame, p.frames,
                    static_cast<unsigned long long>(p.index), clock_text(p.wall_seconds).c_str(),
                    clock_text(p.eta_seconds).c_str());
      if (tty) std::cerr << "\r" << buf << "\x1b[K" << (last ? "\n" : "") << std::flush;
      else std::cerr << buf << "\n";
    };
  try {
    const auto s = render_run(opt);
    if (!quiet) {
      std::cerr << "done: " << s.frames << " frames (" << (s.backend == Backend::povray ? "povray" : "built-in")
                << ") in " << s.output_directory.string() << "\n";
      if (s.movie) std::cerr << "      movie: " << s.movie->string() << "\n";
    }
    return 0;
  } catch (const RunDataError& e) {
    std::cerr << "perifx: error: " << e.what() << "\n";
    return 2;
  } catch (const scene::SceneError& e) {
    std::cerr << "perifx: error: " << e.what() << "\n";
    return 2;
  } catch (const io::IoError& e) {
    std::cerr << "perifx: error: " << e.what() << "\n";
    return 3;
  } catch (const std::invalid_argument& e) {
    std::cerr << "perifx: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "perifx: error: " << e.what() << "\n";
    return 5;
  }
}

}  // namespace perifx::render
