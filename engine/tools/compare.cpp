// `perifx compare` (see compare.hpp): reads both runs through io/run_dir and measures the deviation.
#include "tools/compare.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "components/math.hpp"
#include "io/atomic.hpp"
#include "io/run_dir.hpp"
#include "systems/spatial_grid.hpp"

namespace perifx {
namespace fs = std::filesystem;
namespace {

// Run-directory reads with compare's error type (the message names the file either way).
template <class Read>
auto reading(Read&& read) {
  return io::rethrow_as<io::RunDirError, CompareError>(std::forward<Read>(read));
}

using io::RunMesh;

struct Series {
  std::vector<double> times;
  std::vector<fs::path> files;
};

Series read_series(const fs::path& dir) {
  Series s;
  for (const auto& f : reading([&] { return io::particle_series(dir); })) {
    s.times.push_back(f.time);
    s.files.push_back(f.file);
  }
  return s;
}

std::vector<Vec3> read_vtu_points(const fs::path& file) {
  return reading([&] { return io::read_particle_frame(file); }).position;
}

// Axis-aligned bounding box of a point set.
struct Box {
  Vec3 lo = Vec3::Constant(kInfinity), hi = Vec3::Constant(-kInfinity);
};
Box bounds(const std::vector<Vec3>& pts) {
  Box b;
  for (const auto& p : pts) b.lo = b.lo.cwiseMin(p), b.hi = b.hi.cwiseMax(p);
  return b;
}

double diagonal_of(const std::vector<Vec3>& pts) {
  const Box b = bounds(pts);
  return (b.hi - b.lo).norm();
}

std::vector<Vec3> barycenters(const std::vector<Vec3>& vertices, const RunMesh& m, const fs::path& dir) {
  std::vector<Vec3> out(m.tets.size());
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    Vec3 c = Vec3::Zero();
    for (auto v : m.tets[t]) {
      if (v >= vertices.size()) throw CompareError(dir.string() + ": mesh.json tet " + std::to_string(t) + " names vertex " +
                                                   std::to_string(v) + " but the frames have " + std::to_string(vertices.size()) + " points");
      c += vertices[v];
    }
    out[t] = 0.25 * c;
  }
  return out;
}

// Barycentric coordinates of p in tet (a, b, c, d); false for a degenerate tet.
bool barycentric(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, std::array<double, 4>& w) {
  Mat3 m;
  m.col(0) = b - a;
  m.col(1) = c - a;
  m.col(2) = d - a;
  const double det = m.determinant();
  if (!(std::abs(det) > 1e-300)) return false;
  const Vec3 l = m.inverse() * (p - a);
  w = {1.0 - l.sum(), l[0], l[1], l[2]};
  return true;
}

// Where each point sits in a tet mesh: the 4 vertices of its tet and its barycentric weights.
// A point outside the mesh (a vertex of a curved boundary of another mesh) takes the tet whose
// clamped barycentric point is nearest, with those clamped weights; `outside` is that distance.
struct Embedding {
  std::vector<std::array<std::uint32_t, 4>> vertex;
  std::vector<std::array<double, 4>> weight;
  double outside = 0.0;  // largest distance of a point from the mesh, m
};

Embedding embed(const std::vector<Vec3>& points, const std::vector<Vec3>& vertices, const RunMesh& m, const fs::path& dir) {
  const std::size_t nt = m.tets.size();
  for (std::size_t t = 0; t < nt; ++t)
    for (auto v : m.tets[t])
      if (v >= vertices.size())
        throw CompareError(dir.string() + ": mesh.json tet " + std::to_string(t) + " names vertex " + std::to_string(v) +
                           " but the frames have " + std::to_string(vertices.size()) + " points");
  // Uniform grid over the mesh's bounding box, ~1 tet per cell; each tet listed in the cells its box overlaps.
  const auto [lo, hi] = bounds(vertices);
  const Vec3 ext = (hi - lo).cwiseMax(Vec3::Constant(1e-12 * (1.0 + (hi - lo).norm())));
  const double cell = std::cbrt(ext.prod() / double(std::max<std::size_t>(nt, 1)));
  std::array<long, 3> dim{};
  for (int k = 0; k < 3; ++k) dim[k] = std::clamp(long(std::ceil(ext[k] / cell)), 1L, 512L);
  auto index = [&](const Vec3& p, int k) { return std::clamp(long((p[k] - lo[k]) / ext[k] * double(dim[k])), 0L, dim[k] - 1); };
  std::vector<std::vector<std::uint32_t>> grid(std::size_t(dim[0] * dim[1] * dim[2]));
  auto at = [&](long i, long j, long k) -> std::vector<std::uint32_t>& { return grid[std::size_t((i * dim[1] + j) * dim[2] + k)]; };
  for (std::size_t t = 0; t < nt; ++t) {
    Vec3 tlo = Vec3::Constant(kInfinity), thi = -tlo;
    for (auto v : m.tets[t]) tlo = tlo.cwiseMin(vertices[v]), thi = thi.cwiseMax(vertices[v]);
    for (long i = index(tlo, 0); i <= index(thi, 0); ++i)
      for (long j = index(tlo, 1); j <= index(thi, 1); ++j)
        for (long k = index(tlo, 2); k <= index(thi, 2); ++k) at(i, j, k).push_back(std::uint32_t(t));
  }
  Embedding e;
  e.vertex.resize(points.size());
  e.weight.resize(points.size());
  const double inside_tolerance = 1e-9;
  for (std::size_t p = 0; p < points.size(); ++p) {
    const Vec3& x = points[p];
    double best = kInfinity;
    // Candidates: the point's own grid cell, then (only when it is in no tet there) every tet.
    for (int pass = 0; pass < 2 && best > 0.0; ++pass) {
      auto consider = [&](std::uint32_t t) {
        const auto& v = m.tets[t];
        std::array<double, 4> w;
        if (!barycentric(x, vertices[v[0]], vertices[v[1]], vertices[v[2]], vertices[v[3]], w)) return;
        double dist = 0.0;
        if (*std::min_element(w.begin(), w.end()) < -inside_tolerance) {
          double sum = 0.0;
          for (auto& c : w) sum += (c = std::max(c, 0.0));
          Vec3 q = Vec3::Zero();
          for (int c = 0; c < 4; ++c) q += (w[c] /= sum) * vertices[v[c]];
          dist = (q - x).norm();
        }
        if (dist < best) best = dist, e.vertex[p] = v, e.weight[p] = w;
      };
      if (pass == 0) {
        for (auto t : at(index(x, 0), index(x, 1), index(x, 2))) {
          consider(t);
          if (best == 0.0) break;
        }
      } else {
        for (std::size_t t = 0; t < nt; ++t) consider(std::uint32_t(t));
      }
    }
    if (!std::isfinite(best)) throw CompareError(dir.string() + ": mesh.json has no usable tets");
    e.outside = std::max(e.outside, best);
  }
  return e;
}

std::vector<Vec3> interpolate(const std::vector<Vec3>& vertices, const Embedding& e) {
  std::vector<Vec3> out(e.vertex.size());
  for (std::size_t p = 0; p < out.size(); ++p) {
    Vec3 x = Vec3::Zero();
    for (int c = 0; c < 4; ++c) x += e.weight[p][c] * vertices[e.vertex[p][c]];
    out[p] = x;
  }
  return out;
}

// Two particle runs of one body at different resolutions (a preview against its final): run F's
// (the finer) particle motion evaluated at run C's frame-0 points by a weighted least-squares affine
// fit over F's particles within `reach` of the point, weights (1 − r²/reach²)². The fit is linear in
// F's positions, so it is stored once as coefficients: point p = Σ_k coefficient[k] · F[index[k]],
// offsets[p] ≤ k < offsets[p+1]. Σ c = 1 and Σ c (x_k − p) = 0, so any affine motion of F (a rigid
// translation or rotation, a uniform strain) is reproduced exactly, and frame 0 gives p itself.
struct PointFit {
  std::vector<std::uint32_t> offsets{0}, index;
  std::vector<double> coefficient;
};

PointFit fit_points(const std::vector<Vec3>& points, const std::vector<std::uint32_t>& point_material,
                    const std::vector<Vec3>& source, const std::vector<std::uint32_t>& source_material,
                    const fs::path& dir) {
  // A point takes only particles of its own material (when both runs wrote it): a bullet's particle
  // must not be fitted from the jello around it.
  const bool by_material = point_material.size() == points.size() && source_material.size() == source.size();
  // Reach: 2.5 mean spacings of the source, from its bounding box (an over-estimate for a body that
  // fills its box poorly, which only widens the fit); doubled for a point with too few neighbours.
  const auto [lo, hi] = bounds(source);
  const Vec3 ext = (hi - lo).cwiseMax(Vec3::Constant(1e-9 * (1.0 + (hi - lo).norm())));
  const double spacing = std::cbrt(ext.prod() / double(std::max<std::size_t>(source.size(), 1)));
  PointFit fit;
  constexpr std::size_t kMinNeighbours = 12;
  for (double reach = 2.5 * spacing; fit.offsets.size() <= points.size(); reach *= 2.0) {
    if (reach > 64.0 * spacing + ext.norm())
      throw CompareError(dir.string() + ": too few particles (of the same material) near point " +
                         std::to_string(fit.offsets.size() - 1) + " of the other run to interpolate its motion");
    SpatialGrid grid;
    systems::allocate_grid(grid, source.size(), reach);
    systems::build_grid(grid, source);
    std::vector<std::uint32_t> near;
    std::vector<double> weight;
    std::vector<Eigen::Vector4d> rows;  // [1, (x_k − x)/reach] per neighbour
    while (fit.offsets.size() <= points.size()) {
      const Vec3& x = points[fit.offsets.size() - 1];
      near.clear();
      weight.clear();
      systems::for_each_near(grid, x, [&](std::uint32_t q) {
        const double r2 = (grid.sorted_position[q] - x).squaredNorm() / (reach * reach);
        if (r2 < 1.0 && (!by_material || source_material[grid.sorted[q]] == point_material[fit.offsets.size() - 1]))
          near.push_back(grid.sorted[q]), weight.push_back((1.0 - r2) * (1.0 - r2));
      });
      if (near.size() < kMinNeighbours) break;  // widen the reach for this point and the rest
      // Normal equations of the affine fit, coordinates relative to x and scaled by the reach.
      Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
      rows.clear();
      for (std::size_t k = 0; k < near.size(); ++k) {
        const Vec3 d = (source[near[k]] - x) / reach;
        rows.emplace_back(1.0, d.x(), d.y(), d.z());
        m += weight[k] * rows.back() * rows.back().transpose();
      }
      const Eigen::FullPivLU<Eigen::Matrix4d> lu(m);
      if (lu.rank() < 4) break;  // neighbours on a plane or a line: widen
      const Eigen::Vector4d first = lu.inverse().row(0).transpose();  // m is symmetric
      for (std::size_t k = 0; k < near.size(); ++k) {
        fit.index.push_back(near[k]);
        fit.coefficient.push_back(weight[k] * first.dot(rows[k]));
      }
      fit.offsets.push_back(std::uint32_t(fit.index.size()));
    }
  }
  return fit;
}

std::vector<Vec3> interpolate(const std::vector<Vec3>& source, const PointFit& fit) {
  std::vector<Vec3> out(fit.offsets.size() - 1);
  for (std::size_t p = 0; p < out.size(); ++p) {
    Vec3 x = Vec3::Zero();
    for (std::uint32_t k = fit.offsets[p]; k < fit.offsets[p + 1]; ++k) x += fit.coefficient[k] * source[fit.index[k]];
    out[p] = x;
  }
  return out;
}

}  // namespace

