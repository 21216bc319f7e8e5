// The embedded tetrahedral mesh as it cracks (paper §5.2, systems/README.md §6.4):
// plain data, set up at world construction (systems::setup_embedded_mesh) from WorldState::mesh,
// then changed only by the crack_faces, mesh_split and mesh_vertices systems.
//
// Tet t carries particle t. Faces are identified by (tet, local k): the face opposite local vertex k.
// Every pair of tets that were face-adjacent in the original mesh is a FacePair; a pair is
//   intact    — the tets share the face and its bond is alive (or there never was a bond ... see
//               setup: a face-adjacent pair without a bond is an initial crack and starts cracked),
//   cracked   — the bond broke but the tets still share all three vertices (a pending crack face),
//   separated — vertex splitting gave the two tets different vertices: two boundary triangles.
// Vertex copies made by splitting keep their original vertex in `origin`, so the tets incident to a
// vertex v are found among the tets incident to origin[v] in the original mesh (incidence CSR).
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "components/math.hpp"
#include "perifx/mesh.hpp"  // SurfaceMesh

namespace perifx {

enum class FaceState : std::uint8_t { intact = 0, cracked = 1, separated = 2 };

// How vertices follow the particles.
enum class VertexMotion : std::uint8_t {
  // Default. Each particle p carries a local deformation gradient F_p from its alive bonds (the
  // peridynamic shape tensor, systems/README.md §6.5), replaced by the rotation it last had when its
  // family is too small, K is ill-conditioned or F is badly stretched or inverted; a vertex is the
  // mass-weighted mean of its tet group's predictions y_p + F_p (X_v − x_p). Rigid and affine motion
  // are exact, and a vertex stays within a few tet sizes of its own group's particles.
  deformation = 2,
  // The former default: each vertex is embedded in the particles of its tet group: x_v = X_v + Σ w_p (y_p − x_p)
  // with weights fixed at setup / at the split that made the group, w = the mass-weighted least-
  // squares affine fit evaluated at X_v. Reproduces any affine (so any rigid) motion to round-off;
  // velocity v_v = Σ w_p v_p is Eq 20–21 with fit weights instead of m_p/4.
  embedded = 0,
  // The paper's Eq 20–22 as written: v_v = Σ (m_p/4) v_p / Σ (m_p/4) over incident tets, x_v += dt v_v.
  // Translation is exact; rotation drifts (measured in tests/systems/test_embedded_mesh.cpp).
  paper = 1,
};

struct EmbeddedMesh {
  VertexMotion motion = VertexMotion::deformation;

  // ---- per vertex (grows when vertices split) ----
  std::vector<Vec3> reference_vertices;   // X_v, m (a copy gets its original's)
  std::vector<Vec3> vertices;             // x_v, current, m
  std::vector<Vec3> vertex_velocity;      // m/s
  std::vector<std::uint32_t> origin;      // original vertex index (itself for original vertices)
  std::vector<std::uint8_t> split_copy;   // 1 for a copy made by splitting
  // Embedding weights (VertexMotion::embedded): CSR per vertex, built on that motion's first update
  // (empty until then). Rebuilt for a vertex when its tet group changes; rows of copies are appended
  // (weight_rows[v] = {begin, end} into weight_*).
  std::vector<std::array<std::uint32_t, 2>> weight_rows;
  std::vector<std::uint32_t> weight_particle;
  std::vector<double> weight_value;

  // ---- per particle = per tet (VertexMotion::deformation) ----
  // Derived, evaluated when the mesh is read (systems/mesh_vertices.cpp); empty until the first read:
  std::vector<Mat3> deformation;       // F_p, the particle's local deformation gradient (or its held rotation)
  std::vector<Mat3> deformation_rate;  // Ḟ_p, 1/s (zero where F_p is a held rotation)
  std::vector<std::uint8_t> deformation_fitted;  // 1 where F_p is p's own fitted gradient, 0 where it
                                                 // is a fallback rotation (weighs 1e-3 at shared vertices)
  std::vector<Vec3> deformation_origin;  // o_p, m: where p's vertices are placed from: the value at p of
                                         // the affine fit that gave F_p (family or mesh ring), or y_p
                                         // for a fallback rotation (systems/mesh_vertices.cpp)
  std::vector<Vec3> deformation_origin_velocity;  // ȯ_p, m/s: that fit's velocity at p (or v_p)
  std::vector<std::uint8_t> vertex_anchored;     // per vertex: 1 when a tet with a fitted F holds it
  // Step state, kept by the mesh_rotations system (systems/mesh_rotations.cpp) for tracked particles
  // (family does not fit, or a bond broke): S_p = F_p of the last evaluation (every step for a poor
  // family with alive bonds, at most kRefreshSteps = 8 steps old for a fitting one), a rotation (the
  // held rotation) where the family does not fit. Untouched (identity) for particles never tracked.
  std::vector<Mat3> held_deformation;
  std::vector<std::uint8_t> held_tracked;  // 1 once p is tracked (never goes back to 0)
  std::vector<std::uint8_t> held_fits;     // 1 when p's alive family fitted at its last evaluation
  std::vector<std::uint32_t> held_broken_seen;  // p's broken-bond count at its last evaluation

  // ---- per tet ----
  std::vector<std::array<std::uint32_t, 4>> tets;        // current vertex indices (splitting rewrites)
  std::vector<std::array<std::int32_t, 4>> neighbors;    // original face adjacency, −1 original boundary
  std::vector<std::array<std::int32_t, 4>> face_pair;    // FacePair index of each face, −1 boundary

  // ---- per original face-adjacent tet pair ----
  std::vector<std::array<std::uint32_t, 2>> pair_tets;   // (t, u), t < u
  std::vector<std::array<std::uint8_t, 2>> pair_local;   // local face index in t and in u
  std::vector<std::uint32_t> pair_bond;                  // bond t→u, or kNoBond
  std::vector<FaceState> pair_state;
  static constexpr std::uint32_t kNoBond = 0xFFFFFFFFu;

  // Pairs still intact that have a bond: the crack_faces system scans only these (≈2 per tet).
  std::vector<std::uint32_t> watched_pairs;
  // Pending crack faces: cracked pairs whose tets still share the face, sorted by pair index.
  std::vector<std::uint32_t> pending;
  // Pairs that became cracked this step (input of mesh_split; cleared by it).
  std::vector<std::uint32_t> fresh;

  // ---- original incidence (setup only; never changes) ----
  std::vector<std::uint32_t> incidence_offsets;  // per original vertex + 1
  std::vector<std::uint32_t> incidence;          // tet·4 + local slot

  // ---- counters ----
  std::uint64_t crack_faces_total = 0;   // pairs that ever became cracked (initial cracks included)
  std::uint64_t vertex_copies_total = 0;
  std::uint64_t torn_faces_total = 0;    // intact faces opened to repair pinched (non-manifold) edges (mesh_split.cpp)
  std::uint32_t original_vertex_count = 0;

  std::size_t vertex_count() const { return vertices.size(); }
};

}  // namespace perifx

namespace perifx {

}  // namespace perifx
