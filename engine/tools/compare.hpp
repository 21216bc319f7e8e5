// Run comparison (paper §6): position deviation between two runs' frame series, over the diagonal of
// the reference run's bounding box at frame 0:  Error = |x_p − x_p^ref| / d.
//   PD ↔ PD, FEM ↔ FEM: particle by particle (same scene ⇒ same particles and order).
//   PD ↔ FEM: a PD particle sits at its tet's barycenter, so the FEM run is evaluated there as the
//   mean of the tet's 4 vertex positions (the FEM run's mesh.json gives the tets). Same mesh: tet
//   hashes agree and the FEM barycenters at frame 0 equal the PD particles.
//   Different meshes of one body (e.g. a finer FEM reference): the FEM run's field, linear in each
//   of its tets, is interpolated at the other run's frame-0 points (barycentric weights found once,
//   at frame 0; points outside the mesh, on curved boundaries, take the nearest tet's clamped
//   weights and are compared by motion: their frame-0 offset is subtracted).
//   Two PD runs of different meshes (a preview against its final): the finer run's particle motion
//   is fitted locally (weighted least-squares affine over its particles of the same material near
//   each point, exact for any affine motion) at the coarser run's frame-0 particles. Across an open crack the fit mixes
//   both sides, so after fracture the figure also measures how far the crack patterns differ.
// Frames are paired by time, so runs of different frame rates or durations compare at the times
// they share (both must start at the same time).
// Each run directory has particles.pvd + particles.NNNN.vtu (runner) and mesh.json (written by
// io::write_run_mesh at the start of a run); both are read through io/run_dir.hpp.
#pragma once
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace perifx {

class CompareError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct CompareFrame {
  double time_a = 0.0, time_b = 0.0;
  double max_error = 0.0, mean_error = 0.0;  // over particles, divided by the diagonal
};

struct CompareResult {
  std::string solver_a, solver_b;
  std::string mapping;          // how the points were matched (direct, tet barycenters, interpolated)
  std::size_t points = 0;       // compared points per frame
  double diagonal = 0.0;        // d, m: bounding-box diagonal of run A at frame 0
  std::vector<CompareFrame> frames;
  double max_error = 0.0, mean_error = 0.0;  // over all frames and points
  std::size_t frames_a = 0, frames_b = 0;    // frames in each series (compared: those at common times)
};

// Compares run B against reference run A. Throws CompareError with a clear message when a run
// cannot be read or the runs do not describe the same mesh / frame times.
CompareResult compare_runs(const std::filesystem::path& run_a, const std::filesystem::path& run_b);

// compare.csv: frame,time,max_error,mean_error, then an "overall" row.
void write_compare_csv(const CompareResult& result, const std::filesystem::path& file);

}  // namespace perifx
