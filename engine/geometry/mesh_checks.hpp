// Internal to engine/geometry: the checks every tet mesh read from a file gets (orientation,
// unused vertices, one connected piece). The file formats themselves are read in engine/io.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "geometry/geometry.hpp"

namespace perifx::geometry::detail {

// Signed volume of the tet (a, b, c, d), > 0 when positively oriented.
double signed_volume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);
// Orients a tet read from a file: flips negative ones, and returns false for a degenerate one (volume
// ≤ 1e-12 of its mean edge cubed); `volume` and `mean_edge` are set for the caller's message.
bool orient_tet(const std::vector<Vec3>& vertices, std::array<std::uint32_t, 4>& tet, double& volume,
                double& mean_edge);
// Drops vertices no tet uses (keeping the order of the rest) and renumbers the tets.
void compact_vertices(TetMesh& mesh);
// Throws "<source>: mesh has K disconnected pieces ..." when the tets form more than one group
// linked by shared vertices (also rejects non-manifold faces, via face_neighbors).
void require_one_piece(const TetMesh& mesh, const std::string& source);

}  // namespace perifx::geometry::detail
