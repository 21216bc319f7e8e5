#include "io/pieces_csv.hpp"

#include <charconv>
#include <string>

#include "io/atomic.hpp"

namespace perifx::io {

namespace {

void put(std::string& s, double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  s.append(buf, r.ptr);
}
void put(std::string& s, std::uint64_t v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  s.append(buf, r.ptr);
}

}  // namespace

void write_pieces_csv(const std::filesystem::path& file, const AnimationHistory& h) {
  std::string text = "piece,frame,time,birth_frame,parent,particles,mass,cx,cy,cz,tx,ty,tz,qx,qy,qz,qw,vx,vy,vz,wx,wy,wz\n";
  for (const AnimationFrame& f : h.frames)
    for (const PieceSample& p : f.pieces) {
      const auto o = h.origins.find(p.id);
      put(text, std::uint64_t{p.id}), text += ',';
      put(text, f.frame), text += ',';
      put(text, f.time), text += ',';
      put(text, o == h.origins.end() ? f.frame : o->second.birth_frame), text += ',';
      if (o != h.origins.end() && o->second.parent != kNoPiece) put(text, std::uint64_t{o->second.parent});
      text += ',';
      put(text, std::uint64_t{p.particles}), text += ',';
      put(text, p.mass);
      const Eigen::Vector4d q = rotation_quaternion(p.rotation);
      for (const Vec3* v : {&p.center, &p.translation}) {
        for (int d = 0; d < 3; ++d) text += ',', put(text, (*v)[d]);
      }
      for (int d = 0; d < 4; ++d) text += ',', put(text, q[d]);
      for (const Vec3* v : {&p.velocity, &p.angular_velocity}) {
        for (int d = 0; d < 3; ++d) text += ',', put(text, (*v)[d]);
      }
      text += '\n';
    }
  write_atomic(file, [&](std::ostream& os) { os.write(text.data(), static_cast<std::streamsize>(text.size())); });
}

}  // namespace perifx::io
