// `perifx render` once its options are parsed: progress display and exit codes (see command.hpp).
#include "tools/render/command.hpp"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "io/atomic.hpp"
#include "io/run_dir.hpp"
#include "tools/render/render_run.hpp"
#include "perifx/scene.hpp"

namespace perifx::render {
namespace {

std::string clock_text(double seconds) {
  const long s = std::lround(std::max(0.0, seconds));
  char buf[32];
  std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  return buf;
}

}  // namespace

int render_command(RenderOptions opt, bool quiet) {
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
  } catch (const io::RunDirError& e) {
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
