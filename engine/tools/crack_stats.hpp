// Crack geometry statistics (`perifx crack-stats RUN_DIR`, issue 11 items 3 and 4): how the crack
// faces of a run lie, measured in the reference configuration (the surface PLY's rx ry rz), on one
// frame's surface file (default: the last one).
//
// The crack surface is the set of surface triangles flagged `crack`. Both sides of a separated crack
// face are written (one triangle per tet, same reference positions, opposite winding): triangles are
// welded by their exact reference coordinates and each geometric face is counted once. With
// `exclude_initial` (default) the faces already present on frame 0 (initial cracks, notches) are left
// out, identified by the pair of tets they separate.
//
//   axis-aligned fraction  area of the faces whose unit normal lies within `axis_tolerance_deg` of a
//                          coordinate axis (the structured mesher's grid axes), over the crack area;
//   mirror fit             for a scene mirror-symmetric about the plane {x_m = at} (m = mirror axis),
//                          the faces on each side (by centroid) are fitted with a plane (area-weighted
//                          principal axes of the triangles); per side: the angle between that plane and
//                          the load axis (90° = a crack square to the load), and the tilt: the signed
//                          angle of the crack's direction in the (mirror axis, load axis) plane, positive
//                          when the crack rises toward +load as it runs away from the mirror plane, so a
//                          mirror-symmetric pair has equal tilts; `asymmetry` = |tilt_right − tilt_left|;
//   area ratio             roughness: for each face, the faces whose centroids lie within `radius` of
//                          its centroid are fitted with a plane; ratio = their area / their area
//                          projected on that plane (1 for a flat crack, √2 for a 45° stair-step),
//                          area-weighted mean over the faces;
//   mean dihedral          mean over the edges shared by exactly two crack faces of the angle between
//                          their planes (0..90°, unoriented), degrees.
#pragma once
#include <array>
#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <optional>
#include <stdexcept>
#include <vector>

#include "perifx/math.hpp"

namespace perifx {

class CrackStatsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct CrackStatsOptions {
  std::optional<std::uint64_t> frame;  // default: the last frame with a surface file
  double axis_tolerance_deg = 10.0;
  bool exclude_initial = true;         // leave out the crack faces of frame 0
  int mirror_axis = -1;                // 0, 1, 2 = x, y, z; −1: no mirror fit
  double mirror_at = 0.0;              // the mirror plane's coordinate, m
  int load_axis = 1;                   // 0, 1, 2
  double radius = 0.0;                 // roughness neighbourhood, m; 0 = 3 × mean crack edge length
};

struct CrackSideFit {
  std::size_t faces = 0;
  double area = 0.0;           // m²
  Vec3 normal = Vec3::Zero();  // fitted plane's unit normal
  double angle_to_load = 0.0;  // degrees, 0..90
  double tilt = 0.0;           // degrees, −90..90 (see above)
};

struct CrackStats {
  std::uint64_t frame = 0;
  std::size_t faces = 0;        // geometric crack faces (each once)
  double area = 0.0;            // m²
  double axis_aligned_fraction = 0.0;
  double radius = 0.0;          // the roughness neighbourhood used, m
  double area_ratio = 1.0;
  double mean_dihedral = 0.0;   // degrees
  std::size_t dihedral_edges = 0;
  bool mirror = false;
  CrackSideFit left, right;     // below / above mirror_at along the mirror axis
  double asymmetry = 0.0;       // |right.tilt − left.tilt|, degrees
};

// A crack surface in the reference configuration: triangles over shared vertices (both sides of a
// face may be present; they are merged by their vertices' coordinates).
struct CrackSurface {
  std::vector<Vec3> vertex;
  std::vector<std::array<std::uint32_t, 3>> triangle;
};

// The statistics of one crack surface (options.frame / exclude_initial unused).
CrackStats crack_statistics(const CrackSurface& surface, const CrackStatsOptions& options);
// The statistics of a run directory's frame. Throws CrackStatsError when the directory has no surface
// files, the file carries no crack flags or reference positions, or the frame is missing.
CrackStats crack_statistics(const std::filesystem::path& run_dir, const CrackStatsOptions& options);
void print_crack_stats(std::ostream& out, const CrackStats& stats, const CrackStatsOptions& options);

}  // namespace perifx
