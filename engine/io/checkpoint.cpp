// Checkpoint writer and reader (see checkpoint.hpp).
#include "io/checkpoint.hpp"

#include <cstdio>
#include <cstring>
#include <fstream>
#include <set>
#include <string_view>

#include <nlohmann/json.hpp>

#include "io/atomic.hpp"

namespace perifx::io {

namespace fs = std::filesystem;

namespace {

constexpr char kMagic[8] = {'P', 'E', 'R', 'I', 'F', 'X', 'C', 'K'};
constexpr std::uint32_t kVersion = 24;  // 2: embedded.held_deformation, embedded.held_tracked;
                                       // 3: contact moved-particle updates (per-particle search positions);
                                       // 4: no per-bond |ξ|, ω, mirror index; e^p as float (issue 16);
                                       // 5: model.anisotropy_metric (GᵀG per particle);
                                       // 6: clock.first_break_step
                                       // 7: projectiles.contacts and .touched, global_index
                                       // 8: surface.radius (faces for projectiles)
                                       // 9: state.surface_frame (faces for colliders)
                                       // 10: no projectiles.particle_force, .torque, .touched
                                       // 11: state.collider_contact
                                       // 12: state.collider_contact holds two colliders (32 B)
                                       // 13: model.anisotropic_family
                                       // 14: openable_faces, state.open_faces (crack faces for colliders)
                                       // 15: state.collider_contact holds three colliders (48 B)
                                       // 16: embedded.deformation_origin
                                       // 17: embedded.deformation_origin_velocity
                                       // 18: model.reference_point
                                       // 19: contact.pairs.partner_moved, .near_count
                                       // 20: contact.pairs.resort
                                       // 21: contact.pairs.length (rows with spare capacity)
                                       // 22: contact.search_grid, contact.pairs.displaced(_list)
                                       // 23: contact.displaced_grid
                                       // 24: the header's contact_time_scale (the contact law changed)

// Not saved: worker-slot scratch (sized by the thread count, so a resume on another thread count keeps
// its own) and the projectiles' per-block contact lists (refilled by every step before any reads).
// Per-particle arrays are all saved, even those a step rewrites before reading (state.bond_end,
// state.collider_contact): a resume on another rank count splits the particle arrays it read, and an
// array left out kept its old length there.
bool not_saved(std::string_view name) {
  return name == "contact.pairs.bonded_stamp" || name == "projectiles.block_contacts";
}

// The scalars of a WorldState that no array holds, in one fixed order for writing and reading.
template <class W, class F>
void for_each_scalar(W& w, F&& f) {
  f(w.clock.time);
  f(w.clock.dt);
  f(w.clock.step);
  f(w.clock.first_break_step);
  auto& c = w.contact;
  f(c.largest_distance);
  f(c.grid.cell);
  f(c.grid.mask);
  f(c.search_grid.cell);
  f(c.search_grid.mask);
  f(c.displaced_grid.cell);
  f(c.displaced_grid.mask);
  f(c.pairs.skin);
  f(c.pairs.stamp_base);
  f(c.pairs.broken_at_build);
  f(c.pairs.additions);
  f(c.pairs.valid);
  f(c.pairs.builds);
  f(c.pairs.partial_updates);
  f(c.pairs.searched);
  f(c.pairs.layouts);
  f(c.pairs.search_grid_valid);
  f(c.pairs.search_grid_builds);
  f(c.pairs.displaced_grid_builds);
  auto& e = w.embedded;
  f(e.crack_faces_total);
  f(e.vertex_copies_total);
  f(e.torn_faces_total);
  f(e.original_vertex_count);
  f(w.derived.fragment_count);
  f(w.derived.next_fragment_id);  // stable piece ids (systems/fragments.cpp)
}

[[noreturn]] void bad(const fs::path& file, const std::string& why) {
  throw IoError("cannot resume from checkpoint '" + file.string() + "': " + why);
}

// Reads the file in place, array by array, straight into the world's arrays. Why not the whole file
// into memory first (as it once did, twice: once for the header): a resume then held the world and the
// file's bytes at once, 2.89 GiB at the glass-wall shot's step 2,000 against 1.43 GiB for the run that
// wrote it. Every length is checked against what is left of the file before anything is allocated, so
// a damaged count is refused as a truncated file rather than attempted.
class Reader {
 public:
  explicit Reader(fs::path file) : file_(std::move(file)) {
    std::error_code ec;
    size_ = fs::file_size(file_, ec);
    if (ec) bad(file_, "cannot read its size (" + ec.message() + ")");
    in_.open(file_, std::ios::binary);
    if (!in_) bad(file_, "cannot open it");
  }
  std::uint64_t left() const { return size_ - at_; }
  void read(void* out, std::size_t n) {
    if (n > left()) bad(file_, "the file is truncated");
    if (n == 0) return;  // an empty array's data() may be null
    in_.read(static_cast<char*>(out), static_cast<std::streamsize>(n));
    if (!in_) bad(file_, "a read failed");
    at_ += n;
  }
  template <class T>
  T value() {
    T v{};
    read(&v, sizeof v);
    return v;
  }
  std::string text() {
    const auto n = value<std::uint64_t>();
    if (n > left()) bad(file_, "the file is truncated");
    std::string s(n, '\0');
    read(s.data(), n);
    return s;
  }
  const fs::path& file() const { return file_; }

