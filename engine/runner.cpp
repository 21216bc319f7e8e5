#include "runner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <regex>
#include <sstream>
#include <stdexcept>

#include <sys/resource.h>

#include <nlohmann/json.hpp>

#include "animation.hpp"
#include "components/world_state.hpp"
#include "io/animation_history.hpp"
#include "io/atomic.hpp"
#include "io/gltf.hpp"
#include "io/obj.hpp"
#include "io/pc2.hpp"
#include "io/pieces_csv.hpp"
#include "io/ply.hpp"
#include "io/run_dir.hpp"
#include "io/vtk.hpp"

namespace perifx {
namespace {

std::vector<FieldView> selected_fields(const World& world) {
  const auto& wanted = world.scene().output.fields;
  std::vector<FieldView> all = world.fields();
  if (wanted.empty()) {
    // Position is the geometry itself; everything else goes in as data arrays.
    std::vector<FieldView> out;
    for (auto& f : all)
      if (f.name != "position") out.push_back(f);
    return out;
  }
  std::vector<FieldView> out;
  for (const auto& name : wanted) {
    bool found = false;
    for (auto& f : all)
      if (f.name == name) out.push_back(f), found = true;
    if (!found) {
      std::string known;
      for (auto& f : all) known += (known.empty() ? "" : ", ") + f.name;
      throw std::invalid_argument("output field '" + name + "' does not exist; fields: " + known);
    }
  }
  return out;
}

std::string frame_name(std::uint64_t frame, const char* ext, const char* stem = "particles") {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%s.%04llu.%s", stem, static_cast<unsigned long long>(frame), ext);
  return buf;
}

const char* solver_name(scene::Solver s) {
  switch (s) {
    case scene::Solver::peridynamics: return "peridynamics";
    case scene::Solver::fem_linear: return "fem_linear";
    case scene::Solver::fem_corotated: return "fem_corotated";
  }
  return "?";
}

// What mesh.json records: FEM particles are the mesh vertices (so the tets go in too), peridynamic
// particles the tet barycenters.
io::RunMesh run_mesh(const World& world) {
  const TetMeshView mesh = world.reference_mesh();
  const std::vector<std::array<std::uint32_t, 4>> tets(mesh.tets.begin(), mesh.tets.end());
  io::RunMesh m;
  m.solver = solver_name(world.scene().solver);
  m.vertices_are_particles = world.scene().solver != scene::Solver::peridynamics;
  m.particles = world.particle_count();
  m.vertices = mesh.vertices.size();
  m.tet_count = tets.size();
  m.hash = io::tet_hash(tets, mesh.vertices.size());
  if (m.vertices_are_particles) m.tets = tets;
  m.frame_rate = world.scene().time.frame_rate;
  m.dt = world.dt();
  const auto& out = world.scene().output;
  if (out.obj || out.surface_ply || out.surface_vtp)
    for (const auto& body : world.state().bodies) m.horizon = std::max(m.horizon, body.horizon);
  return m;
}

namespace fs = std::filesystem;

// particles.NNNN.vtu, surface.NNNN.obj ...: the frame number, or -1 for other names.
long long frame_number(const std::string& name) {
  static const std::regex kFrame(R"((particles|surface|tets|dust)\.(\d+)\.(vtu|ply|obj|vtp))");
  std::smatch m;
  return std::regex_match(name, m, kFrame) ? std::stoll(m[2].str()) : -1;
}

bool is_run_file(const std::string& name) {
  // A temporary of an atomic write (io/atomic.hpp: "<name>.tmp-<pid>") that a kill left behind.
  if (const auto tmp = name.find(".tmp-"); tmp != std::string::npos) return is_run_file(name.substr(0, tmp));
  return frame_number(name) >= 0 || name == "projectiles.csv" || name == "summary.json" || name == "mesh.json" ||
         name == "checkpoint.bin" || name == "surface.mtl" || name == "pieces.csv" || name == "animation.bin" ||
         name == "animation.obj" || name == "animation.pc2" || name == "animation.glb" ||
         (name.size() > 4 && name.ends_with(".pvd"));
}

void remove_files(const std::vector<fs::path>& files) {
  for (const auto& f : files) {
    std::error_code ec;
    fs::remove(f, ec);
    if (ec) throw io::IoError("cannot remove '" + f.string() + "' (a previous run's file): " + ec.message());
  }
}

using PvdEntries = std::vector<std::pair<double, std::string>>;

// A distributed run on a rank other than 0: the same steps, gathers and stop decisions as rank 0's
// run_world makes, in the same order (each is collective), and no files.
template <class StepOfFrame>
RunSummary follow_run(World& world, std::uint64_t frames, std::uint64_t start_frame, std::uint64_t first_step,
                      StepOfFrame step_of_frame, bool profile) {
  RunSummary summary;
  summary.first_frame = summary.last_frame = start_frame;
  world.set_profiling(profile);
  if (start_frame == 0) world.gather();  // frame 0
  for (std::uint64_t k = start_frame + 1; k <= frames; ++k) {
    const std::uint64_t target = first_step + step_of_frame(k);
    while (world.step_count() < target) world.step();
    world.gather();
    summary.last_frame = k;
    if (world.broadcast(false)) {
      summary.interrupted = true;
      break;
    }
  }
  summary.frames = frames;
  summary.steps = world.step_count() - first_step;
  summary.threads = world.threads();
  summary.rank_stats = world.rank_stats();                             // rank 0 gathers them
  if (profile) summary.system_times = world.all_ranks_system_times();  // and these
  return summary;
}

// glTF keyframes of the final pieces `ids` (increasing): per recorded frame the best-fit rigid motion
// of the piece, or of the piece it split from when it did not exist yet (reference pose if neither).
std::vector<io::RigidPieceTrack> piece_tracks(const AnimationHistory& history, const std::vector<std::uint32_t>& ids) {
  std::vector<io::RigidPieceTrack> tracks;
  for (std::uint32_t id : ids) {
    io::RigidPieceTrack t;
    t.id = id;
    for (std::size_t f = 0; f < history.frames.size(); ++f) {
      const PieceSample* p = piece_pose(history, f, id);
      t.translation.push_back(p ? p->translation : Vec3::Zero());
      Eigen::Vector4d q = p ? rotation_quaternion(p->rotation) : Eigen::Vector4d(0, 0, 0, 1);
      if (!t.rotation.empty() && q.dot(t.rotation.back()) < 0) q = -q;  // the short way round
      t.rotation.push_back(q);
    }
    tracks.push_back(std::move(t));
  }
  return tracks;
}

// The exports made from a run's whole history: pieces.csv, and animation.obj + .pc2 (cache) and
// animation.glb (gltf) from the surface of its last frame.
void write_animation(const World& world, const AnimationHistory& history, const SurfaceMesh& last_surface,
                     const fs::path& dir) {
  const auto& out = world.scene().output;
  io::write_pieces_csv(dir / "pieces.csv", history);
  if (last_surface.triangles.empty()) return;  // every piece below min_piece_tets: no surface to animate
  const AnimationCache cache = build_animation_cache(history, last_surface);
  if (out.cache && !cache.frames.empty()) {
    io::write_surface_mtl(dir / "surface.mtl");
    io::write_obj_cache(dir / "animation.obj", cache.surface, cache.frames.front(), cache.crack_uv);
    io::write_pc2(dir / "animation.pc2", cache.frames);
  }
  if (out.gltf) {
    SurfaceMesh rest = cache.surface;
    rest.vertices = rest.reference;  // each piece's mesh in its reference pose; the nodes move it
    std::vector<std::uint32_t> ids(rest.fragment.begin(), rest.fragment.end());
    std::sort(ids.begin(), ids.end());
    ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
    std::vector<double> times;
    for (const AnimationFrame& f : history.frames) times.push_back(double(f.frame) / world.scene().time.frame_rate);
    io::write_glb(dir / "animation.glb", rest, cache.crack_uv, times, piece_tracks(history, ids),
                  std::string("perifx ") + PERIFX_VERSION);
  }
}

}  // namespace

std::vector<fs::path> run_files(const fs::path& dir) {
  std::vector<fs::path> out;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return out;
  for (const auto& entry : fs::directory_iterator(dir, ec))
    if (entry.is_regular_file() && is_run_file(entry.path().filename().string())) out.push_back(entry.path());
  std::sort(out.begin(), out.end());
  return out;
}

RunSummary run_world(World& world, const RunOptions& options) {
  using clock = std::chrono::steady_clock;
  const auto& sc = world.scene();
  RunSummary summary;
  summary.output_directory = options.output_directory ? *options.output_directory : sc.output.directory;
  const std::uint64_t frames =
      options.frames ? *options.frames
                     : static_cast<std::uint64_t>(std::floor(sc.time.duration * sc.time.frame_rate + 1e-9));
  auto step_of_frame = [&](std::uint64_t k) { return io::frame_step(k, sc.time.frame_rate, world.dt()); };
  const std::uint64_t total_steps = step_of_frame(frames);
  io::PvdSeries pvd(summary.output_directory / "particles.pvd");
  io::PvdSeries surface_pvd(summary.output_directory / "surface.pvd");
  io::PvdSeries tets_pvd(summary.output_directory / "tets.pvd");
  bool mesh_output = sc.output.obj || sc.output.surface_ply || sc.output.surface_vtp || sc.output.tets_vtu;
  bool animation = sc.output.cache || sc.output.gltf;
  // A distributed run's rank 0 holds the embedded mesh and splits it at each gather (runtime.hpp).
  const bool distributed = world.distributed();
  const bool has_mesh = world.has_embedded_mesh();
  // Surfaces the scene did not ask for (the default) are left out of runs without a split mesh (FEM).
  if (mesh_output && !has_mesh && sc.output.surfaces_by_default) mesh_output = false;
  if (mesh_output && !has_mesh)
    throw std::invalid_argument("output formats obj/surface_ply/surface_vtp/tets_vtu need the embedded tet mesh "
                                "(solver 'peridynamics')");
  // Rank 0 of a distributed run (or the one process) writes the files; every rank reads a checkpoint.
  const bool lead = !distributed || world.rank() == 0;
  if (lead) io::remove_stale_temporaries(summary.output_directory);  // *.tmp-<pid> of killed runs
  if (animation && !has_mesh) {
    if (!sc.output.surfaces_by_default)
      throw std::invalid_argument("output formats cache/gltf need the embedded tet mesh (solver 'peridynamics')");
    animation = false;
  }
  AnimationHistory history;
  history.record_vertices = sc.output.cache;
  history.min_piece_tets = sc.output.min_piece_tets;
  const std::size_t bonds = world.bond_count();

  // A folder holding another run: refuse, clear it, or continue it from its checkpoint.
  const fs::path& dir = summary.output_directory;
  const fs::path checkpoint = dir / "checkpoint.bin";
  std::uint64_t start_frame = 0, first_step = world.step_count();
  std::string projectile_csv;  // projectiles.csv so far
  // Rank 0 alone judges the folder: the others would see the files it begins writing (and a refusal
  // on rank 0 stops the whole job anyway).
  const auto existing = lead ? run_files(dir) : std::vector<fs::path>{};
  if (options.existing == ExistingRun::resume && fs::exists(checkpoint)) {
    const auto note = nlohmann::json::parse(world.load_checkpoint(checkpoint));
    start_frame = note.at("frame").get<std::uint64_t>();
    if (start_frame > frames)
      throw std::invalid_argument("cannot resume: the checkpoint in '" + dir.string() + "' is at frame " +
                                  std::to_string(start_frame) + ", past this run's last frame " + std::to_string(frames) +
                                  " (ask for more frames, or --overwrite)");
    first_step = note.at("first_step").get<std::uint64_t>();
    pvd.restore(note.at("particles_pvd").get<PvdEntries>());
    surface_pvd.restore(note.at("surface_pvd").get<PvdEntries>());
    tets_pvd.restore(note.at("tets_pvd").get<PvdEntries>());
    projectile_csv = note.at("projectile_csv").get<std::string>();
    if (animation && lead) {  // rank 0 keeps the history (and the mesh it is trimmed against)
      // Written just before the checkpoint, so it reaches the checkpoint's frame (or one later).
      history = io::read_animation_history(dir / "animation.bin");
      try {
        trim_animation_history(history, world, start_frame);
      } catch (const std::runtime_error& e) {
        throw io::IoError("cannot resume from '" + (dir / "animation.bin").string() + "': " + e.what());
      }
    }
    // Frames the interrupted run wrote after its checkpoint are written again (the same bytes); any
    // beyond this run's last frame would not be, so they go, and so do temporaries a kill left.
    std::vector<fs::path> later;
    for (const auto& f : existing)
      if (frame_number(f.filename().string()) > static_cast<long long>(frames) ||
          f.filename().string().find(".tmp-") != std::string::npos)
        later.push_back(f);
    if (lead) remove_files(later);
  } else if (!existing.empty()) {
    if (options.existing == ExistingRun::refuse) {
      std::string names;
      for (std::size_t k = 0; k < existing.size() && k < 3; ++k) names += (k ? ", " : "") + existing[k].filename().string();
      if (existing.size() > 3) names += ", ... (" + std::to_string(existing.size()) + " files)";
      throw io::IoError("output directory '" + dir.string() + "' holds another run's output (" + names +
                        "); use --overwrite to replace it or --resume to continue it");
    }
    if (lead) remove_files(existing);  // overwrite, or resume with no checkpoint: start over
  }
  if (!lead) return follow_run(world, frames, start_frame, first_step, step_of_frame, options.profile);
  summary.first_frame = start_frame;
  if (sc.output.obj) io::write_surface_mtl(summary.output_directory / "surface.mtl");

  double step_wall = 0.0, output_wall = 0.0;
  SurfaceMesh last_surface;  // the last written frame's surface (the animation exports' topology)
  const bool dust = sc.output.dust_points && sc.output.min_piece_tets > 0 && has_mesh;
  auto write_frame = [&](std::uint64_t k) {
    const auto t0 = clock::now();
    world.gather();  // a distributed run's state, into rank 0's world (nothing in one process)
    const auto fields = selected_fields(world);
    const std::vector<Vec3> points(world.positions().begin(), world.positions().end());
    if (sc.output.vtu) {
      io::write_vtu_points(summary.output_directory / frame_name(k, "vtu"), points, fields);
      pvd.add(world.time(), frame_name(k, "vtu"));
    }
    if (sc.output.ply) io::write_ply_points(summary.output_directory / frame_name(k, "ply"), points, fields);
    // Embedded tet mesh (§5.2): the split mesh's surface (original + crack triangles) and its tets.
    if (mesh_output || animation) {
      if (sc.output.obj || sc.output.surface_ply || sc.output.surface_vtp || animation) {
        // One evaluation of the vertices per frame, shared by the surface files and the animation.
        SurfaceMesh surface = world.surface();
        if (animation) record_animation_frame(history, world, k);
        if (sc.output.obj) io::write_obj_surface(dir / frame_name(k, "obj", "surface"), surface);
        if (sc.output.surface_ply) io::write_ply_surface(dir / frame_name(k, "ply", "surface"), surface);
        if (sc.output.surface_vtp) {
          io::write_vtp_surface(dir / frame_name(k, "vtp", "surface"), surface);
          surface_pvd.add(world.time(), frame_name(k, "vtp", "surface"));
        }
        if (animation) last_surface = std::move(surface);
      }
      if (mesh_output && sc.output.tets_vtu) {
        const TetMeshView mesh = world.tet_mesh();
        const FieldView damage = world.field("damage"), fragment = world.field("fragment_id");
        const auto* damage_data = static_cast<const double*>(damage.data);
        const auto* fragment_data = static_cast<const std::uint32_t*>(fragment.data);
        io::write_vtu_tets(dir / frame_name(k, "vtu", "tets"), {mesh.vertices.begin(), mesh.vertices.end()},
                           {mesh.tets.begin(), mesh.tets.end()}, {damage_data, damage_data + damage.count},
                           {fragment_data, fragment_data + fragment.count});
        tets_pvd.add(world.time(), frame_name(k, "vtu", "tets"));
      }
    }
    // Dust (output.dust = points): the particles of the pieces the surface leaves out, as PLY points.
    if (dust) {
      const std::vector<std::uint32_t> dust_ids = world.dust_particles();
      const auto y = world.positions();
      const auto v = world.velocities();
      const WorldState& st = world.state();
      std::vector<Vec3> where, speed;
      std::vector<double> radius;
      std::vector<std::uint32_t> piece;
      for (std::uint32_t p : dust_ids) {
        where.push_back(y[p]);
        speed.push_back(v[p]);
        radius.push_back(std::cbrt(3.0 * st.particles.volume[p] / (4.0 * 3.14159265358979323846)));
        piece.push_back(st.derived.fragment_id[p]);
      }
      const std::size_t n = dust_ids.size();
      const std::vector<FieldView> dust_fields = {
          {"velocity", FieldType::f64, 3, FieldLocation::particle, speed.data(), n, "m/s", "particle velocity"},
          {"radius", FieldType::f64, 1, FieldLocation::particle, radius.data(), n, "m", "radius of the sphere of the particle's volume"},
          {"piece", FieldType::u32, 1, FieldLocation::particle, piece.data(), n, "1", "fragment_id of the dropped piece"}};
      io::write_ply_points(dir / frame_name(k, "ply", "dust"), where, dust_fields);
    }
    // Rigid projectiles: one CSV row per projectile and frame; the whole file is rewritten
    // atomically each frame, so a reader never sees a half-written row.
    if (const auto projectiles = world.projectiles(); !projectiles.empty()) {
      std::ostringstream rows;
      rows.precision(17);
      if (projectile_csv.empty()) projectile_csv = "time,id,x,y,z,vx,vy,vz,wx,wy,wz,fx,fy,fz,radius\n";
      for (std::size_t id = 0; id < projectiles.size(); ++id) {
        const auto& pr = projectiles[id];
        rows << world.time() << ',' << id;
        for (const Vec3* v : {&pr.center, &pr.velocity, &pr.angular_velocity, &pr.contact_force})
          rows << ',' << v->x() << ',' << v->y() << ',' << v->z();
        rows << ',' << pr.radius << '\n';
      }
      projectile_csv += rows.str();
      io::write_atomic(summary.output_directory / "projectiles.csv", [&](std::ostream& out) { out << projectile_csv; });
    }
    output_wall += std::chrono::duration<double>(clock::now() - t0).count();
  };

  auto write_checkpoint = [&](std::uint64_t k) {
    const auto t0 = clock::now();
    nlohmann::json note = {{"frame", k},
                           {"first_step", first_step},
                           {"particles_pvd", pvd.entries()},
                           {"surface_pvd", surface_pvd.entries()},
                           {"tets_pvd", tets_pvd.entries()},
                           {"projectile_csv", projectile_csv},
                           {"distributed", distributed}};
    if (animation) io::write_animation_history(dir / "animation.bin", history);
    world.save_checkpoint(checkpoint, note.dump());
    output_wall += std::chrono::duration<double>(clock::now() - t0).count();
  };

  if (start_frame == 0) {
    write_frame(0);
    // mesh.json: what the particles are and the tet connectivity, so `perifx compare` can map a
    // peridynamic run (tet barycenters) onto an FEM run (mesh vertices) of the same scene.
    io::write_run_mesh(summary.output_directory, run_mesh(world));
  }
  summary.last_frame = start_frame;
  world.set_profiling(options.profile);
  const std::uint64_t session_step = world.step_count();  // rates count this session's steps only
  const std::uint64_t every = sc.output.checkpoint_every;
  for (std::uint64_t k = start_frame + 1; k <= frames; ++k) {
    const std::uint64_t target = first_step + step_of_frame(k);
    const auto t0 = clock::now();
    try {
      while (world.step_count() < target) world.step();
    } catch (const InstabilityError& e) {
      // Name the last good frame (already on disk); the bad state is never written.
      std::string message = e.what();
      const std::string note = "; the last valid frame is " + std::to_string(k - 1) + " (already written)";
      const auto hint = message.find("; hint:");
      message.insert(hint == std::string::npos ? message.size() : hint, note);
      throw InstabilityError(message, e.step(), e.particle());
    }
    step_wall += std::chrono::duration<double>(clock::now() - t0).count();
    write_frame(k);
    summary.last_frame = k;
    // Rank 0 decides for every rank (follow_run makes the same call).
    const bool stop = world.broadcast(options.stop_requested && options.stop_requested() && k < frames);
    if (stop || (every > 0 && (k % every == 0 || k == frames))) write_checkpoint(k);
    if (options.on_frame) {
      RunProgress pr;
      pr.frame = k;
      pr.frames = frames;
      pr.step = world.step_count() - first_step;
      pr.steps = total_steps;
      pr.wall_seconds = step_wall + output_wall;
      const std::uint64_t stepped = world.step_count() - session_step;
      pr.steps_per_second = step_wall > 0 ? double(stepped) / step_wall : 0.0;
      const double per_step = stepped ? pr.wall_seconds / double(stepped) : 0.0;
      pr.eta_seconds = per_step * double(total_steps - pr.step);
      pr.time = world.time();
      pr.world = &world;
      options.on_frame(pr);
    }
    if (stop) {
      summary.interrupted = true;
      break;
    }
  }

  if (animation && !history.frames.empty()) {
    const auto t0 = clock::now();
    // A resume that ran no frame has no surface yet: the checkpoint's (one more evaluation).
    if (last_surface.triangles.empty() && history.frames.back().frame == summary.last_frame) last_surface = world.surface();
    write_animation(world, history, last_surface, dir);
    output_wall += std::chrono::duration<double>(clock::now() - t0).count();
  }

  summary.particles = world.particle_count();
  summary.bonds = bonds;
  summary.alive_bonds = world.alive_bond_count();
  summary.fragments = world.fragment_count();
  summary.steps = world.step_count() - first_step;
  summary.frames = frames;
  summary.simulated_seconds = world.time();
  summary.wall_seconds = step_wall;
  summary.output_seconds = output_wall;
  if (rusage use{}; getrusage(RUSAGE_SELF, &use) == 0)
    summary.peak_memory_bytes = static_cast<std::uint64_t>(use.ru_maxrss) * 1024u;  // Linux: KiB
  summary.bond_updates_per_second =
      step_wall > 0 ? double(bonds) * double(world.step_count() - session_step) / step_wall : 0.0;
  summary.threads = world.threads();
  summary.ranks = world.ranks();
  summary.rebalances = world.rebalances();
  summary.first_break_time = world.first_break_time();
  summary.rank_stats = world.rank_stats();  // collective: follow_run makes the same call
  for (const RankStats& r : summary.rank_stats) {
    summary.contact_list_builds += r.contact.list_builds;
    summary.contact_list_additions += r.contact.list_additions;
    summary.contact_list_partial_updates += r.contact.list_partial_updates;
    summary.contact_list_searched += r.contact.list_searched;
  }
  if (options.profile) summary.system_times = world.all_ranks_system_times(), summary.setup_times = world.setup_times();

  // nlohmann-json does the quoting, so any scene name gives valid JSON; ordered keeps the field order.
  nlohmann::ordered_json js;
  js["scene"] = sc.name;
  js["version"] = PERIFX_VERSION;
  js["particles"] = summary.particles;
  js["bonds"] = summary.bonds;
  js["alive_bonds"] = summary.alive_bonds;
  js["fragments"] = summary.fragments;
  js["first_break_time"] = summary.first_break_time ? nlohmann::ordered_json(*summary.first_break_time)
                                                    : nlohmann::ordered_json(nullptr);
  js["steps"] = summary.steps;
  js["frames"] = summary.frames;
  js["dt"] = world.dt();
  js["simulated_seconds"] = summary.simulated_seconds;
  js["threads"] = summary.threads;
  js["step_wall_seconds"] = summary.wall_seconds;
  js["output_wall_seconds"] = summary.output_seconds;
  js["bond_updates_per_second"] = summary.bond_updates_per_second;
  js["peak_memory_bytes"] = summary.peak_memory_bytes;
  js["ranks"] = summary.ranks;
  js["rebalances"] = summary.rebalances;
  js["contact_list_builds"] = summary.contact_list_builds;
  js["contact_list_additions"] = summary.contact_list_additions;
  js["contact_list_partial_updates"] = summary.contact_list_partial_updates;
  js["contact_list_searched"] = summary.contact_list_searched;
  if (summary.ranks > 1) {
    auto& shares = js["rank_stats"];
    shares = nlohmann::ordered_json::array();
    for (const RankStats& r : summary.rank_stats)
      shares.push_back({{"owned_particles", r.owned_particles},
                        {"bond_ghosts", r.bond_ghosts},
                        {"contact_ghosts", r.contact_ghosts},
                        {"halo_bytes_per_step", r.steps ? double(r.halo_bytes) / double(r.steps) : 0.0},
                        {"contact_ghost_refreshes", r.contact_ghost_refreshes},
                        {"contact_list_builds", r.contact.list_builds},
                        {"contact_list_searched", r.contact.list_searched},
                        {"state_gathers", r.state_gathers},
                        {"piece_rounds", r.piece_rounds},
                        {"replay_seconds", r.replay_seconds},
                        {"gather_seconds", r.gather_seconds},
                        {"piece_seconds", r.piece_seconds}});
  }
  js["first_frame"] = summary.first_frame;  // > 0: resumed after that frame's checkpoint
  js["last_frame"] = summary.last_frame;
  js["interrupted"] = summary.interrupted;
  if (options.profile) {
    auto& prof = js["profile"];
    prof = nlohmann::ordered_json::array();
    for (const auto& t : summary.system_times)
      prof.push_back({{"system", t.name}, {"wall_seconds", t.seconds}, {"steps", t.runs}});
    if (summary.ranks > 1)
      for (std::size_t k = 0; k < summary.system_times.size(); ++k)
        prof[k]["rank_wall_seconds"] = summary.system_times[k].rank_seconds;
    auto& setup = js["setup_profile"];
    setup = nlohmann::ordered_json::array();
    for (const auto& t : summary.setup_times) setup.push_back({{"phase", t.name}, {"wall_seconds", t.seconds}});
  }
  // Timings differ run to run; keep them out of the frame files so those stay byte-identical.
  const std::string text = js.dump(2) + "\n";
  io::write_atomic(summary.output_directory / "summary.json", [&](std::ostream& out) { out << text; });
  return summary;
}

std::string profile_table(const RunSummary& summary) {
  std::string out;
  char line[200];
  // Steps of this session (a resumed run counts from its checkpoint): the most any system ran.
  std::uint64_t runs = 0;
  for (const auto& t : summary.system_times) runs = std::max(runs, t.runs);
  const double steps = runs > 0 ? double(runs) : 1.0;
  const double wall = summary.wall_seconds > 0 ? summary.wall_seconds : 1.0;
  // A distributed run adds the fastest and slowest rank's seconds per system (this table is rank 0's):
  // a halo exchange where some rank is much slower than another is where the faster ones wait.
  const bool by_rank = !summary.system_times.empty() && !summary.system_times.front().rank_seconds.empty();
  std::snprintf(line, sizeof line, "%-22s %10s %10s %8s%s\n", "system", "wall s", "ms/step", "share",
                by_rank ? "   fastest rank s  slowest rank s" : "");
  out += line;
  double in_systems = 0.0;
  for (const auto& t : summary.system_times) {
    std::snprintf(line, sizeof line, "%-22s %10.3f %10.4f %7.1f%%", t.name.c_str(), t.seconds,
                  t.runs ? 1e3 * t.seconds / double(t.runs) : 0.0, 100.0 * t.seconds / wall);
    out += line;
    if (by_rank) {
      const auto [low, high] = std::minmax_element(t.rank_seconds.begin(), t.rank_seconds.end());
      std::snprintf(line, sizeof line, " %8.3f (r%td) %8.3f (r%td)", *low, low - t.rank_seconds.begin(), *high,
                    high - t.rank_seconds.begin());
      out += line;
    }
    out += "\n";
    in_systems += t.seconds;
  }
  // The rest of the stepping time: graph start-up and hand-over between nodes, the instability
  // check. A profiled step runs one system at a time (Scheduler::set_profiling), so it is not negative
  // beyond clock rounding; shown as 0 then.
  const double rest = std::max(0.0, summary.wall_seconds - in_systems);
  std::snprintf(line, sizeof line, "%-22s %10.3f %10.4f %7.1f%%\n", "(between systems)", rest, 1e3 * rest / steps,
                100.0 * rest / wall);
  out += line;
  std::snprintf(line, sizeof line, "%-22s %10.3f %10.4f %7.1f%%\n", "stepping total", summary.wall_seconds,
                1e3 * summary.wall_seconds / steps, 100.0);
  out += line;
  std::snprintf(line, sizeof line, "%-22s %10.3f %10s %8s\n", "file output", summary.output_seconds, "-", "-");
  out += line;
  if (!summary.setup_times.empty()) {
    double total = 0.0;
    out += "set-up phase                              wall s\n";
    for (const auto& t : summary.setup_times) {
      std::snprintf(line, sizeof line, "%-40s %8.3f\n", t.name.c_str(), t.seconds);
      out += line;
      total += t.seconds;
    }
    std::snprintf(line, sizeof line, "%-40s %8.3f\n", "set-up total", total);
    out += line;
  }
  return out;
}

}  // namespace perifx
