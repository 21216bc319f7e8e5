// Jittered structured meshes: a Freudenthal grid has every tet face on one of a few planes, so a crack
// that follows broken face-adjacent bonds runs along the grid's axis and diagonal planes, walls break
// into blocks and a symmetric load can crack asymmetrically. Moving every vertex by a seeded random
// offset (a fraction of its shortest edge) removes the preferred directions while keeping the mesh
// conforming. Boundary vertices move only within their flat face (or along their straight edge), so
// a box keeps its exact shape; corners and vertices of curved boundaries stay put.
#include <cmath>
#include <map>

#include "geometry/geometry.hpp"

namespace perifx::geometry {
namespace {

// splitmix64: a well-mixed 64-bit hash, so each vertex's offset depends only on (seed, vertex).
std::uint64_t mix(std::uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}
double unit(std::uint64_t bits) { return static_cast<double>(bits >> 11) * 0x1.0p-53 * 2.0 - 1.0; }  // [-1, 1)

double signed_volume(const TetMesh& m, const std::array<std::uint32_t, 4>& t) {
  const Vec3 a = m.vertices[t[1]] - m.vertices[t[0]], b = m.vertices[t[2]] - m.vertices[t[0]],
             c = m.vertices[t[3]] - m.vertices[t[0]];
  return a.dot(b.cross(c)) / 6.0;
}

}  // namespace

std::size_t jitter_vertices(TetMesh& mesh, double amplitude, std::uint64_t seed, const std::array<bool, 3>& mirror) {
  const std::size_t nv = mesh.vertices.size();
  if (!(amplitude > 0.0) || nv == 0) return 0;
  // Shortest incident edge per vertex: the local scale of the offset.
  std::vector<double> scale(nv, kInfinity);
  for (const auto& t : mesh.tets)
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) {
        const double len = (mesh.vertices[t[a]] - mesh.vertices[t[b]]).norm();
        scale[t[a]] = std::min(scale[t[a]], len);
        scale[t[b]] = std::min(scale[t[b]], len);
      }
  // Boundary faces (faces without a neighbour) and the distinct normals at each boundary vertex.
  const auto neighbors = face_neighbors(mesh);
  static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  std::vector<std::vector<Vec3>> normals(nv);
  for (std::size_t t = 0; t < mesh.tets.size(); ++t)
    for (int k = 0; k < 4; ++k) {
      if (neighbors[t][k] >= 0) continue;
      const auto& tet = mesh.tets[t];
      const Vec3 &p = mesh.vertices[tet[kFace[k][0]]], &q = mesh.vertices[tet[kFace[k][1]]],
                 &r = mesh.vertices[tet[kFace[k][2]]];
      const Vec3 n = (q - p).cross(r - p).normalized();
      for (int c = 0; c < 3; ++c) {
        auto& list = normals[tet[kFace[k][c]]];
        bool known = false;
        for (const Vec3& m : list) known = known || std::abs(m.dot(n)) > 1.0 - 1e-9;
        if (!known) list.push_back(n);
      }
    }
  // Mobility: interior free; one face plane: tangential; two planes at ≥ 30°: along their edge.
  std::vector<Mat3> mobility(nv, Mat3::Identity());
  for (std::size_t v = 0; v < nv; ++v) {
    const auto& n = normals[v];
    if (n.size() == 1) {
      mobility[v] = Mat3::Identity() - n[0] * n[0].transpose();
    } else if (n.size() == 2 && std::abs(n[0].dot(n[1])) < std::cos(kPi / 6.0)) {
      const Vec3 e = n[0].cross(n[1]).normalized();
      mobility[v] = e * e.transpose();
    } else if (n.size() >= 2) {
      mobility[v].setZero();
    }
  }
  // Mirrored: the key is the position (mirrored coordinates taken absolute) on a 1e-9 lattice of the body's size
  // (mirror images agree to round-off), the offset takes the position's signs, and a coordinate that
  // is 0 (a vertex on a centre plane) gets no offset across that plane.
  double extent = 0.0;
  for (const Vec3& p : mesh.vertices) extent = std::max(extent, p.cwiseAbs().maxCoeff());
  const double quantum = 1e-9 * (extent > 0.0 ? extent : 1.0);
  std::vector<Vec3> offset(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    std::uint64_t key = static_cast<std::uint64_t>(v);
    Vec3 sign = Vec3::Ones();
    if (mirror[0] || mirror[1] || mirror[2]) {
      key = 0x2545F4914F6CDD1Dull;
      for (int a = 0; a < 3; ++a) {
        const double x = mesh.vertices[v][a];
        const bool m = mirror[static_cast<std::size_t>(a)];
        const auto q = static_cast<std::int64_t>(std::llround((m ? std::abs(x) : x) / quantum));
        key = mix(key ^ static_cast<std::uint64_t>(q));
        if (m) sign[a] = q == 0 ? 0.0 : (x < 0.0 ? -1.0 : 1.0);
      }
    }
    const std::uint64_t h = mix(seed ^ mix(key));
    const Vec3 u(unit(mix(h)), unit(mix(h + 1)), unit(mix(h + 2)));
    offset[v] = amplitude * scale[v] * (mobility[v] * Vec3(u.cwiseProduct(sign)));
  }
  // Keep every tet well shaped: a tet that would fall below a quarter of its volume halves the
  // offsets of its vertices, a few times, then they stay where the grid put them.
  std::vector<double> volume0(mesh.tets.size());
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) volume0[t] = signed_volume(mesh, mesh.tets[t]);
  const std::vector<Vec3> original = mesh.vertices;
  std::size_t moved = 0;
  for (int round = 0; round <= 8; ++round) {
    for (std::size_t v = 0; v < nv; ++v) mesh.vertices[v] = original[v] + offset[v];
    std::vector<std::uint8_t> shrink(nv, 0);
    bool bad = false;
    for (std::size_t t = 0; t < mesh.tets.size(); ++t)
      if (signed_volume(mesh, mesh.tets[t]) < 0.25 * volume0[t]) {
        bad = true;
        for (auto v : mesh.tets[t]) shrink[v] = 1;
      }
    if (!bad) break;
    for (std::size_t v = 0; v < nv; ++v)
      if (shrink[v]) offset[v] = round < 7 ? Vec3(0.5 * offset[v]) : Vec3(Vec3::Zero());
  }
  for (std::size_t v = 0; v < nv; ++v) moved += offset[v] != Vec3::Zero();
  return moved;
}

}  // namespace perifx::geometry