 private:
  fs::path file_;
  std::ifstream in_;
  std::uint64_t size_ = 0;
  std::uint64_t at_ = 0;
};

void put_text(std::ostream& out, const std::string& s) {
  const std::uint64_t n = s.size();
  out.write(reinterpret_cast<const char*>(&n), sizeof n);
  out.write(s.data(), std::streamsize(n));
}

nlohmann::json header_json(const CheckpointHeader& h) {
  return {{"scene_hash", h.scene_hash}, {"scene_text", h.scene_text}, {"solver", h.solver}, {"dt", h.dt},
          {"contact_time_scale", h.contact_time_scale}, {"step", h.step}, {"particles", h.particles}, {"bonds", h.bonds}, {"note", h.note}};
}

CheckpointHeader read_header(Reader& in) {
  char magic[8];
  in.read(magic, sizeof magic);
  if (std::memcmp(magic, kMagic, sizeof magic) != 0) bad(in.file(), "not a perifx checkpoint");
  if (const auto v = in.value<std::uint32_t>(); v != kVersion)
    bad(in.file(), "format version " + std::to_string(v) + " (this perifx reads version " + std::to_string(kVersion) + ")");
  CheckpointHeader h;
  try {
    const auto j = nlohmann::json::parse(in.text());
    h.scene_hash = j.at("scene_hash").get<std::string>();
    h.scene_text = j.at("scene_text").get<std::string>();
    h.solver = j.at("solver").get<std::string>();
    h.dt = j.at("dt").get<double>();
    h.contact_time_scale = j.at("contact_time_scale").get<double>();
    h.step = j.at("step").get<std::uint64_t>();
    h.particles = j.at("particles").get<std::uint64_t>();
    h.bonds = j.at("bonds").get<std::uint64_t>();
    h.note = j.at("note").get<std::string>();
  } catch (const nlohmann::json::exception& e) {
    bad(in.file(), std::string("malformed header (") + e.what() + ")");
  }
  return h;
}

}  // namespace

std::string scene_hash(const std::string& text) {
  std::uint64_t h = 0xcbf29ce484222325ull;  // FNV-1a 64
  for (const unsigned char ch : text) h = (h ^ ch) * 0x100000001b3ull;
  char buf[20];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

void write_checkpoint(const fs::path& file, const WorldState& w, CheckpointHeader h) {
  h.step = w.clock.step;
  h.dt = w.clock.dt;
  h.contact_time_scale = w.settings.contact.time_scale;
  h.particles = w.particles.count();
  h.bonds = w.bonds.count();
  write_atomic(file, [&](std::ostream& out) {
    out.write(kMagic, sizeof kMagic);
    out.write(reinterpret_cast<const char*>(&kVersion), sizeof kVersion);
    put_text(out, header_json(h).dump());
    for_each_array(w, [&](ArrayKind, const char* name, const auto& array) {
      if (not_saved(name)) return;
      using T = std::decay_t<decltype(array[0])>;
      put_text(out, name);
      const std::uint32_t size = sizeof(T);
      const std::uint64_t count = array.size();
      out.write(reinterpret_cast<const char*>(&size), sizeof size);
      out.write(reinterpret_cast<const char*>(&count), sizeof count);
      out.write(reinterpret_cast<const char*>(array.data()), std::streamsize(count * sizeof(T)));
    });
    for_each_scalar(w, [&](const auto& v) { out.write(reinterpret_cast<const char*>(&v), sizeof v); });
    out.write("END!", 4);
  });
}

CheckpointHeader read_checkpoint_header(const fs::path& file) {
  if (!fs::exists(file)) bad(file, "no such file");
  Reader in(file);
  return read_header(in);
}

std::string checkpoint_mismatch(const CheckpointHeader& h, const std::string& scene_text, double dt,
                                double contact_time_scale, const std::string& solver, std::uint64_t particles,
                                std::uint64_t bonds) {
  std::string why;
  auto add = [&](const std::string& s) { why += (why.empty() ? "" : "; ") + s; };
  if (h.scene_hash != scene_hash(scene_text)) {
    // Name the top-level keys that differ. threads, name and description do not change the results.
    std::string keys;
    try {
      const auto a = nlohmann::json::parse(h.scene_text), b = nlohmann::json::parse(scene_text);
      std::set<std::string> names;
      for (const auto& [k, v] : a.items()) names.insert(k);
      for (const auto& [k, v] : b.items()) names.insert(k);
      for (const auto& k : names) {
        if (k == "threads" || k == "description" || k == "name") continue;
        const bool in_a = a.contains(k), in_b = b.contains(k);
        if (in_a && in_b && a[k] == b[k]) continue;
        keys += (keys.empty() ? "" : ", ") + k + (!in_a ? " (added)" : !in_b ? " (removed)" : "");
      }
      if (!keys.empty()) add("the scene changed since the checkpoint (top-level keys: " + keys + ")");
    } catch (const nlohmann::json::exception&) {
      add("the scene text changed since the checkpoint (hash " + h.scene_hash + ", now " + scene_hash(scene_text) + ")");
    }
  }
  if (h.dt != dt) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "time step %.17g s, checkpoint has %.17g s", dt, h.dt);
    add(buf);
  }
  if (h.contact_time_scale != contact_time_scale) {
    char buf[112];
    std::snprintf(buf, sizeof buf, "contact time scale %.17g s, checkpoint has %.17g s", contact_time_scale,
                  h.contact_time_scale);
    add(buf);
  }
  if (h.solver != solver) add("solver " + solver + ", checkpoint has " + h.solver);
  if (why.empty() && (h.particles != particles || h.bonds != bonds))
    add(std::to_string(particles) + " particles and " + std::to_string(bonds) + " bonds, checkpoint has " +
        std::to_string(h.particles) + " and " + std::to_string(h.bonds));
  return why;
}

CheckpointHeader read_checkpoint(const fs::path& file, WorldState& w) {
  if (!fs::exists(file)) bad(file, "no such file");
  Reader in(file);
  CheckpointHeader h = read_header(in);
  for_each_array(w, [&](ArrayKind, const char* name, auto& array) {
    if (not_saved(name)) return;
    using T = std::decay_t<decltype(array[0])>;
    if (const std::string got = in.text(); got != name) bad(file, "expected array '" + std::string(name) + "', found '" + got + "'");
    const auto size = in.value<std::uint32_t>();
    const auto count = in.value<std::uint64_t>();
    if (size != sizeof(T)) bad(file, std::string("array '") + name + "' has elements of another size");
    if (count > in.left() / sizeof(T)) bad(file, "the file is truncated");
    array.resize(count);
    in.read(array.data(), count * sizeof(T));
  });
  for_each_scalar(w, [&](auto& v) { v = in.value<std::decay_t<decltype(v)>>(); });
  char end[4];
  in.read(end, sizeof end);
  if (std::memcmp(end, "END!", 4) != 0) bad(file, "the file does not end where expected");
  return h;
}

}  // namespace perifx::io