CompareResult compare_runs(const fs::path& dir_a, const fs::path& dir_b) {
  const Series sa = read_series(dir_a), sb = read_series(dir_b);
  const RunMesh ma = reading([&] { return io::read_run_mesh(dir_a); });
  const RunMesh mb = reading([&] { return io::read_run_mesh(dir_b); });
  CompareResult r;
  r.solver_a = ma.solver;
  r.solver_b = mb.solver;
  r.frames_a = sa.files.size();
  r.frames_b = sb.files.size();
  // Frame 0 of each run, read once: its points, and its materials for the resolution fit.
  const io::ParticleFrame fa0 = reading([&] { return io::read_particle_frame(sa.files[0]); });
  const io::ParticleFrame fb0 = reading([&] { return io::read_particle_frame(sb.files[0]); });
  const std::vector<Vec3>& a0 = fa0.position;
  const std::vector<Vec3>& b0 = fb0.position;
  r.diagonal = diagonal_of(a0);
  if (!(r.diagonal > 0.0)) throw CompareError(dir_a.string() + ": frame 0 has a zero bounding box");

  // How each run's frame points become the compared points.
  enum class Map { direct, barycenters, interpolated, fitted };
  Map map_a = Map::direct, map_b = Map::direct;
  Embedding embedding;  // for Map::interpolated
  PointFit point_fit;   // for Map::fitted
  double frame0_tolerance = 1e-9;
  if (ma.present && mb.present && ma.hash != mb.hash) {
    // Different meshes (e.g. a finer FEM reference): an FEM run's displacement field is linear in
    // each tet, so it can be evaluated anywhere in the body. Interpolate the FEM run (A when it is
    // one, else B) at the other run's frame-0 points.
    if (ma.tets.empty() && mb.tets.empty()) {
      // Two particle runs of different resolutions (a preview and its final): the finer run's
      // motion, fitted locally, at the coarser run's particles.
      const bool on_a = a0.size() >= b0.size();
      point_fit = on_a ? fit_points(b0, fb0.material, a0, fa0.material, dir_a)
                       : fit_points(a0, fa0.material, b0, fb0.material, dir_b);
      (on_a ? map_a : map_b) = Map::fitted;
      r.mapping = std::string("the runs differ in resolution: run ") + (on_a ? "A" : "B") + "'s particle motion (" +
                  std::to_string(on_a ? a0.size() : b0.size()) + " particles) fitted locally (weighted least-squares "
                  "affine, exact for any affine motion) at run " + (on_a ? "B" : "A") + "'s " +
                  std::to_string(on_a ? b0.size() : a0.size()) + " frame-0 points";
    } else {
      const bool on_a = !ma.tets.empty();
      embedding = on_a ? embed(b0, a0, ma, dir_a) : embed(a0, b0, mb, dir_b);
      (on_a ? map_a : map_b) = Map::interpolated;
      r.mapping = std::string("the meshes differ: run ") + (on_a ? "A" : "B") +
                  "'s FEM field interpolated (linear in each of its tets) at run " + (on_a ? "B" : "A") +
                  "'s frame-0 points; points outside that mesh (curved boundaries) take the nearest tet and are "
                  "compared by motion (their frame-0 offset subtracted)";
    }
    // Same body meshed twice: the points lie in the other mesh up to its curved-boundary facets.
    frame0_tolerance = 0.02;
  } else {
    const bool a_vertices = ma.vertices_are_particles, b_vertices = mb.vertices_are_particles;
    if (a_vertices && !b_vertices) map_a = Map::barycenters;
    if (b_vertices && !a_vertices) map_b = Map::barycenters;
    if (map_a == Map::barycenters && ma.tets.empty()) throw CompareError(dir_a.string() + ": FEM run without tets in mesh.json");
    if (map_b == Map::barycenters && mb.tets.empty()) throw CompareError(dir_b.string() + ": FEM run without tets in mesh.json");
    r.mapping = map_a == Map::barycenters ? "run A's FEM vertices averaged per tet onto run B's particles (tet barycenters)"
                : map_b == Map::barycenters ? "run B's FEM vertices averaged per tet onto run A's particles (tet barycenters)"
                                            : "direct, particle by particle";
  }
  auto points_of = [&](const Series& s, std::size_t k, Map map, const RunMesh& m, const fs::path& dir) {
    auto pts = read_vtu_points(s.files[k]);
    if (map == Map::barycenters) return barycenters(pts, m, dir);
    if (map == Map::interpolated) return interpolate(pts, embedding);
    if (map == Map::fitted) return interpolate(pts, point_fit);
    return pts;
  };

  // Different meshes: a point outside the interpolated mesh sits at a fixed offset from where the
  // field is evaluated (its clamped weights); that offset is geometry, not motion, so it is
  // subtracted from every frame. Zero for points inside the mesh (all of them for a box).
  std::vector<Vec3> offset;
  const bool resampled = map_a == Map::interpolated || map_b == Map::interpolated || map_a == Map::fitted ||
                         map_b == Map::fitted;
  // Frames are paired by time: each of A's frames with B's frame at the same time (within 1% of the
  // coarser frame spacing), so runs of different frame rates or lengths compare at their common times.
  auto spacing_of = [](const Series& s) { return s.times.size() > 1 ? std::abs(s.times[1] - s.times[0]) : 0.0; };
  const double spacing = std::max(spacing_of(sa), spacing_of(sb));
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t ka = 0, kb = 0; ka < sa.times.size() && kb < sb.times.size();) {
    const double d = sa.times[ka] - sb.times[kb];
    if (std::abs(d) <= 0.01 * spacing + 1e-12) pairs.emplace_back(ka++, kb++);
    else if (d < 0) ++ka;
    else ++kb;
  }
  if (pairs.empty() || pairs.front() != std::pair<std::size_t, std::size_t>{0, 0})
    throw CompareError(dir_a.string() + " and " + dir_b.string() + " have no common first frame (t = " +
                       std::to_string(sa.times[0]) + " s and t = " + std::to_string(sb.times[0]) +
                       " s); compare runs that start together");
  double sum_all = 0.0;
  std::size_t count_all = 0;
  for (const auto& [ka, kb] : pairs) {
    const auto pa = points_of(sa, ka, map_a, ma, dir_a);
    const auto pb = points_of(sb, kb, map_b, mb, dir_b);
    if (pa.size() != pb.size())
      throw CompareError("frame " + std::to_string(ka) + ": " + std::to_string(pa.size()) + " points in " + dir_a.string() +
                         " vs " + std::to_string(pb.size()) + " in " + dir_b.string() +
                         (ma.present && mb.present ? "" : " (a run without mesh.json cannot be mapped)") +
                         "; compare runs of the same scene and resolution");
    if (ka == 0) {
      r.points = pa.size();
      // Same scene ⇒ identical reference positions (up to the VTU's exact doubles and the 1/4 mean);
      // different meshes of one body ⇒ the same up to curved-boundary facets.
      double worst = 0.0;
      for (std::size_t i = 0; i < pa.size(); ++i) worst = std::max(worst, (pa[i] - pb[i]).norm());
      if (worst > frame0_tolerance * r.diagonal)
        throw CompareError("frame 0 differs by up to " + std::to_string(worst / r.diagonal) +
                           " of the diagonal: the runs do not start from the same " +
                           (resampled ? "body (same scene?)" : "mesh (same scene and resolution?)"));
      if (resampled) {
        offset.resize(pa.size());
        for (std::size_t i = 0; i < pa.size(); ++i) offset[i] = pa[i] - pb[i];
      }
    }
    CompareFrame f;
    f.time_a = sa.times[ka];
    f.time_b = sb.times[kb];
    double sum = 0.0;
    for (std::size_t i = 0; i < pa.size(); ++i) {
      Vec3 d = pa[i] - pb[i];
      if (!offset.empty()) d -= offset[i];
      const double e = d.norm() / r.diagonal;
      f.max_error = std::max(f.max_error, e);
      sum += e;
    }
    f.mean_error = pa.empty() ? 0.0 : sum / double(pa.size());
    sum_all += sum;
    count_all += pa.size();
    r.max_error = std::max(r.max_error, f.max_error);
    r.frames.push_back(f);
  }
  r.mean_error = count_all ? sum_all / double(count_all) : 0.0;
  return r;
}

void write_compare_csv(const CompareResult& r, const fs::path& file) {
  std::ostringstream s;
  s.precision(9);
  s << "frame,time,max_error,mean_error\n";
  for (std::size_t k = 0; k < r.frames.size(); ++k)
    s << k << ',' << r.frames[k].time_a << ',' << r.frames[k].max_error << ',' << r.frames[k].mean_error << '\n';
  s << "overall,," << r.max_error << ',' << r.mean_error << '\n';
  const std::string text = s.str();
  io::write_atomic(file, [&](std::ostream& out) { out << text; });
}

}  // namespace perifx
