// perifx command line: run, check, info and spec for scene files. Exit codes (also in the README):
//   0 success   1 usage error   2 invalid scene or mesh   3 output could not be written
//   4 time step above the stable limit   5 internal error
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "compare.hpp"
#include "geometry/geometry.hpp"
#include "io/io.hpp"
#include "perifx/world.hpp"
#include "render/command.hpp"
#include "runner.hpp"
#include "components/world_state.hpp"

namespace {

enum Exit { kOk = 0, kUsage = 1, kScene = 2, kOutput = 3, kUnstable = 4, kInternal = 5 };

const std::string kUsageText = std::string(
    "usage: perifx <command> [options]\n"
    "  run SCENE.json [--out DIR] [--frames N] [--threads N] [--quiet] [--solver S] [--dt SECONDS]\n"
    "                      simulate and write frames (VTU + PVD for ParaView, PLY for Houdini/Blender);\n"
    "                      --solver peridynamics|fem_linear|fem_corotated and --dt override the scene\n"
    "  compare RUN_A RUN_B position deviation of run B from reference run A per frame, over A's\n"
    "                      bounding-box diagonal at frame 0 (paper §6); writes RUN_A/compare.csv.\n"
    "                      Same scene; an FEM run may also be of a finer mesh (interpolated)\n"
    "  check SCENE.json    validate the scene without running it\n"
    "  info SCENE.json [--threads N]\n"
    "                      particles, bonds, memory and the stable time step\n"
    "  spec                print the scene format reference (markdown)\n"
    ) + perifx::render::kRenderUsage +
    "exit codes: 0 ok, 1 usage, 2 invalid scene or mesh, 3 output error, 4 unstable time step, 5 internal\n";

struct Args {
  std::string command, scene;
  std::optional<std::string> out;
  std::optional<std::uint64_t> frames;
  std::optional<int> threads;
  std::optional<std::string> solver;
  std::optional<double> dt;
  std::string second;  // compare: RUN_B
  bool quiet = false;
};

[[noreturn]] void usage_error(const std::string& message) {
  std::cerr << "perifx: " << message << "\n" << kUsageText;
  std::exit(kUsage);
}

long long parse_count(const std::string& flag, const std::string& value, long long min) {
  try {
    std::size_t used = 0;
    const long long v = std::stoll(value, &used);
    if (used != value.size() || v < min) throw std::invalid_argument("range");
    return v;
  } catch (const std::exception&) {
    usage_error(flag + " expects an integer >= " + std::to_string(min) + ", got '" + value + "'");
  }
}

Args parse(int argc, char** argv) {
  if (argc < 2) usage_error("no command given");
  Args a;
  a.command = argv[1];
  if (a.command == "-h" || a.command == "--help" || a.command == "help") {
    std::cout << kUsageText;
    std::exit(kOk);
  }
  for (int k = 2; k < argc; ++k) {
    const std::string arg = argv[k];
    auto value = [&]() -> std::string {
      if (k + 1 >= argc) usage_error(arg + " needs a value");
      return argv[++k];
    };
    if (arg == "--out") a.out = value();
    else if (arg == "--frames") a.frames = static_cast<std::uint64_t>(parse_count(arg, value(), 1));
    else if (arg == "--threads") a.threads = static_cast<int>(parse_count(arg, value(), 1));
    else if (arg == "--quiet") a.quiet = true;
    else if (arg == "--solver") {
      a.solver = value();
      if (*a.solver != "peridynamics" && *a.solver != "fem_linear" && *a.solver != "fem_corotated")
        usage_error("--solver expects peridynamics, fem_linear or fem_corotated, got '" + *a.solver + "'");
    } else if (arg == "--dt") {
      const std::string v = value();
      char* end = nullptr;
      a.dt = std::strtod(v.c_str(), &end);
      if (end != v.c_str() + v.size() || !(*a.dt > 0.0) || !std::isfinite(*a.dt))
        usage_error("--dt expects a positive number of seconds, got '" + v + "'");
    }
    else if (!arg.empty() && arg[0] == '-') usage_error("unknown option '" + arg + "'");
    else if (a.scene.empty()) a.scene = arg;
    else if (a.command == "compare" && a.second.empty()) a.second = arg;
    else usage_error("unexpected argument '" + arg + "'");
  }
  if (a.command == "compare" && a.second.empty()) usage_error("'compare' needs two run directories");
  if (a.command != "spec" && a.scene.empty()) usage_error("'" + a.command + "' needs a scene file");
  return a;
}

std::string human_bytes(double b) {
  const char* units[] = {"B", "KiB", "MiB", "GiB"};
  int u = 0;
  while (b >= 1024.0 && u < 3) b /= 1024.0, ++u;
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f %s", b, units[u]);
  return buf;
}

std::string clock_text(double seconds) {
  const long s = std::lround(std::max(0.0, seconds));
  char buf[32];
  std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  return buf;
}

perifx::scene::Scene load(const Args& a) {
  auto sc = perifx::scene::load_scene_file(a.scene);
  if (a.threads) sc.threads = *a.threads;
  if (a.solver) {
    using perifx::scene::Solver;
    sc.solver = *a.solver == "fem_linear" ? Solver::fem_linear
                : *a.solver == "fem_corotated" ? Solver::fem_corotated : Solver::peridynamics;
  }
  if (a.dt) sc.time.dt = *a.dt;
  return sc;
}

// compare RUN_A RUN_B: exit 2 when the runs cannot be read or do not match.
int cmd_compare(const Args& a) {
  try {
    const auto r = perifx::compare_runs(a.scene, a.second);
    char buf[256];
    std::cout << "reference (A)    " << a.scene << " (" << r.solver_a << ")\n";
    std::cout << "compared  (B)    " << a.second << " (" << r.solver_b << ")\n";
    std::cout << "mapping          " << r.mapping << "\n";
    std::snprintf(buf, sizeof buf, "points           %zu per frame; diagonal d = %.6g m (A, frame 0)\n", r.points, r.diagonal);
    std::cout << buf;
    if (r.frames_a != r.frames_b)
      std::cout << "note             frame counts differ (" << r.frames_a << " vs " << r.frames_b << "); compared the first "
                << r.frames.size() << "\n";
    std::cout << "frame     time [s]   max |dx|/d   mean |dx|/d\n";
    for (std::size_t k = 0; k < r.frames.size(); ++k) {
      std::snprintf(buf, sizeof buf, "%5zu  %11.5g  %11.4e  %11.4e\n", k, r.frames[k].time_a, r.frames[k].max_error,
                    r.frames[k].mean_error);
      std::cout << buf;
    }
    std::snprintf(buf, sizeof buf, "overall              %11.4e  %11.4e   (max %.3g%%, mean %.3g%% of the diagonal)\n",
                  r.max_error, r.mean_error, 100.0 * r.max_error, 100.0 * r.mean_error);
    std::cout << buf;
    perifx::write_compare_csv(r, std::filesystem::path(a.scene) / "compare.csv");
    return kOk;
  } catch (const perifx::CompareError& e) {
    std::cerr << "perifx: compare: " << e.what() << "\n";
    return kScene;
  }
}

int cmd_check(const Args& a) {
  const auto sc = load(a);
  std::cout << a.scene << ": ok (" << sc.materials.size() << " materials, " << sc.bodies.size() << " bodies, "
            << sc.boundary_conditions.size() << " boundary conditions, " << sc.colliders.size() << " colliders)\n";
  return kOk;
}

// Prints the stable-step verdict; returns false when dt is above the limit.
bool report_time_step(const perifx::World& world, std::ostream& out) {
  const double stable = world.stable_time_step();
  const double dt = world.dt();
  char buf[256];
  std::snprintf(buf, sizeof buf, "time step        %.3g s (stable limit %.3g s, %.0f%% of it)\n", dt, stable,
                100.0 * dt / stable);
  out << buf;
  if (dt > stable) {
    std::snprintf(buf, sizeof buf,
                  "error: time/dt = %.3g s exceeds the stable explicit step %.3g s; the run would blow up. "
                  "Use time/dt <= %.3g.\n", dt, stable, 0.9 * stable);
    std::cerr << buf;
    return false;
  }
  if (dt > 0.8 * stable) out << "warning: time/dt is within 20% of the stable limit; large deformation may still blow up\n";
  return true;
}

int cmd_info(const Args& a) {
  perifx::World world(load(a));
  const auto mem = world.memory();
  const auto& st = world.state();
  std::cout << "scene            " << world.scene().name << "\n";
  std::cout << "particles        " << world.particle_count() << "\n";
  std::cout << "bonds            " << world.bond_count() << " directed ("
            << (world.particle_count() ? double(world.bond_count()) / double(world.particle_count()) : 0.0)
            << " per particle)\n";
  for (const auto& b : st.bodies)
    std::cout << "body             " << b.name << ": " << b.particle_count << " particles, lambda " << b.mean_edge_length
              << " m, horizon " << b.horizon << " m\n";
  std::cout << "memory           particles " << human_bytes(double(mem.particle_bytes)) << " ("
            << mem.bytes_per_particle << " B each), bonds " << human_bytes(double(mem.bond_bytes)) << " ("
            << mem.bytes_per_bond << " B each), mesh " << human_bytes(double(mem.mesh_bytes)) << "\n";
  std::cout << "threads          " << world.threads() << "\n";
  const bool ok = report_time_step(world, std::cout);
  std::cout << "schedule\n" << world.schedule();
  return ok ? kOk : kUnstable;
}

int cmd_run(const Args& a) {
  perifx::World world(load(a));
  const bool tty = ::isatty(STDERR_FILENO) && !a.quiet;
  if (!a.quiet)
    std::cerr << "perifx: " << world.scene().name << ": " << world.particle_count() << " particles, "
              << world.bond_count() << " bonds, " << world.threads() << " threads\n";
  if (!report_time_step(world, a.quiet ? std::clog : std::cerr)) return kUnstable;
  perifx::RunOptions opt;
  if (a.out) opt.output_directory = *a.out;
  opt.frames = a.frames;
  auto last_print = std::chrono::steady_clock::now();
  if (!a.quiet)
    opt.on_frame = [&](const perifx::RunProgress& p) {
      const auto now = std::chrono::steady_clock::now();
      const bool last = p.frame == p.frames;
      if (!tty && !last && std::chrono::duration<double>(now - last_print).count() < 10.0) return;
      last_print = now;
      char buf[200];
      std::snprintf(buf, sizeof buf, "frame %llu/%llu  step %llu/%llu  %.0f steps/s  elapsed %s  ETA %s",
                    (unsigned long long)p.frame, (unsigned long long)p.frames, (unsigned long long)p.step,
                    (unsigned long long)p.steps, p.steps_per_second, clock_text(p.wall_seconds).c_str(),
                    clock_text(p.eta_seconds).c_str());
      if (tty) std::cerr << "\r" << buf << "\x1b[K" << (last ? "\n" : "") << std::flush;
      else std::cerr << buf << "\n";
    };
  const auto s = perifx::run_world(world, opt);
  if (!a.quiet) {
    char buf[400];
    std::snprintf(buf, sizeof buf,
                  "done: %zu particles, %zu bonds (%zu alive), %zu fragments, %llu steps, %llu frames, %.3g s simulated\n"
                  "      wall %.2f s stepping + %.2f s output, %.3g bond-updates/s on %d threads\n"
                  "      output: %s\n",
                  s.particles, s.bonds, s.alive_bonds, s.fragments, (unsigned long long)s.steps, (unsigned long long)s.frames,
                  s.simulated_seconds, s.wall_seconds, s.output_seconds, s.bond_updates_per_second, s.threads,
                  s.output_directory.string().c_str());
    std::cerr << buf;
  }
  return kOk;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 2 && std::string(argv[1]) == "render") return perifx::render::render_command(argc, argv);
  const Args a = parse(argc, argv);
  try {
    if (a.command == "run") return cmd_run(a);
    if (a.command == "compare") return cmd_compare(a);
    if (a.command == "check") return cmd_check(a);
    if (a.command == "info") return cmd_info(a);
    if (a.command == "spec") {
      std::cout << perifx::scene::scene_format_markdown();
      return kOk;
    }
    usage_error("unknown command '" + a.command + "'");
  } catch (const perifx::scene::SceneError& e) {
    std::cerr << "perifx: error: " << e.what() << "\n";
    return kScene;
  } catch (const perifx::geometry::GeometryError& e) {
    std::cerr << "perifx: error: " << e.what() << "\n";
    return kScene;
  } catch (const perifx::io::IoError& e) {
    std::cerr << "perifx: error: " << e.what() << "\n";
    return kOutput;
  } catch (const std::invalid_argument& e) {
    std::cerr << "perifx: error: " << e.what() << "\n";
    return kScene;
  } catch (const std::exception& e) {
    std::cerr << "perifx: internal error: " << e.what() << "\n";
    return kInternal;
  }
}
