// What a run remembers frame by frame for the exports made at its end (issue 13): per-piece rigid
// motion (pieces.csv, the glTF keyframes) and every embedded-mesh vertex's position (the fixed-
// topology point cache animation.obj + animation.pc2).
//
// AnimationHistory is plain data; record_animation_frame appends one frame, computed from the world
// alone and serially in particle / vertex order, so it is the same for any thread count. The runner
// saves it beside each checkpoint (io/animation_history.*) and, on resume, trims it back to the
// checkpoint's frame (trim_animation_history).
#pragma once
#include <cstdint>
#include <array>
#include <map>
#include <vector>

#include "perifx/math.hpp"
#include "perifx/mesh.hpp"
#include "perifx/world.hpp"

namespace perifx {

inline constexpr std::uint32_t kNoPiece = 0xFFFFFFFFu;

// One piece (a connected component of alive bonds, stable `fragment_id`) at one frame. The best-fit
// rigid motion maps the piece's particles from their reference positions X to their positions y:
// y ≈ rotation·X + translation, minimising Σ m |rotation·X + translation − y|² over proper rotations
// (Kabsch, mass-weighted).
struct PieceSample {
  std::uint32_t id = 0;
  std::uint32_t particles = 0;
  double mass = 0.0;                       // kg
  Vec3 center = Vec3::Zero();              // centre of mass, m
  Mat3 rotation = Mat3::Identity();
  Vec3 translation = Vec3::Zero();         // m
  Vec3 velocity = Vec3::Zero();            // of the centre of mass, m/s
  Vec3 angular_velocity = Vec3::Zero();    // rad/s, I⁻¹ L about the centre of mass (0 when I is singular)
};

struct PieceOrigin {
  std::uint64_t birth_frame = 0;           // first frame the id appears (0 for pieces of the first frame)
  std::uint32_t parent = kNoPiece;         // the piece its particles belonged to the frame before
};

struct AnimationFrame {
  std::uint64_t frame = 0;
  double time = 0.0;                       // s
  std::vector<PieceSample> pieces;         // pieces of at least min_piece_tets particles, by id
  std::uint32_t vertex_count = 0;          // embedded-mesh vertices that exist at this frame
  std::vector<float> positions;            // 3 per vertex (empty unless vertices are recorded)
};

struct AnimationHistory {
  bool record_vertices = false;
  std::uint32_t min_piece_tets = 0;
  std::vector<AnimationFrame> frames;      // increasing frame numbers
  std::map<std::uint32_t, PieceOrigin> origins;  // every id seen (also below min_piece_tets)
  // Per embedded-mesh vertex: the vertex it was split from (itself for vertices of the first
  // frame) and the first frame it existed at.
  std::vector<std::uint32_t> vertex_parent;
  std::vector<std::uint64_t> vertex_birth;
  // The previous recorded frame's tets and fragment ids (to find parents); not saved, rebuilt from
  // the world on resume.
  std::vector<std::array<std::uint32_t, 4>> previous_tets;
  std::vector<std::uint32_t> previous_fragment;
};

// Appends `frame` (frames must increase). Needs a world with an embedded mesh whose vertices the
// caller has just made current, once (World::surface() or tet_mesh()): the vertex positions are read
// as they are, because each evaluation relaxes the held rotation of particles with few bonds a little
// further, so a second one would record positions the frame's surface files do not have.
void record_animation_frame(AnimationHistory& history, const World& world, std::uint64_t frame);

// After a resume from the checkpoint of `frame`: drops later frames, vertices and pieces and takes
// the previous-frame bookkeeping from `world`. Throws std::runtime_error when the history does not
// reach `frame` or disagrees with the world's vertex count.
void trim_animation_history(AnimationHistory& history, const World& world, std::uint64_t frame);

// The sample of piece `id` at frame index `f` of the history, or of its nearest ancestor that has one
// (pieces that do not exist yet move with the piece they will split from); null when none does.
const PieceSample* piece_pose(const AnimationHistory& history, std::size_t f, std::uint32_t id);

// Position of embedded vertex `v` at frame index `f`: its own, or that of the vertex it was split
// from when it did not exist yet (a copy sits on its original until it separates).
Vec3 vertex_position(const AnimationHistory& history, std::size_t f, std::uint32_t v);

// The fixed-topology cache of the final surface: its triangles with vertices in first-use order
// (outside then crack faces per piece, pieces by id: the order write_obj_cache writes them), each
// vertex's position per recorded frame, crack-face UVs from a planar projection of the reference
// positions.
struct AnimationCache {
  SurfaceMesh surface;                     // triangles sorted by (piece, crack), stable; vertices
                                           // renumbered in first-use order; positions = last frame
  std::vector<std::vector<float>> frames;  // per recorded frame, 3 per vertex
  std::vector<double> times;               // s
  std::vector<std::array<std::array<double, 2>, 3>> crack_uv;  // per triangle (zero on outside faces)
};

AnimationCache build_animation_cache(const AnimationHistory& history, const SurfaceMesh& final_surface);

// A rotation matrix as a unit quaternion (x, y, z, w) with w ≥ 0.
Eigen::Vector4d rotation_quaternion(const Mat3& rotation);

// Crack-face UVs: each triangle is projected along the reference axis its normal is closest to, the
// other two reference coordinates, less the bounding-box minimum, divided by the box's largest side.
std::vector<std::array<std::array<double, 2>, 3>> crack_face_uvs(const SurfaceMesh& surface);

}  // namespace perifx
