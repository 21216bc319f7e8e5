// Surface extraction (output only, not a step system): the boundary triangles of the current split
// embedded mesh. A tet face is on the boundary when it had no neighbour in the original mesh
// (original surface) or its face pair is separated (crack surface). Triangles are wound outward:
// tets are positively oriented, and the face opposite local vertex k is taken in the order below.
// Vertices no triangle uses are dropped; the rest keep their relative order, so the output is
// deterministic. Piece ids come from the caller (derived.fragment_id), per particle = tet; with
// min_piece_tets > 0 the triangles of pieces with fewer particles (= tets) are left out. Each vertex
// also carries its velocity, reference position and embedded-mesh index.
// Reads: mesh (embedded mesh).
#include "systems.hpp"

namespace perifx::systems {

std::vector<std::uint32_t> piece_tet_counts(const std::vector<std::uint32_t>& fragment_id) {
  std::vector<std::uint32_t> count;
  for (std::uint32_t id : fragment_id) {
    if (id >= count.size()) count.resize(std::size_t{id} + 1, 0);
    ++count[id];
  }
  return count;
}

std::vector<std::uint32_t> dust_particles(const std::vector<std::uint32_t>& fragment_id, std::uint32_t min_piece_tets) {
  std::vector<std::uint32_t> out;
  if (min_piece_tets == 0) return out;
  const auto count = piece_tet_counts(fragment_id);
  for (std::uint32_t p = 0; p < fragment_id.size(); ++p)
    if (count[fragment_id[p]] < min_piece_tets) out.push_back(p);
  return out;
}

void extract_surface(const WorldState& w, const std::vector<std::uint32_t>* fragment_id, SurfaceMesh& out,
                     std::uint32_t min_piece_tets) {
  static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  const EmbeddedMesh& e = w.embedded;
  out = SurfaceMesh{};
  std::vector<std::uint32_t> remap(e.vertices.size(), 0);
  // Tets per piece, when small pieces are dropped (ids are below 2·tets: see fragments.cpp).
  std::vector<std::uint32_t> piece_tets;
  const bool drop = min_piece_tets > 0 && fragment_id && fragment_id->size() == e.tets.size();
  if (drop) piece_tets = piece_tet_counts(*fragment_id);
  for (std::uint32_t t = 0; t < e.tets.size(); ++t)
    for (int k = 0; k < 4; ++k) {
      const std::int32_t pair = e.face_pair[t][static_cast<std::size_t>(k)];
      const bool crack = pair >= 0;
      if (crack && e.pair_state[static_cast<std::size_t>(pair)] != FaceState::separated) continue;
      if (drop && piece_tets[(*fragment_id)[t]] < min_piece_tets) continue;
      std::array<std::uint32_t, 3> tri{};
      for (int c = 0; c < 3; ++c) {
        tri[static_cast<std::size_t>(c)] = e.tets[t][static_cast<std::size_t>(kFace[k][c])];
        remap[tri[static_cast<std::size_t>(c)]] = 1;
      }
      out.triangles.push_back(tri);
      out.crack.push_back(crack ? 1 : 0);
      out.fragment.push_back(fragment_id && t < fragment_id->size() ? (*fragment_id)[t] : 0u);
      out.tet.push_back(t);
    }
  std::uint32_t next = 0;
  for (std::size_t v = 0; v < remap.size(); ++v) {
    if (!remap[v]) continue;
    remap[v] = next++;
    out.vertices.push_back(e.vertices[v]);
    out.velocity.push_back(e.vertex_velocity[v]);
    out.reference.push_back(e.reference_vertices[v]);
    out.source.push_back(static_cast<std::uint32_t>(v));
  }
  for (auto& tri : out.triangles)
    for (auto& v : tri) v = remap[v];
}

}  // namespace perifx::systems
