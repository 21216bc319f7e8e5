#include "io/animation_history.hpp"

#include <cstring>
#include <string>

#include "io/atomic.hpp"

namespace perifx::io {

namespace fs = std::filesystem;

namespace {

constexpr char kMagic[8] = {'P', 'F', 'X', 'A', 'N', 'I', 'M', '1'};
constexpr char kEnd[4] = {'E', 'N', 'D', '!'};

class Out {
 public:
  explicit Out(std::ostream& os) : os_(os) {}
  template <class T>
  void put(const T& v) { os_.write(reinterpret_cast<const char*>(&v), sizeof v); }
  void put_vec(const Vec3& v) { put(v.x()), put(v.y()), put(v.z()); }
  template <class T>
  void put_array(const std::vector<T>& a) {
    put(std::uint64_t{a.size()});
    os_.write(reinterpret_cast<const char*>(a.data()), static_cast<std::streamsize>(a.size() * sizeof(T)));
  }
 private:
  std::ostream& os_;
};

class In {
 public:
  In(std::string data, fs::path file) : data_(std::move(data)), file_(std::move(file)) {}
  [[noreturn]] void bad(const std::string& why) const {
    throw IoError("cannot read animation history '" + file_.string() + "': " + why);
  }
  void raw(void* out, std::size_t n) {
    if (n > data_.size() - at_) bad("the file is truncated");
    std::memcpy(out, data_.data() + at_, n);
    at_ += n;
  }
  template <class T>
  T get() { T v; raw(&v, sizeof v); return v; }
  Vec3 get_vec() { Vec3 v; v.x() = get<double>(), v.y() = get<double>(), v.z() = get<double>(); return v; }
  template <class T>
  void get_array(std::vector<T>& a) {
    const auto n = get<std::uint64_t>();
    if (n > (data_.size() - at_) / sizeof(T)) bad("the file is truncated");
    a.resize(n);
    raw(a.data(), n * sizeof(T));
  }
 private:
  std::string data_;
  fs::path file_;
  std::size_t at_ = 0;
};

}  // namespace

void write_animation_history(const fs::path& file, const AnimationHistory& h) {
  write_atomic(file, [&](std::ostream& os) {
    Out out(os);
    os.write(kMagic, sizeof kMagic);
    out.put(std::uint8_t{h.record_vertices});
    out.put(h.min_piece_tets);
    out.put(std::uint64_t{h.frames.size()});
    for (const AnimationFrame& f : h.frames) {
      out.put(f.frame);
      out.put(f.time);
      out.put(f.vertex_count);
      out.put(static_cast<std::uint32_t>(f.pieces.size()));
      for (const PieceSample& p : f.pieces) {
        out.put(p.id);
        out.put(p.particles);
        out.put(p.mass);
        out.put_vec(p.center);
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) out.put(p.rotation(r, c));
        out.put_vec(p.translation);
        out.put_vec(p.velocity);
        out.put_vec(p.angular_velocity);
      }
      out.put(std::uint8_t{!f.positions.empty()});
      if (!f.positions.empty()) out.put_array(f.positions);
    }
    out.put(std::uint64_t{h.origins.size()});
    for (const auto& [id, o] : h.origins) out.put(id), out.put(o.birth_frame), out.put(o.parent);
    out.put_array(h.vertex_parent);
    out.put_array(h.vertex_birth);
    os.write(kEnd, sizeof kEnd);
  });
}

AnimationHistory read_animation_history(const fs::path& file) {
  In in(read_file(file, "animation history"), file);
  char magic[8];
  in.raw(magic, sizeof magic);
  if (std::memcmp(magic, kMagic, sizeof magic) != 0) in.bad("not a perifx animation history (expected 'PFXANIM1' first)");
  AnimationHistory h;
  h.record_vertices = in.get<std::uint8_t>() != 0;
  h.min_piece_tets = in.get<std::uint32_t>();
  const auto frames = in.get<std::uint64_t>();
  for (std::uint64_t k = 0; k < frames; ++k) {
    AnimationFrame f;
    f.frame = in.get<std::uint64_t>();
    f.time = in.get<double>();
    f.vertex_count = in.get<std::uint32_t>();
    const auto pieces = in.get<std::uint32_t>();
    for (std::uint32_t q = 0; q < pieces; ++q) {
      PieceSample p;
      p.id = in.get<std::uint32_t>();
      p.particles = in.get<std::uint32_t>();
      p.mass = in.get<double>();
      p.center = in.get_vec();
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) p.rotation(r, c) = in.get<double>();
      p.translation = in.get_vec();
      p.velocity = in.get_vec();
      p.angular_velocity = in.get_vec();
      f.pieces.push_back(p);
    }
    if (in.get<std::uint8_t>()) {
      in.get_array(f.positions);
      if (f.positions.size() != 3ull * f.vertex_count) in.bad("frame " + std::to_string(f.frame) + " has the wrong number of positions");
    }
    h.frames.push_back(std::move(f));
  }
  const auto origins = in.get<std::uint64_t>();
  for (std::uint64_t k = 0; k < origins; ++k) {
    const auto id = in.get<std::uint32_t>();
    PieceOrigin o;
    o.birth_frame = in.get<std::uint64_t>();
    o.parent = in.get<std::uint32_t>();
    h.origins.emplace(id, o);
  }
  in.get_array(h.vertex_parent);
  in.get_array(h.vertex_birth);
  if (h.vertex_parent.size() != h.vertex_birth.size()) in.bad("vertex parents and birth frames differ in count");
  char end[4];
  in.raw(end, sizeof end);
  if (std::memcmp(end, kEnd, sizeof end) != 0) in.bad("no end marker (expected 'END!')");
  return h;
}

}  // namespace perifx::io
