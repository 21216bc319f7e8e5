// Surface checker (`perifx check-surface RUN_DIR`): whether a run's surface files can be rendered as
// a fractured solid. Per frame, on the surface (surface.NNNN.ply, else .obj) and particle
// (particles.NNNN.vtu/.ply) files of a run directory, read through io/run_dir.hpp:
//   far        surface vertices farther than one horizon δ from every particle of their own piece
//              (piece: the `fragment` of the vertex's triangles and the particles' `fragment_id`)
//              and, where the file has reference positions, farther from them than at rest (the
//              vertex's reference position against the piece's particles at frame 0) by over 0.1 δ:
//              a mesher's elongated tet can put a vertex beyond δ at rest;
//   inverted   closed shells (edge-connected triangle sets, every edge used twice) whose signed
//              volume is negative, unless a positive closed shell of the same piece encloses them
//              (bounding boxes): those bound a cavity or a closed internal crack and are counted
//              apart, as `cavities` (not a problem);
//   open       edges used by one triangle only;
//   non-manifold  edges used by more than two triangles (two groups of tets that meet along an edge
//              whose end vertices were not split apart);
//   stretched  triangles with an edge longer than 3× its reference length while the particles of
//              their tet's neighbourhood (same piece, within δ at frame 0) did not stretch 3×;
//   longest    the longest surface edge, m.
// Vertices that a surface file writes more than once (PLY rim copies with split normals) are welded
// by their `source` index. δ comes from mesh.json (`horizon`, written by runs with surface output) or
// the caller. The stretch test needs the reference positions and tets of perifx's surface PLY; for
// files without them it is reported as not available (-1).
#pragma once
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace perifx {

class SurfaceCheckError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct SurfaceCheckOptions {
  std::optional<std::uint64_t> frames;  // check frames 0..N−1 only
  double horizon = 0.0;                 // δ, m; 0 = from mesh.json
  double stretch_ratio = 3.0;
  bool details = false;                 // list every counted element (SurfaceFrameCheck::details)
};

struct SurfaceFrameCheck {
  std::uint64_t frame = 0;
  double time = 0.0;
  std::size_t vertices = 0, triangles = 0, pieces = 0;
  std::size_t far_vertices = 0, inverted_shells = 0, open_edges = 0, nonmanifold_edges = 0;
  std::size_t cavities = 0;            // negative closed shells inside a positive one (not counted in issues)
  long long stretched_triangles = -1;  // -1: the file has no reference positions / tets
  double longest_edge = 0.0;           // m
  // With SurfaceCheckOptions::details: one line per far vertex, inverted shell, non-manifold edge and
  // stretched triangle (embedded-mesh vertex = `source`, tets = particles, piece), for diagnosis.
  std::vector<std::string> details;
  std::size_t issues() const {
    return far_vertices + inverted_shells + open_edges + nonmanifold_edges + static_cast<std::size_t>(std::max(0LL, stretched_triangles));
  }
};

struct SurfaceCheckReport {
  double horizon = 0.0;
  std::vector<SurfaceFrameCheck> frames;
  std::size_t issues() const {
    std::size_t n = 0;
    for (const auto& f : frames) n += f.issues();
    return n;
  }
};

// Throws SurfaceCheckError when the directory cannot be read, has no surface files or no horizon.
SurfaceCheckReport check_run_surfaces(const std::filesystem::path& run_dir, const SurfaceCheckOptions& options = {});
// The report as a plain-text table (one line per frame, then the totals).
void print_surface_check(std::ostream& out, const SurfaceCheckReport& report);

}  // namespace perifx
