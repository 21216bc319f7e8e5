// perifx command line (CLI11): run, check, info and spec for scene files, compare, render and check-surface for run
// directories; every command has --help, and perifx --version. Exit codes (also in the README):
//   0 success   1 usage error   2 invalid scene or mesh   3 output could not be written
//   4 time step above the stable limit   5 internal error
//   6 interrupted by SIGTERM/SIGINT (the frame in progress, a checkpoint and the summary were written)
//   7 simulation became unstable   8 not enough memory (estimate above the available memory; run --force overrides)
#include <unistd.h>

#include <csignal>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "distributed/runtime.hpp"
#include "geometry/geometry.hpp"
#include "io/atomic.hpp"
#include "perifx/world.hpp"
#include "runner.hpp"
#include "setup/preflight.hpp"
#include "setup/world_setup.hpp"
#include "systems/yield_law.hpp"
#include "tools/compare.hpp"
#include "tools/crack_stats.hpp"
#include "tools/render/command.hpp"
#include "tools/surface_check.hpp"

namespace {

enum Exit { kOk = 0, kUsage = 1, kScene = 2, kOutput = 3, kUnstable = 4, kInternal = 5, kInterrupted = 6,
           kBlowUp = 7, kMemory = 8 };

// The one global of the program: a signal handler can only set a flag. `perifx run` installs
// on_stop_signal for SIGTERM and SIGINT (one-shot: a second signal kills as usual) and the run loop
// polls the flag after every frame (RunOptions::stop_requested).
volatile std::sig_atomic_t g_stop_signal = 0;
extern "C" void on_stop_signal(int sig) { g_stop_signal = sig; }

// Usage errors are one line on stderr and exit code 1; `perifx <command> --help` has the details.
struct UsageError {
  std::string message;
};

// What the command line asked for, as CLI11 parsed it; values stay text until checked below, so
// every bad value gets the same kind of message.
struct Args {
  std::string command, scene;
  std::string second;  // compare: RUN_B
  std::optional<std::string> out, frames, threads, solver, dt, contact_time_scale, progress, horizon;
  std::optional<std::string> ranks;  // info --ranks
  bool quiet = false, overwrite = false, resume = false, force = false;
  bool render = false;  // run --render
  bool profile = false;  // run --profile
  bool details = false;  // check-surface --details
  // crack-stats
  std::optional<std::string> frame, mirror, mirror_at, load_axis, axis_tolerance, radius;
  bool include_initial = false;
  const perifx::distributed::MpiSession* mpi = nullptr;  // run under mpirun: distribute the world
};

long long parse_count(const std::string& flag, const std::string& value, long long min) {
  std::size_t used = 0;
  long long v = 0;
  try {
    v = std::stoll(value, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != value.size() || v < min)
    throw UsageError{flag + " expects an integer >= " + std::to_string(min) + ", got '" + value + "'"};
  return v;
}

double parse_positive(const std::string& flag, const std::string& v, const char* what = "a positive number") {
  char* end = nullptr;
  const double x = std::strtod(v.c_str(), &end);
  if (v.empty() || *end != '\0' || !(x > 0) || !std::isfinite(x))
    throw UsageError{flag + " expects " + what + ", got '" + v + "'"};
  return x;
}

// `count` comma-separated finite numbers.
std::vector<double> parse_numbers(const std::string& flag, const std::string& v, int count, const char* form) {
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
  // Checked before the scene is read, so a bad option is a usage error even for a bad scene.
  const std::optional<int> threads =
      a.threads ? std::optional<int>(static_cast<int>(parse_count("--threads", *a.threads, 1))) : std::nullopt;
  const bool auto_dt = a.dt && *a.dt == "auto";
  const std::optional<double> dt =
      a.dt && !auto_dt ? std::optional<double>(parse_positive("--dt", *a.dt, "a positive number of seconds or auto"))
                       : std::nullopt;
  const bool auto_contact = a.contact_time_scale && *a.contact_time_scale == "auto";
  const std::optional<double> contact_time_scale =
      a.contact_time_scale && !auto_contact
          ? std::optional<double>(parse_positive("--contact-time-scale", *a.contact_time_scale,
                                                 "a positive number of seconds or auto"))
          : std::nullopt;
  if (a.solver && *a.solver != "peridynamics" && *a.solver != "fem_linear" && *a.solver != "fem_corotated")
    throw UsageError{"--solver expects peridynamics, fem_linear or fem_corotated, got '" + *a.solver + "'"};
  auto sc = perifx::scene::load_scene_file(a.scene);
  if (threads) sc.threads = *threads;
  const bool scene_is_peridynamic = sc.solver == perifx::scene::Solver::peridynamics;
  if (a.solver) {
    using perifx::scene::Solver;
    sc.solver = *a.solver == "fem_linear" ? Solver::fem_linear
                : *a.solver == "fem_corotated" ? Solver::fem_corotated : Solver::peridynamics;
  }
  if (auto_dt) sc.time.auto_dt = true, sc.time.dt = 0.0;  // picked at set-up
  if (auto_contact) sc.contact.time_scale = 0.0;  // resolved at set-up
  if (contact_time_scale) sc.contact.time_scale = *contact_time_scale;
  if (dt) {
    sc.time.dt = *dt;
    sc.time.auto_dt = false;
    try {
      perifx::scene::check_time(sc);
    } catch (const perifx::scene::SceneError& e) {
      throw UsageError{"--dt " + *a.dt + ": " + e.message()};
    }
  }
  if (sc.solver != perifx::scene::Solver::peridynamics && sc.output.surfaces_by_default) {
    // Surfaces the scene did not list (the default): an FEM run has no split mesh, so leave them out.
    sc.output.obj = sc.output.surface_ply = sc.output.cache = false;
    sc.output.surfaces_by_default = false;
  }
  if (sc.solver != perifx::scene::Solver::peridynamics && scene_is_peridynamic) {
    // `--solver fem_*` runs a peridynamic scene again for comparison (README): the formats that only
    // the peridynamic solver's embedded mesh can write are left out, and said so; a scene the FEM
    // solver cannot run is refused first (no note before the error).
    perifx::setup::check_solver(sc);
    std::string dropped;
    for (auto [flag, name] : {std::pair{&sc.output.obj, "obj"}, {&sc.output.surface_ply, "surface_ply"},
                              {&sc.output.surface_vtp, "surface_vtp"}, {&sc.output.tets_vtu, "tets_vtu"},
                              {&sc.output.cache, "cache"}, {&sc.output.gltf, "gltf"}})
      if (*flag) {
        *flag = false;
        dropped += (dropped.empty() ? "" : ", ") + std::string(name);
      }
    if (!dropped.empty())
      std::cerr << "perifx: --solver " << *a.solver << ": output formats " << dropped
                << " left out (they need the peridynamic solver's embedded tet mesh)\n";
  }
  if (sc.solver != perifx::scene::Solver::peridynamics &&
      (sc.output.obj || sc.output.surface_ply || sc.output.surface_vtp || sc.output.tets_vtu || sc.output.cache ||
       sc.output.gltf))
    throw perifx::scene::SceneError(a.scene, "/output/formats",
                                    "obj, surface_ply, surface_vtp, tets_vtu, cache and gltf need the embedded tet mesh (got an FEM "
                                    "solver; expected solver 'peridynamics' or formats vtu, ply)");
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

// check-surface RUN_DIR: the per-frame surface table; exit 2 when a count is non-zero or the run
// cannot be read (engine/tools/surface_check.hpp).
int cmd_check_surface(const Args& a) {
  perifx::SurfaceCheckOptions opt;
  if (a.frames) opt.frames = static_cast<std::uint64_t>(parse_count("--frames", *a.frames, 1));
  if (a.horizon) opt.horizon = parse_positive("--horizon", *a.horizon);
  opt.details = a.details;
  try {
    const auto report = perifx::check_run_surfaces(a.scene, opt);
    perifx::print_surface_check(std::cout, report);
    return report.issues() ? kScene : kOk;
  } catch (const perifx::SurfaceCheckError& e) {
    std::cerr << "perifx: check-surface: " << e.what() << "\n";
    return kScene;
  }
}

// crack-stats RUN_DIR: crack geometry of one frame (engine/tools/crack_stats.hpp); exit 2 when the run
// cannot be read.
int cmd_crack_stats(const Args& a) {
  perifx::CrackStatsOptions opt;
  auto axis = [](const std::string& flag, const std::string& v) {
    if (v == "x") return 0;
    if (v == "y") return 1;
    if (v == "z") return 2;
    throw UsageError{flag + " expects x, y or z, got '" + v + "'"};
  };
  auto number = [](const std::string& flag, const std::string& v) {
    char* end = nullptr;
    const double x = std::strtod(v.c_str(), &end);
    if (v.empty() || *end != '\0' || !std::isfinite(x)) throw UsageError{flag + " expects a number, got '" + v + "'"};
    return x;
  };
  if (a.frame) opt.frame = static_cast<std::uint64_t>(parse_count("--frame", *a.frame, 0));
  if (a.mirror) opt.mirror_axis = axis("--mirror", *a.mirror);
  if (a.mirror_at) opt.mirror_at = number("--mirror-at", *a.mirror_at);
  if (a.load_axis) opt.load_axis = axis("--load-axis", *a.load_axis);
  if (a.axis_tolerance) opt.axis_tolerance_deg = parse_positive("--axis-tolerance", *a.axis_tolerance);
  if (a.radius) opt.radius = parse_positive("--radius", *a.radius);
  opt.exclude_initial = !a.include_initial;
  try {
    perifx::print_crack_stats(std::cout, perifx::crack_statistics(std::filesystem::path(a.scene), opt), opt);
    return kOk;
  } catch (const perifx::CrackStatsError& e) {
    std::cerr << "perifx: crack-stats: " << e.what() << "\n";
    return kScene;
  }
}

bool report_time_step(const perifx::World& world, std::ostream& out);

// Everything run refuses before the first step: the scene, every mesh's contents, the memory
// estimate, the world's setup and the stable-step limit.
int cmd_check(const Args& a) {
  const auto sc = load(a);
  const auto estimate = perifx::setup::preflight(sc, true);
  {
    perifx::World world(sc);
    std::ostringstream verdict;
    if (!report_time_step(world, verdict)) return kUnstable;
  }
  std::cout << a.scene << ": memory estimate " << perifx::setup::format_bytes(estimate.bytes) << " for "
            << estimate.particles << " particles (available "
            << (estimate.available > 0 ? perifx::setup::format_bytes(estimate.available) : std::string("unknown"))
            << ")\n";
  std::cout << a.scene << ": ok (" << sc.materials.size() << " materials, " << sc.bodies.size() << " bodies, "
            << sc.boundary_conditions.size() << " boundary conditions, " << sc.colliders.size() << " colliders)\n";
  return kOk;
}

bool report_step_limit(const perifx::World& world, std::ostream& out);

// The contact time scale, when anything touches; a warning when the step is longer (the contact then
// depends on the step: systems/contact_law.hpp).
void report_contact_time_scale(const perifx::World& world, std::ostream& out) {
  const double tau = world.contact_time_scale(), dt = world.dt();
  if (!(tau > 0.0)) return;
  char buf[320];
  std::snprintf(buf, sizeof buf, "contact          time scale %.3g s (%s; springs stiffness_factor*m/%s^2)\n", tau,
                world.scene().contact.time_scale > 0.0 ? "given" : "auto", dt > tau ? "dt" : "tau");
  out << buf;
  if (dt > tau) {
    std::snprintf(buf, sizeof buf,
                  "warning: time/dt %.3g s is longer than the contact time scale %.3g s: contact and impacts "
                  "then depend on the step (give a step of at most %.3g s, or \"auto\")\n", dt, tau, tau);
    out << buf;
  }
}

// The stable-step verdict, then the contact time scale; false when dt is above the limit.
bool report_time_step(const perifx::World& world, std::ostream& out) {
  if (!report_step_limit(world, out)) return false;
  report_contact_time_scale(world, out);
  return true;
}

// Prints the stable-step verdict; returns false when dt is above the limit. A time step at or below
// 80 % of the cheap lower bound (World::stable_time_step_bound) needs no eigenvalue estimate: it is
// stable, and not within the 20 % of the limit that the estimate's path warns about.
bool report_step_limit(const perifx::World& world, std::ostream& out) {
  const double dt = world.dt();
  char buf[384];  // the longest line, an automatic step set by motion, is about 210 characters
  if (world.scene().time.auto_dt) {  // picked at set-up (setup/world_setup.cpp, automatic_time_step)
    const double stable = world.stable_time_step(), interval = 1.0 / world.scene().time.frame_rate;
    const double steps = std::round(interval / dt);
    // More steps per frame than 80 % of the limit needs: the prescribed motion set the step.
    const bool by_motion = steps > std::ceil(interval / (0.8 * stable));
    std::snprintf(buf, sizeof buf, "time step        %.3g s (auto: %.0f%% of the stable limit %.3g s%s, %.0f steps per frame)\n",
                  dt, 100.0 * dt / stable, stable,
                  by_motion ? "; set by the fastest prescribed motion: a quarter of the finest cell, or of a smaller projectile's radius, per step" : "", steps);
    out << buf;
    return true;
  }
  const double bound = world.stable_time_step_bound();
  if (bound > 0.0 && dt <= 0.8 * bound) {
    std::snprintf(buf, sizeof buf, "time step        %.3g s (stable: %.0f%% of %.3g s, a lower bound on the limit)\n", dt,
                  100.0 * dt / bound, bound);
    out << buf;
    return true;
  }
  const double stable = world.stable_time_step();
  std::snprintf(buf, sizeof buf, "time step        %.3g s (stable limit %.3g s, %.0f%% of it)\n", dt, stable,
                100.0 * dt / stable);
  out << buf;
  if (!(stable > 0.0)) {  // NaN: the stiffness could not be analysed
    std::cerr << "perifx: error: " << world.scene().source.string()
              << ": /materials: no stable time step can be computed (got overflowing stiffness or mass; expected "
                 "moduli, densities and sizes of a real solid)\n";
    return false;
  }
  if (!(dt <= stable)) {
    std::snprintf(buf, sizeof buf,
                  "time step above the stable explicit limit; the run would blow up (got %.3g s; expected at most "
                  "the stable step %.3g s, e.g. %.3g)", dt, stable, 0.9 * stable);
    std::cerr << "perifx: error: " << world.scene().source.string() << ": /time/dt: " << buf << "\n";
    return false;
  }
  if (dt > 0.8 * stable) out << "warning: time/dt is within 20% of the stable limit; large deformation may still blow up\n";
  return true;
}

int cmd_info(const Args& a) {
  const long long ranks = a.ranks ? parse_count("--ranks", *a.ranks, 1) : 0;  // before the (long) set-up
  perifx::World world(load(a));
  const auto mem = world.memory();
  std::cout << "scene            " << world.scene().name << "\n";
  std::cout << "particles        " << world.particle_count() << "\n";
  std::cout << "bonds            " << world.bond_count() << " directed ("
            << (world.particle_count() ? double(world.bond_count()) / double(world.particle_count()) : 0.0)
            << " per particle)\n";
  for (const auto& b : world.bodies())
    std::cout << "body             " << b.name << ": " << b.particle_count << " particles, lambda " << b.mean_edge_length
              << " m, horizon " << b.horizon << " m\n";
  // Each material in physical units, and what its yield stress means for the per-bond law (§12.2).
  // The flow stress set-up derived from an offset yield stress is read from the world's resolved
  // materials (setup::resolve_settings), not derived a second time.
  const auto& resolved = world.state().settings.materials;
  for (std::size_t k = 0; k < world.scene().materials.size(); ++k) {
    const perifx::scene::Material& m = world.scene().materials[k];
    const double kappa = m.bulk_modulus, mu = m.shear_modulus;
    std::ostringstream line;
    line.precision(4);
    line << "material         " << m.name << (m.preset.empty() ? "" : " (preset " + m.preset + ")") << ": density "
         << m.density << " kg/m^3, E " << perifx::youngs_modulus(kappa, mu) << " Pa, nu "
         << perifx::poisson_ratio(kappa, mu);
    if (m.fracture_energy > 0.0) line << ", fracture_energy " << m.fracture_energy << " J/m^2";
    else if (std::isfinite(m.critical_stretch)) line << ", critical_stretch " << m.critical_stretch;
    if (m.yield_stress > 0.0 && std::isfinite(m.yield_stress))
      line << ", yield_stress " << m.yield_stress << " Pa (the flow stress; 0.2 % offset yield "
           << perifx::systems::offset_yield_ratio(kappa, mu, m.yield_stress) << " of it)";
    else if (m.offset_yield_stress > 0.0 && std::isfinite(m.offset_yield_stress))
      line << ", offset_yield_stress " << m.offset_yield_stress << " Pa (0.2 % offset; the flow stress it sets is "
           << resolved[k].yield_stress << " Pa)";
    else if (std::isfinite(m.yield_energy)) line << ", yield_energy " << m.yield_energy;
    std::cout << line.str() << "\n";
  }
  std::cout << "memory           particles " << human_bytes(double(mem.particle_bytes)) << " ("
            << mem.bytes_per_particle << " B each), bonds " << human_bytes(double(mem.bond_bytes)) << " ("
            << mem.bytes_per_bond << " B each), mesh " << human_bytes(double(mem.mesh_bytes)) << ", contact "
            << human_bytes(double(mem.contact_bytes)) << ", other " << human_bytes(double(mem.other_bytes))
            << "; total " << human_bytes(double(mem.total_bytes)) << "\n";
  // What the process holds now, and how much of it the kernel backs with 2 MiB pages (the step's arrays
  // ask for them; the rest does through malloc when perifx restarted itself with glibc's hugetlb tunable).
  if (const auto resident = perifx::setup::resident_memory(); resident.total >= 0.0)
    std::cout << "resident         " << human_bytes(resident.total) << ", in huge pages "
              << human_bytes(std::max(resident.huge_pages, 0.0)) << "\n";
  std::cout << "fields          ";
  for (const auto& f : perifx::World::field_catalog()) std::cout << " " << f.name << " [" << f.unit << "]";
  std::cout << "\n";
  std::cout << "threads          " << world.threads() << "\n";
  const bool ok = report_time_step(world, std::cout);
  {  // where the set-up time went (the stable-step estimate included)
    double total = 0.0;
    std::ostringstream phases;
    phases.precision(3);
    for (const auto& t : world.setup_times()) {
      phases << (phases.tellp() > 0 ? ", " : "") << t.name << " " << t.seconds << " s";
      total += t.seconds;
    }
    std::ostringstream head;
    head.precision(3);
    head << "set-up           " << total << " s (" << phases.str() << ")\n";
    std::cout << head.str();
  }
  if (a.ranks) {  // the decomposition plan (engine/distributed/decomposition.hpp)
    std::vector<perifx::DomainView> domains;
    try {
      domains = world.decompose(static_cast<int>(std::min<long long>(ranks, std::numeric_limits<int>::max())));
    } catch (const std::invalid_argument& e) {  // more ranks than particles
      throw UsageError{std::string("--ranks ") + e.what()};
    }
    std::uint64_t halo = 0, most_bonds = 0, bonds = 0;
    for (const auto& d : domains) {
      halo += d.halo_bytes_per_step;
      most_bonds = std::max(most_bonds, d.bonds);
      bonds += d.bonds;
    }
    // An FEM world splits its vertices by tet corners (decomposition.hpp): its "bonds" are those, and
    // a rank holds the FEM data of its tets (about a quarter of the world's per corner).
    const bool fem = world.scene().solver != perifx::scene::Solver::peridynamics;
    const char* const work = fem ? "tet corners" : "bonds";
    const double bytes_per_work = fem ? (bonds ? double(mem.mesh_bytes) / double(bonds) : 0.0) : mem.bytes_per_bond;
    std::cout << "ranks            " << ranks << ": halo " << human_bytes(double(halo))
              << " per step in all, largest rank " << (bonds ? double(most_bonds) * double(ranks) / double(bonds) : 1.0)
              << " x the mean " << work << "\n";
    // A rank would hold its particles' and bonds' (FEM: tets') arrays plus a particle's arrays per
    // ghost, at this world's bytes per particle and per bond or corner (contact arrays not counted).
    std::cout << "rank  first_particle  particles  " << (fem ? "tet_corners  ghosts  tet_ghosts" : "bonds  ghosts  bond_ghosts")
              << "  contact_ghosts  neighbors  halo_per_step  memory\n";
    for (std::size_t r = 0; r < domains.size(); ++r) {
      const auto& d = domains[r];
      const double bytes = double(d.particle_count + d.ghosts) * mem.bytes_per_particle + double(d.bonds) * bytes_per_work;
      std::cout << r << "  " << d.first_particle << "  " << d.particle_count << "  " << d.bonds << "  " << d.ghosts
                << "  " << d.bond_ghosts << "  " << d.contact_ghosts << "  " << d.neighbor_ranks << "  "
                << human_bytes(double(d.halo_bytes_per_step)) << "  " << human_bytes(bytes) << "\n";
    }
  }
  std::cout << "schedule\n" << world.schedule();
  return ok ? kOk : kUnstable;
}

// One JSON object per line on stdout, for farm managers.
void print_progress_json(const perifx::RunProgress& p) {
  const perifx::World& w = *p.world;
  const std::size_t broken = (w.bond_count() - w.alive_bond_count()) / 2;
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "{\"frame\":%llu,\"frames\":%llu,\"step\":%llu,\"steps\":%llu,\"time\":%.9g,\"steps_per_second\":%.6g,"
                "\"elapsed_seconds\":%.3f,\"eta_seconds\":%.3f,\"broken_bonds\":%zu,\"pieces\":%zu,\"memory_bytes\":%zu}",
                (unsigned long long)p.frame, (unsigned long long)p.frames, (unsigned long long)p.step,
                (unsigned long long)p.steps, p.time, p.steps_per_second, p.wall_seconds, p.eta_seconds, broken,
                w.fragment_count(), w.memory().total_bytes);
  std::cout << buf << std::endl;  // flushed: a farm manager reads it line by line
}

int cmd_run(const Args& a) {
  const std::optional<std::uint64_t> frames =
      a.frames ? std::optional<std::uint64_t>(static_cast<std::uint64_t>(parse_count("--frames", *a.frames, 1)))
               : std::nullopt;
  if (a.progress && *a.progress != "text" && *a.progress != "json")
    throw UsageError{"--progress expects text or json, got '" + *a.progress + "'"};
  if (a.overwrite && a.resume) throw UsageError{"--overwrite and --resume exclude each other"};
  if (a.out && a.out->empty()) throw UsageError{"--out expects a directory, got ''"};
  const bool json = a.progress && *a.progress == "json";
  const bool talk = !a.quiet && !json;  // human-readable lines on stderr
  const auto sc = load(a);
  if (frames) {
    try {
      perifx::scene::check_time(sc, *frames);
    } catch (const perifx::scene::SceneError& e) {
      throw UsageError{"--frames " + *a.frames + ": " + e.message()};
    }
  }
  // Meshes checked, memory estimated for the ranks on this machine (refused unless --force).
  const bool distributed = a.mpi && a.mpi->active();
  const auto placement = distributed ? perifx::distributed::rank_placement() : perifx::setup::RankPlacement{};
  const auto setup_start = std::chrono::steady_clock::now();  // the wait a user sees: preflight and set-up
  const auto estimate = perifx::setup::preflight(sc, !a.force, placement);
  // A large world takes seconds to minutes to set up (4.4 s at 9e5 particles, 110 s at 4.8e6): say so
  // before the silence.
  if (talk && estimate.particles >= 100000)
    std::cerr << "perifx: " << sc.name << ": setting up " << estimate.particles << " particles (estimated peak "
              << perifx::setup::format_bytes(estimate.bytes) << ")...\n" << std::flush;
  // Under mpirun the ranks other than 0 build a shell and receive their part from rank 0 (World::distribute),
  // which alone builds, checks and writes the whole world; a refusal there stops the job. The others
  // wait for it asleep, so it sets up and checks the time step on their cores too, then steps on its own.
  auto setup_scene = sc;
  if (distributed) setup_scene.threads = perifx::setup::setup_threads(sc.threads, a.mpi->rank(), placement);
  perifx::World world(setup_scene, distributed && a.mpi->rank() != 0 ? perifx::WorldBuild::shell : perifx::WorldBuild::whole);
  if (frames && sc.time.auto_dt) {  // the step picked at set-up against --frames' duration (a shell has none yet)
    try {
      perifx::scene::check_time(world.scene(), *frames);
    } catch (const perifx::scene::SceneError& e) {
      throw UsageError{"--frames " + *a.frames + ": " + e.message()};
    }
  }
  const bool tty = ::isatty(STDERR_FILENO) && talk;
  if (talk)
    std::cerr << "perifx: " << world.scene().name << ": " << world.particle_count() << " particles, "
              << world.bond_count() << " bonds, " << world.threads() << " threads"
              << (setup_scene.threads != sc.threads ? " to set up, " + std::to_string(sc.threads) + " to step" : std::string())
              << ", set up in " << std::fixed << std::setprecision(2)
              << std::chrono::duration<double>(std::chrono::steady_clock::now() - setup_start).count() << " s"
              << std::defaultfloat << "\n";
  std::ostringstream silent;  // --quiet / json: the time-step report is dropped (its error still goes to stderr)
  if (!world.shell() && !report_time_step(world, talk ? std::cerr : silent)) return kUnstable;
  if (distributed) {
    if (setup_scene.threads != sc.threads) world.set_threads(sc.threads);
    world.distribute();
    if (talk) std::cerr << "perifx: distributed over " << world.ranks() << " MPI ranks\n";
  }
  perifx::RunOptions opt;
  if (a.out) opt.output_directory = *a.out;
  opt.frames = frames;
  opt.profile = a.profile;
  opt.existing = a.resume ? perifx::ExistingRun::resume
                 : a.overwrite ? perifx::ExistingRun::overwrite : perifx::ExistingRun::refuse;
  std::signal(SIGTERM, on_stop_signal);
  std::signal(SIGINT, on_stop_signal);
  opt.stop_requested = [] { return g_stop_signal != 0; };
  auto last_print = std::chrono::steady_clock::now();
  if (json)
    opt.on_frame = print_progress_json;
  else if (talk)
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
  std::signal(SIGTERM, SIG_DFL);
  std::signal(SIGINT, SIG_DFL);
  if (talk) {
    char buf[500];
    std::snprintf(buf, sizeof buf,
                  "%s: %zu particles, %zu bonds (%zu alive), %zu fragments, %llu steps, frames %llu..%llu of %llu, %.3g s simulated\n"
                  "      wall %.2f s stepping + %.2f s output, %.3g bond-updates/s on %d threads, peak memory %s\n"
                  "      output: %s\n",
                  s.interrupted ? "interrupted" : "done", s.particles, s.bonds, s.alive_bonds, s.fragments,
                  (unsigned long long)s.steps, (unsigned long long)s.first_frame, (unsigned long long)s.last_frame,
                  (unsigned long long)s.frames, s.simulated_seconds, s.wall_seconds, s.output_seconds,
                  s.bond_updates_per_second, s.threads, perifx::setup::format_bytes(double(s.peak_memory_bytes)).c_str(),
                  s.output_directory.string().c_str());
    std::cerr << buf;
    // A distributed run: each rank's share, ghosts and the halo bytes it received per step.
    for (std::size_t r = 0; s.ranks > 1 && r < s.rank_stats.size(); ++r) {
      const perifx::RankStats& st = s.rank_stats[r];
      std::snprintf(buf, sizeof buf,
                    "      rank %zu: %u particles, %u bond ghosts, %u contact ghosts, %.1f kB halo per step, "
                    "%llu contact-ghost refreshes\n",
                    r, st.owned_particles, st.bond_ghosts, st.contact_ghosts,
                    st.steps ? 1e-3 * double(st.halo_bytes) / double(st.steps) : 0.0,
                    (unsigned long long)st.contact_ghost_refreshes);
      std::cerr << buf;
      if (st.state_gathers > 0) {
        std::snprintf(buf, sizeof buf,
                      "        %llu state gathers (frames, re-splits): %.2f s mesh replay, %.2f s gather, %.2f s pieces (%llu label rounds)\n",
                      (unsigned long long)st.state_gathers, st.replay_seconds, st.gather_seconds, st.piece_seconds,
                      (unsigned long long)st.piece_rounds);
        std::cerr << buf;
      }
    }
  }
  if (a.profile) std::cout << "profile (" << s.threads << " threads):\n" << perifx::profile_table(s) << std::flush;
  if (s.interrupted) {
    if (!a.quiet) std::cerr << "perifx: interrupted after frame " << s.last_frame << "; continue with --resume\n";
    return kInterrupted;
  }
  if (a.render) {
    // --render: PNG frames (and an MP4 when ffmpeg is installed) in OUT/render, then where to look.
    perifx::render::RenderOptions ro;
    ro.run_directory = s.output_directory;
    ro.scene_file = std::filesystem::path(a.scene);
    ro.mp4 = std::system("command -v ffmpeg >/dev/null 2>&1") == 0;
    const int code = perifx::render::render_command(ro, a.quiet);
    if (code != kOk) return code;
    if (!a.quiet) {
      const auto dir = s.output_directory.string();
      std::cerr << "\nopen the results:\n"
                << "  frames     " << dir << "/render/frame.*.png" << (ro.mp4 ? "  (movie: " + dir + "/render/movie.mp4)" : "")
                << "\n  ParaView   paraview " << dir << "/particles.pvd   (representation: Point Gaussian)\n"
                << (std::filesystem::exists(s.output_directory / "animation.pc2")
                        ? "  Blender    " + dir + "/animation.obj + animation.pc2 (Mesh Cache modifier; README, \"Blender\")\n"
                        : "  Blender    File > Import > Wavefront (.obj): " + dir + "/surface.NNNN.obj, one file per frame\n")
                << (std::filesystem::exists(s.output_directory / "animation.glb")
                        ? "  glTF       " + dir + "/animation.glb (rigid pieces: game engines, Blender, three.js)\n"
                        : "");
    }
  }
  return kOk;
}

// `perifx render` options: parsed into RenderOptions (text values checked as for the other commands).
struct RenderArgs {
  perifx::render::RenderOptions options;
  std::string run_directory;
  bool quiet = false;
  std::optional<std::string> out, width, height, color_by, frames, backend, scene, projectile_radius, particle_scale, draw,
      threads, view, fit_frames, zoom, cut;
};

perifx::render::RenderOptions render_options(RenderArgs& r) {
  using namespace perifx::render;
  RenderOptions opt = r.options;
  opt.run_directory = r.run_directory;
  if (r.out) opt.output_directory = *r.out;
  if (r.width) opt.width = int(parse_count("--width", *r.width, 16));
  if (r.height) opt.height = int(parse_count("--height", *r.height, 16));
  if (r.scene) opt.scene_file = *r.scene;
  if (r.projectile_radius) opt.projectile_radius = parse_positive("--projectile-radius", *r.projectile_radius);
  if (r.particle_scale) opt.particle_scale = parse_positive("--particle-scale", *r.particle_scale);
  if (r.threads) opt.threads = int(parse_count("--threads", *r.threads, 1));
  if (r.zoom) opt.zoom = parse_positive("--zoom", *r.zoom);
  if (r.view) {
    // X,Y,Z: the direction from the subject to the camera (Y up), e.g. 0,0,1 looks along -z.
    const auto c = parse_numbers("--view", *r.view, 3, "X,Y,Z");
    opt.view = perifx::Vec3(c[0], c[1], c[2]);
    if (!(opt.view.norm() > 0)) throw UsageError{"--view needs a non-zero direction"};
  }
  if (r.cut) {
    // NX,NY,NZ,D: hide what lies on the side n·x > D of the plane (n is normalized here).
    const auto c = parse_numbers("--cut", *r.cut, 4, "NX,NY,NZ,D");
    const perifx::Vec3 n(c[0], c[1], c[2]);
    if (!(n.norm() > 0)) throw UsageError{"--cut needs a non-zero normal"};
    opt.cut = CutPlane{n.normalized(), c[3] / n.norm()};
  }
  if (r.draw) {
    if (*r.draw == "auto") opt.draw = Draw::automatic;
    else if (*r.draw == "particles") opt.draw = Draw::particles;
    else if (*r.draw == "surface") opt.draw = Draw::surface;
    else throw UsageError{"--draw expects auto, particles or surface, got '" + *r.draw + "'"};
  }
  if (r.color_by) {
    if (*r.color_by == "damage") opt.color_by = ColorBy::damage;
    else if (*r.color_by == "material") opt.color_by = ColorBy::material;
    else if (*r.color_by == "none") opt.color_by = ColorBy::none;
    else throw UsageError{"--color-by expects damage, material or none, got '" + *r.color_by + "'"};
  }
  if (r.backend) {
    if (*r.backend == "povray") opt.backend = Backend::povray;
    else if (*r.backend == "builtin") opt.backend = Backend::builtin;
    else throw UsageError{"--backend expects povray or builtin, got '" + *r.backend + "'"};
  }
  // A:B (inclusive), A: (from A), :B (up to B) or A (just A).
  auto range = [](const std::string& flag, const std::string& v, std::optional<std::uint64_t>& first,
                  std::optional<std::uint64_t>& last) {
    const auto colon = v.find(':');
    const std::string a = v.substr(0, colon), b = colon == std::string::npos ? a : v.substr(colon + 1);
    if (!a.empty()) first = std::uint64_t(parse_count(flag, a, 0));
    if (!b.empty()) last = std::uint64_t(parse_count(flag, b, 0));
    if (first && last && *last < *first) throw UsageError{flag + " A:B needs A <= B, got '" + v + "'"};
  };
  if (r.frames) range("--frames", *r.frames, opt.first_frame, opt.last_frame);
  if (r.fit_frames) range("--fit-frames", *r.fit_frames, opt.fit_first, opt.fit_last);
  return opt;
}

// An option whose text is kept as given (checked later, see Args).
CLI::Option* text_option(CLI::App* app, const std::string& name, std::optional<std::string>& target,
                         const std::string& description) {
  return app->add_option_function<std::string>(name, [&target](const std::string& v) { target = v; }, description);
}

int run_command(const Args& a) {
  if (a.command == "run") return cmd_run(a);
  if (a.command == "compare") return cmd_compare(a);
  if (a.command == "check") return cmd_check(a);
  if (a.command == "check-surface") return cmd_check_surface(a);
  if (a.command == "crack-stats") return cmd_crack_stats(a);
  if (a.command == "info") return cmd_info(a);
  std::cout << perifx::scene::scene_format_markdown();  // spec
  return kOk;
}

}  // namespace

int cli_main(int argc, char** argv, const perifx::distributed::MpiSession& mpi);

// Under mpirun every rank runs the same command; rank 0 alone prints. An error that leaves one rank
// behind would hang the others in their next exchange, so a distributed error stops the whole job
// (MPI_Abort) with the command's exit code.
int main(int argc, char** argv) {
  perifx::setup::restart_with_huge_page_malloc(argv);  // first: it may restart the program (preflight.hpp)
  perifx::setup::release_freed_memory_promptly();  // the peak the preflight estimates (preflight.hpp)
  try {
    perifx::distributed::MpiSession mpi(argc, argv);
    if (!mpi.active() && perifx::distributed::launcher_ranks() > 1) {
      std::cerr << "perifx: started by mpirun with " << perifx::distributed::launcher_ranks()
                << " ranks, but this perifx was built without MPI (configure with -DPERIFX_MPI=ON); each rank would "
                   "run the whole scene into the same files\n";
      return kUsage;
    }
    std::ostringstream muted_out, muted_err;
    std::streambuf* const out = std::cout.rdbuf();
    std::streambuf* const err = std::cerr.rdbuf();
    if (mpi.rank() != 0) std::cout.rdbuf(muted_out.rdbuf()), std::cerr.rdbuf(muted_err.rdbuf());
    const int code = cli_main(argc, argv, mpi);
    std::cout.rdbuf(out), std::cerr.rdbuf(err);
    if (code != kOk && code != kInterrupted && mpi.ranks() > 1) {
      // Another rank's error can be its own (rank 0 may not share it): say which rank it is. An error
      // every rank meets (a bad scene) is then printed once per rank.
      if (mpi.rank() != 0) {
        std::istringstream lines(muted_err.str());
        for (std::string line; std::getline(lines, line);) std::cerr << "[rank " << mpi.rank() << "] " << line << "\n";
      }
      // mpirun forwards a rank's output through a pipe that MPI_Abort can cut before it is read: give
      // the error line half a second to reach the terminal (it was lost otherwise, now and then).
      std::cout.flush(), std::cerr.flush();
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
      mpi.abort(code);
    }
    return code;
  } catch (const std::exception& e) {
    std::cerr << "perifx: internal error: " << e.what() << "\n";
    return kInternal;
  }
}

int cli_main(int argc, char** argv, const perifx::distributed::MpiSession& mpi) {
  CLI::App app{"perifx: peridynamics-based fracture animation of elastoplastic solids", "perifx"};
  app.set_version_flag("--version", std::string("perifx ") + PERIFX_VERSION);
  app.require_subcommand(1);
  app.footer(
      "exit codes: 0 ok, 1 usage, 2 invalid scene or mesh, 3 output error, 4 unstable time step, 5 internal,\n"
      "6 interrupted (SIGTERM/SIGINT; checkpoint written, continue with run --resume)\n"
      "7 simulation blew up, 8 not enough memory\n"
      "Run perifx COMMAND --help for a command's options.");
  Args a;
  // Scene overrides shared by run, check and info.
  auto scene_options = [&a](CLI::App* sub) {
    sub->add_option("SCENE", a.scene, "scene file (JSON)")->required();
    text_option(sub, "--threads", a.threads, "worker threads (N >= 1)");
    text_option(sub, "--solver", a.solver, "peridynamics|fem_linear|fem_corotated (overrides the scene)");
    text_option(sub, "--dt", a.dt, "time step in seconds, or auto (overrides the scene)");
    text_option(sub, "--contact-time-scale", a.contact_time_scale,
                "contact time scale in seconds, or auto (overrides the scene's contact/time_scale; a preview given "
                "its final's keeps the final's contact springs)");
  };
  CLI::App* run = app.add_subcommand("run", "simulate and write frames (VTU/VTP + PVD for ParaView, OBJ/PLY for Houdini, an OBJ + PC2 point cache for Blender, glTF for game engines)");
  scene_options(run);
  text_option(run, "--out", a.out, "output directory (overrides the scene)");
  text_option(run, "--frames", a.frames, "run this many frames (N >= 1) instead of the scene's duration");
  run->add_flag("--quiet", a.quiet, "print nothing but errors");
  text_option(run, "--progress", a.progress, "text|json: json writes one JSON object per frame on stdout (frame, step, "
                                             "time, steps/s, ETA, broken bonds, pieces, memory)");
  run->add_flag("--overwrite", a.overwrite, "remove another run's files from the output directory first");
  run->add_flag("--resume", a.resume, "continue the run in the output directory after its last checkpoint "
                                      "(start over when there is none)");
  run->add_flag("--render", a.render, "then render PNG frames (and movie.mp4 with ffmpeg) into OUT/render");
  run->add_flag("--force", a.force, "run even when the memory estimate exceeds the available memory");
  run->add_flag("--profile", a.profile, "time every system of the step and print the table at the end (stdout; also "
                                        "\"profile\" in summary.json)");
  scene_options(app.add_subcommand("check", "validate the scene without running it"));
  CLI::App* info = app.add_subcommand("info", "particles, bonds, memory, the stable time step and the task graph");
  scene_options(info);
  text_option(info, "--ranks", a.ranks,
              "also print how the world would split over N ranks (N >= 1): owned particles, bonds, ghosts and the "
              "bytes each rank receives per step");
  app.add_subcommand("spec", "print the scene format reference (markdown)");
  CLI::App* compare = app.add_subcommand(
      "compare", "position deviation of run B from reference run A per frame, over A's bounding-box diagonal at "
                 "frame 0 (paper §6), at the frame times both runs share; writes RUN_A/compare.csv. Same body; "
                 "the runs may differ in resolution (a preview against its final: the finer run is fitted at the "
                 "coarser run's particles) or solver (an FEM run is interpolated in its tets)");
  compare->add_option("RUN_A", a.scene, "reference run directory")->required();
  compare->add_option("RUN_B", a.second, "compared run directory")->required();

  CLI::App* check_surface = app.add_subcommand(
      "check-surface", "per frame: surface vertices farther than a horizon from their piece (and than at rest), inverted closed shells, "
                       "open edges, triangles stretched > 3x where the particles are not, longest edge; exit 2 when a "
                       "count is non-zero");
  check_surface->add_option("RUN_DIR", a.scene, "run directory")->required();
  text_option(check_surface, "--frames", a.frames, "check frames 0..N-1 only");
  text_option(check_surface, "--horizon", a.horizon, "horizon in metres (default: mesh.json)");
  check_surface->add_flag("--details", a.details,
                          "list every counted element under its frame (far vertex, inverted shell with its tets, "
                          "non-manifold edge, stretched triangle)");

  CLI::App* crack_stats = app.add_subcommand(
      "crack-stats", "crack geometry of one frame in the reference configuration: share of crack area with a normal "
                     "near a grid axis, roughness (area over local best-fit plane area, mean dihedral angle), and "
                     "with --mirror the crack's angle on each side of a symmetry plane");
  crack_stats->add_option("RUN_DIR", a.scene, "run directory")->required();
  text_option(crack_stats, "--frame", a.frame, "frame to measure (default: the last with a surface file)");
  text_option(crack_stats, "--mirror", a.mirror, "x|y|z: axis normal to the symmetry plane (fits each side)");
  text_option(crack_stats, "--mirror-at", a.mirror_at, "the symmetry plane's coordinate, m (default 0)");
  text_option(crack_stats, "--load-axis", a.load_axis, "x|y|z: load axis for the angles (default y)");
  text_option(crack_stats, "--axis-tolerance", a.axis_tolerance, "degrees (default 10)");
  text_option(crack_stats, "--radius", a.radius, "roughness neighbourhood, m (default 3x mean crack edge)");
  crack_stats->add_flag("--include-initial", a.include_initial, "also count the crack faces present on frame 0");

  RenderArgs r;
  CLI::App* render = app.add_subcommand(
      "render", "PNG frames (RUN_DIR/render/frame.NNNN.png; POV-Ray if installed, else built-in) and with --mp4 a "
                "movie (ffmpeg)");
  render->add_option("RUN_DIR", r.run_directory, "run directory")->required();
  text_option(render, "--out", r.out, "output directory (default RUN_DIR/render)");
  text_option(render, "--width", r.width, "image width (>= 16, default 1280)");
  text_option(render, "--height", r.height, "image height (>= 16, default 720)");
  text_option(render, "--color-by", r.color_by, "damage|material|none");
  text_option(render, "--frames", r.frames, "A:B, A:, :B or A: run frames to render");
  render->add_flag("--mp4", r.options.mp4, "also encode movie.mp4 with ffmpeg");
  text_option(render, "--backend", r.backend, "povray|builtin");
  text_option(render, "--scene", r.scene, "the run's SCENE.json: projectile radii, ground plane");
  text_option(render, "--projectile-radius", r.projectile_radius, "radius R when projectiles.csv has none");
  text_option(render, "--particle-scale", r.particle_scale, "sphere radius = S * volume^(1/3)");
  text_option(render, "--draw", r.draw, "auto|particles|surface: the embedded-mesh surface (crack faces orange) or the particles");
  text_option(render, "--threads", r.threads, "threads (N >= 1; default all cores)");
  text_option(render, "--view", r.view, "X,Y,Z: direction from the subject to the camera (default 0.75,0.55,1.3)");
  text_option(render, "--fit-frames", r.fit_frames, "A:B: frames the camera is framed on");
  text_option(render, "--zoom", r.zoom, "Z > 1: closer");
  text_option(render, "--cut", r.cut, "NX,NY,NZ,D: leave out what lies where n·x > D (a cut-away view)");
  render->add_flag("--quiet", r.quiet, "no progress or summary");

  if (argc == 2 && std::string(argv[1]) == "help") argv[1] = const_cast<char*>("--help");
  if (argc >= 2 && argv[1][0] != '-' && [&] {
        for (const CLI::App* sub : app.get_subcommands({})) if (sub->get_name() == argv[1]) return false;
        return true;
      }()) {
    std::cerr << "perifx: unknown command '" << argv[1] << "' (see perifx --help)\n";
    return kUsage;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    std::cerr << "perifx: " << e.what() << " (see perifx --help)\n";
    return kUsage;
  }
  for (CLI::App* sub : app.get_subcommands()) a.command = sub->get_name();
  a.mpi = &mpi;
  try {
    if (a.command == "render") return perifx::render::render_command(render_options(r), r.quiet);
    return run_command(a);
  } catch (const UsageError& e) {
    std::cerr << "perifx: " << e.message << " (see perifx " << a.command << " --help)\n";
    return kUsage;
  } catch (const perifx::scene::SceneError& e) {
    std::cerr << "perifx: error: " << e.what() << "\n";
    return kScene;
  } catch (const perifx::geometry::GeometryError& e) {
    std::cerr << "perifx: error: " << e.what() << "\n";
    return kScene;
  } catch (const perifx::setup::MemoryError& e) {
    std::cerr << "perifx: error: " << e.what() << "\n";
    return kMemory;
  } catch (const perifx::InstabilityError& e) {
    std::cerr << "perifx: error: " << e.what() << "\n";
    return kBlowUp;
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
