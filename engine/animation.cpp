#include "animation.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

#include "components/world_state.hpp"
#include "systems/systems.hpp"

namespace perifx {
namespace {

struct Sums {
  std::uint32_t particles = 0;
  std::uint32_t first = 0;             // smallest particle index
  double mass = 0.0;
  Vec3 mx = Vec3::Zero(), my = Vec3::Zero(), mv = Vec3::Zero();
  Mat3 cross = Mat3::Zero();           // Σ m (X − X̄)(y − ȳ)ᵀ
  Vec3 momentum = Vec3::Zero();        // Σ m (y − ȳ) × (v − v̄)
  Mat3 inertia = Mat3::Zero();         // Σ m (|r|² 1 − r rᵀ), r = y − ȳ
};

template <class T>
const T* field_data(const World& world, const char* name) {
  return static_cast<const T*>(world.field(name).data);
}

}  // namespace

void record_animation_frame(AnimationHistory& h, const World& world, std::uint64_t frame) {
  if (!h.frames.empty() && frame <= h.frames.back().frame)
    throw std::logic_error("animation frames must increase (frame " + std::to_string(frame) + " after " +
                           std::to_string(h.frames.back().frame) + ")");
  AnimationFrame out;
  out.frame = frame;
  out.time = world.time();

  // ---- pieces: two passes over the particles in index order ----
  const std::size_t n = world.particle_count();
  const auto* fragment = field_data<std::uint32_t>(world, "fragment_id");
  const auto* mass = field_data<double>(world, "mass");
  const auto x = world.reference_positions();
  const auto y = world.positions();
  const auto v = world.velocities();
  std::map<std::uint32_t, Sums> sums;
  for (std::size_t i = 0; i < n; ++i) {
    Sums& s = sums[fragment[i]];
    if (s.particles == 0) s.first = static_cast<std::uint32_t>(i);
    ++s.particles;
    s.mass += mass[i];
    s.mx += mass[i] * x[i];
    s.my += mass[i] * y[i];
    s.mv += mass[i] * v[i];
  }
  for (std::size_t i = 0; i < n; ++i) {
    Sums& s = sums[fragment[i]];
    if (s.particles < h.min_piece_tets) continue;
    const Vec3 xc = s.mx / s.mass, yc = s.my / s.mass, vc = s.mv / s.mass;
    const Vec3 r = y[i] - yc;
    s.cross += mass[i] * (x[i] - xc) * r.transpose();
    s.momentum += mass[i] * r.cross(v[i] - vc);
    s.inertia += mass[i] * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
  }
  const bool first_frame = h.frames.empty() && h.previous_fragment.empty();
  for (const auto& [id, s] : sums) {
    if (!h.origins.count(id)) {
      PieceOrigin o;
      o.birth_frame = frame;
      if (!first_frame && s.first < h.previous_fragment.size()) o.parent = h.previous_fragment[s.first];
      h.origins.emplace(id, o);
    }
    if (s.particles < h.min_piece_tets || s.mass <= 0.0) continue;
    PieceSample p;
    p.id = id;
    p.particles = s.particles;
    p.mass = s.mass;
    p.center = s.my / s.mass;
    // The proper rotation minimising Σ m |R (X − X̄) − (y − ȳ)|²: the rotation factor of Σ m (y − ȳ)(X − X̄)ᵀ.
    p.rotation = systems::polar_rotation(s.cross.transpose());
    p.translation = p.center - p.rotation * (s.mx / s.mass);
    p.velocity = s.mv / s.mass;
    p.angular_velocity = systems::angular_velocity(s.inertia, s.momentum);
    out.pieces.push_back(p);
  }

  h.previous_fragment.assign(fragment, fragment + n);

  // ---- vertices: parents of the copies made since the previous frame ----
  // The vertices as the caller's World::surface() / tet_mesh() left them: evaluating them again would
  // move particles with few bonds on (their held rotation relaxes each evaluation).
  const EmbeddedMesh& mesh = world.state().embedded;
  const std::size_t known = h.vertex_parent.size(), count = mesh.vertices.size();
  h.vertex_parent.resize(count, kNoPiece);
  h.vertex_birth.resize(count, frame);
  if (count > known) {
    if (first_frame || h.previous_tets.size() != mesh.tets.size()) {
      for (std::size_t c = known; c < count; ++c) h.vertex_parent[c] = static_cast<std::uint32_t>(c);
    } else {
      // A copy c in slot j of tet t was split off the vertex that slot held the frame before.
      for (std::size_t t = 0; t < mesh.tets.size(); ++t)
        for (int j = 0; j < 4; ++j) {
          const std::uint32_t c = mesh.tets[t][j];
          if (c >= known && h.vertex_parent[c] == kNoPiece) h.vertex_parent[c] = h.previous_tets[t][j];
        }
      const auto& origin = world.state().embedded.origin;  // unused copies: their original vertex
      for (std::size_t c = known; c < count; ++c)
        if (h.vertex_parent[c] == kNoPiece) h.vertex_parent[c] = c < origin.size() ? origin[c] : std::uint32_t(c);
    }
  }
  out.vertex_count = static_cast<std::uint32_t>(count);
  if (h.record_vertices) {
    out.positions.resize(3 * count);
    for (std::size_t k = 0; k < count; ++k)
      for (int d = 0; d < 3; ++d) out.positions[3 * k + d] = static_cast<float>(mesh.vertices[k][d]);
  }
  h.previous_tets.assign(mesh.tets.begin(), mesh.tets.end());
  h.frames.push_back(std::move(out));
}

void trim_animation_history(AnimationHistory& h, const World& world, std::uint64_t frame) {
  while (!h.frames.empty() && h.frames.back().frame > frame) h.frames.pop_back();
  if (h.frames.empty() || h.frames.back().frame != frame)
    throw std::runtime_error("the animation history does not reach frame " + std::to_string(frame));
  const std::uint32_t count = h.frames.back().vertex_count;
  const EmbeddedMesh& mesh = world.state().embedded;  // as the checkpoint left it (no re-evaluation)
  if (mesh.vertices.size() != count)
    throw std::runtime_error("the animation history has " + std::to_string(count) + " vertices at frame " +
                             std::to_string(frame) + ", the checkpoint " + std::to_string(mesh.vertices.size()));
  h.vertex_parent.resize(count);
  h.vertex_birth.resize(count);
  for (auto it = h.origins.begin(); it != h.origins.end();)
    it = it->second.birth_frame > frame ? h.origins.erase(it) : std::next(it);
  h.previous_tets.assign(mesh.tets.begin(), mesh.tets.end());
  const FieldView fragment = world.field("fragment_id");
  const auto* ids = static_cast<const std::uint32_t*>(fragment.data);
  h.previous_fragment.assign(ids, ids + fragment.count);
}

const PieceSample* piece_pose(const AnimationHistory& h, std::size_t f, std::uint32_t id) {
  const auto& pieces = h.frames[f].pieces;
  for (int guard = 0; guard < 1 << 20 && id != kNoPiece; ++guard) {
    const auto it = std::lower_bound(pieces.begin(), pieces.end(), id,
                                     [](const PieceSample& p, std::uint32_t i) { return p.id < i; });
    if (it != pieces.end() && it->id == id) return &*it;
    const auto o = h.origins.find(id);
    if (o == h.origins.end()) return nullptr;
    id = o->second.parent;
  }
  return nullptr;
}

Vec3 vertex_position(const AnimationHistory& h, std::size_t f, std::uint32_t v) {
  const AnimationFrame& fr = h.frames[f];
  while (v >= fr.vertex_count && h.vertex_parent[v] != v) v = h.vertex_parent[v];
  return {fr.positions[3 * v], fr.positions[3 * v + 1], fr.positions[3 * v + 2]};
}

Eigen::Vector4d rotation_quaternion(const Mat3& rotation) {
  Eigen::Quaterniond q(rotation);
  q.normalize();
  Eigen::Vector4d out(q.x(), q.y(), q.z(), q.w());
  if (out[3] < 0) out = -out;
  return out;
}

std::vector<std::array<std::array<double, 2>, 3>> crack_face_uvs(const SurfaceMesh& s) {
  std::vector<std::array<std::array<double, 2>, 3>> uv(s.triangles.size());
  if (s.reference.empty()) return uv;
  Vec3 lo = Vec3::Constant(kInfinity), hi = -lo;
  for (const Vec3& r : s.reference) lo = lo.cwiseMin(r), hi = hi.cwiseMax(r);
  const double side = std::max((hi - lo).maxCoeff(), 1e-30);
  for (std::size_t f = 0; f < s.triangles.size(); ++f) {
    if (!s.crack[f]) continue;
    const auto& t = s.triangles[f];
    const Vec3 a = s.reference[t[0]], b = s.reference[t[1]], c = s.reference[t[2]];
    const Vec3 normal = (b - a).cross(c - a);
    int axis = 0;
    normal.cwiseAbs().maxCoeff(&axis);
    const int u = (axis + 1) % 3, w = (axis + 2) % 3;
    for (int k = 0; k < 3; ++k) {
      const Vec3 p = s.reference[t[k]] - lo;
      uv[f][k] = {p[u] / side, p[w] / side};
    }
  }
  return uv;
}

AnimationCache build_animation_cache(const AnimationHistory& h, const SurfaceMesh& in) {
  AnimationCache cache;
  std::vector<std::size_t> order(in.triangles.size());
  for (std::size_t f = 0; f < order.size(); ++f) order[f] = f;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return in.fragment[a] != in.fragment[b] ? in.fragment[a] < in.fragment[b] : in.crack[a] < in.crack[b];
  });
  std::vector<std::uint32_t> renumber(in.vertices.size(), kNoPiece);
  std::vector<std::uint32_t> used;  // old index per new index
  SurfaceMesh& s = cache.surface;
  for (std::size_t f : order) {
    std::array<std::uint32_t, 3> tri{};
    for (int k = 0; k < 3; ++k) {
      std::uint32_t& r = renumber[in.triangles[f][k]];
      if (r == kNoPiece) r = static_cast<std::uint32_t>(used.size()), used.push_back(in.triangles[f][k]);
      tri[k] = r;
    }
    s.triangles.push_back(tri);
    s.crack.push_back(in.crack[f]);
    s.fragment.push_back(in.fragment[f]);
    s.tet.push_back(in.tet.empty() ? 0 : in.tet[f]);
  }
  for (std::uint32_t old : used) {
    s.vertices.push_back(in.vertices[old]);
    if (!in.velocity.empty()) s.velocity.push_back(in.velocity[old]);
    if (!in.reference.empty()) s.reference.push_back(in.reference[old]);
    if (!in.source.empty()) s.source.push_back(in.source[old]);
  }
  if (h.record_vertices && !s.source.empty()) {
    for (std::size_t f = 0; f < h.frames.size(); ++f) {
      std::vector<float> pos(3 * used.size());
      for (std::size_t k = 0; k < used.size(); ++k) {
        const Vec3 p = vertex_position(h, f, s.source[k]);
        for (int d = 0; d < 3; ++d) pos[3 * k + d] = static_cast<float>(p[d]);
      }
      cache.frames.push_back(std::move(pos));
      cache.times.push_back(h.frames[f].time);
    }
  }
  cache.crack_uv = crack_face_uvs(s);
  return cache;
}

}  // namespace perifx
