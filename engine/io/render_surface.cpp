// Render surface: vertex copies per (vertex, crack flag) and their normals (see render_surface.hpp).
#include "io/render_surface.hpp"

namespace perifx::io {

RenderSurface render_surface(const SurfaceMesh& s) {
  const std::size_t nv = s.vertices.size();
  constexpr std::uint32_t kNone = 0xFFFFFFFFu;
  // Slot 2v + c: vertex v as used by triangles with crack flag c.
  std::vector<std::uint32_t> slot(2 * nv, kNone);
  for (std::size_t f = 0; f < s.triangles.size(); ++f) {
    const std::uint32_t c = f < s.crack.size() && s.crack[f] ? 1 : 0;
    for (auto v : s.triangles[f]) slot[2 * std::size_t{v} + c] = 0;
  }
  RenderSurface r;
  for (std::size_t k = 0; k < slot.size(); ++k) {
    if (slot[k] == kNone) continue;
    const std::size_t v = k / 2;
    slot[k] = static_cast<std::uint32_t>(r.position.size());
    r.position.push_back(s.vertices[v]);
    r.normal.push_back(Vec3::Zero());
    r.velocity.push_back(v < s.velocity.size() ? s.velocity[v] : Vec3::Zero());
    r.reference.push_back(v < s.reference.size() ? s.reference[v] : s.vertices[v]);
    r.source.push_back(v < s.source.size() ? s.source[v] : static_cast<std::uint32_t>(v));
  }
  r.triangles.resize(s.triangles.size());
  for (std::size_t f = 0; f < s.triangles.size(); ++f) {
    const std::uint32_t c = f < s.crack.size() && s.crack[f] ? 1 : 0;
    const auto& t = s.triangles[f];
    const Vec3 n = (s.vertices[t[1]] - s.vertices[t[0]]).cross(s.vertices[t[2]] - s.vertices[t[0]]);  // 2·area·normal
    for (std::size_t i = 0; i < 3; ++i) {
      r.triangles[f][i] = slot[2 * std::size_t{t[i]} + c];
      r.normal[r.triangles[f][i]] += n;
    }
  }
  for (Vec3& n : r.normal) {
    const double len = n.norm();
    n = len > 0.0 ? Vec3(n / len) : Vec3::Zero();
  }
  return r;
}

std::vector<std::uint32_t> vertex_pieces(const RenderSurface& r, const SurfaceMesh& surface) {
  std::vector<std::uint32_t> piece(r.position.size(), 0u);
  for (std::size_t f = 0; f < r.triangles.size() && f < surface.fragment.size(); ++f)
    for (auto v : r.triangles[f]) piece[v] = surface.fragment[f];
  return piece;
}

}  // namespace perifx::io
