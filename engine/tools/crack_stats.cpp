// Crack geometry statistics (see crack_stats.hpp).
#include "tools/crack_stats.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <ostream>
#include <set>
#include <unordered_map>

#include "io/run_dir.hpp"

namespace perifx {
namespace {

constexpr double kDeg = 180.0 / 3.14159265358979323846;

struct Face {
  std::array<std::uint32_t, 3> v;  // welded vertex ids
  Vec3 centroid, normal;           // unit normal
  double area = 0.0;
  Mat3 scatter = Mat3::Zero();     // area × covariance of the uniform triangle about its centroid
};

Face make_face(const std::vector<Vec3>& x, const std::array<std::uint32_t, 3>& t) {
  Face f;
  f.v = t;
  const Vec3 &a = x[t[0]], &b = x[t[1]], &c = x[t[2]];
  const Vec3 n = (b - a).cross(c - a);
  f.area = 0.5 * n.norm();
  f.normal = f.area > 0.0 ? Vec3(n / n.norm()) : Vec3::Zero();
  f.centroid = (a + b + c) / 3.0;
  // Covariance of a uniform triangle: (1/12) Σ d_i d_iᵀ, d_i = vertex − centroid.
  for (const Vec3* p : {&a, &b, &c}) {
    const Vec3 d = *p - f.centroid;
    f.scatter += d * d.transpose();
  }
  f.scatter *= f.area / 12.0;
  return f;
}

// Area-weighted plane through faces: the eigenvector of the smallest eigenvalue of their scatter.
Vec3 fit_normal(const std::vector<Face>& faces, const std::vector<std::uint32_t>& which, double* area_out = nullptr) {
  double area = 0.0;
  Vec3 mean = Vec3::Zero();
  for (auto f : which) area += faces[f].area, mean += faces[f].area * faces[f].centroid;
  if (area_out) *area_out = area;
  if (!(area > 0.0)) return Vec3::Zero();
  mean /= area;
  Mat3 s = Mat3::Zero();
  for (auto f : which) {
    const Vec3 d = faces[f].centroid - mean;
    s += faces[f].scatter + faces[f].area * d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Mat3> es(s);
  return es.eigenvectors().col(0);
}

// A triangle's three reference corners, sorted: the same key for a crack face and its twin on the
// other side of the crack (same reference triangle, opposite orientation).
std::array<double, 9> reference_key(const io::SurfaceFrame& s, std::size_t f) {
  std::array<std::array<double, 3>, 3> p;
  for (int c = 0; c < 3; ++c) {
    const Vec3& r = s.reference[s.triangle[f][static_cast<std::size_t>(c)]];
    p[static_cast<std::size_t>(c)] = {r.x(), r.y(), r.z()};
  }
  std::sort(p.begin(), p.end());
  std::array<double, 9> key{};
  for (int i = 0; i < 9; ++i) key[static_cast<std::size_t>(i)] = p[static_cast<std::size_t>(i / 3)][static_cast<std::size_t>(i % 3)];
  return key;
}

}  // namespace

CrackStats crack_statistics(const CrackSurface& in, const CrackStatsOptions& opt) {
  CrackStats st;
  // Weld vertices by coordinates, then merge triangles over the same three welded vertices.
  std::map<std::array<double, 3>, std::uint32_t> weld_map;
  std::vector<std::uint32_t> weld(in.vertex.size());
  std::vector<Vec3> x;
  for (std::size_t v = 0; v < in.vertex.size(); ++v) {
    const auto key = std::array<double, 3>{in.vertex[v].x(), in.vertex[v].y(), in.vertex[v].z()};
    const auto [it, fresh] = weld_map.emplace(key, static_cast<std::uint32_t>(x.size()));
    if (fresh) x.push_back(in.vertex[v]);
    weld[v] = it->second;
  }
  std::vector<Face> faces;
  {
    std::set<std::array<std::uint32_t, 3>> seen;
    for (const auto& t : in.triangle) {
      std::array<std::uint32_t, 3> w{weld[t[0]], weld[t[1]], weld[t[2]]};
      auto key = w;
      std::sort(key.begin(), key.end());
      if (key[0] == key[1] || key[1] == key[2] || !seen.insert(key).second) continue;
      faces.push_back(make_face(x, w));
    }
  }
  st.faces = faces.size();
  double aligned = 0.0, edge_sum = 0.0;
  std::size_t edge_count = 0;
  const double cos_tol = std::cos(opt.axis_tolerance_deg / kDeg);
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::uint32_t>> edges;
  for (std::uint32_t f = 0; f < faces.size(); ++f) {
    st.area += faces[f].area;
    if (faces[f].normal.cwiseAbs().maxCoeff() >= cos_tol) aligned += faces[f].area;
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t a = faces[f].v[static_cast<std::size_t>(e)], b = faces[f].v[static_cast<std::size_t>((e + 1) % 3)];
      edge_sum += (x[a] - x[b]).norm();
      ++edge_count;
      edges[{std::min(a, b), std::max(a, b)}].push_back(f);
    }
  }
  if (faces.empty()) return st;
  st.axis_aligned_fraction = aligned / st.area;
  // Dihedral angles over edges shared by two faces.
  double dihedral = 0.0;
  for (const auto& [key, fs] : edges) {
    if (fs.size() != 2) continue;
    const double c = std::min(1.0, std::abs(faces[fs[0]].normal.dot(faces[fs[1]].normal)));
    dihedral += std::acos(c) * kDeg;
    ++st.dihedral_edges;
  }
  st.mean_dihedral = st.dihedral_edges ? dihedral / static_cast<double>(st.dihedral_edges) : 0.0;
  // Area ratio over local neighbourhoods (cells of side `radius` over the centroids).
  st.radius = opt.radius > 0.0 ? opt.radius : 3.0 * edge_sum / static_cast<double>(edge_count);
  {
    const double h = st.radius;
    auto cell = [h](double c) { return static_cast<long long>(std::floor(c / h)); };
    std::map<std::array<long long, 3>, std::vector<std::uint32_t>> grid;
    for (std::uint32_t f = 0; f < faces.size(); ++f)
      grid[{cell(faces[f].centroid.x()), cell(faces[f].centroid.y()), cell(faces[f].centroid.z())}].push_back(f);
    std::vector<std::uint32_t> near;
    double weighted = 0.0;
    for (std::uint32_t f = 0; f < faces.size(); ++f) {
      near.clear();
      const Vec3& c = faces[f].centroid;
      for (long long i = cell(c.x()) - 1; i <= cell(c.x()) + 1; ++i)
        for (long long j = cell(c.y()) - 1; j <= cell(c.y()) + 1; ++j)
          for (long long k = cell(c.z()) - 1; k <= cell(c.z()) + 1; ++k) {
            const auto it = grid.find({i, j, k});
            if (it == grid.end()) continue;
            for (auto g : it->second)
              if ((faces[g].centroid - c).norm() <= h) near.push_back(g);
          }
      const Vec3 n = fit_normal(faces, near);
      double area = 0.0, projected = 0.0;
      for (auto g : near) area += faces[g].area, projected += faces[g].area * std::abs(faces[g].normal.dot(n));
      const double ratio = projected > 0.0 ? area / projected : 1.0;
      weighted += faces[f].area * ratio;
    }
    st.area_ratio = st.area > 0.0 ? weighted / st.area : 1.0;
  }
  // Mirror fit.
  if (opt.mirror_axis >= 0 && opt.mirror_axis < 3) {
    st.mirror = true;
    const int m = opt.mirror_axis, l = opt.load_axis;
    for (int side = 0; side < 2; ++side) {
      std::vector<std::uint32_t> which;
      for (std::uint32_t f = 0; f < faces.size(); ++f)
        if ((faces[f].centroid[m] > opt.mirror_at) == (side == 1)) which.push_back(f);
      CrackSideFit& fit = side == 0 ? st.left : st.right;
      fit.faces = which.size();
      fit.normal = fit_normal(faces, which, &fit.area);
      if (which.empty()) continue;
      const double nl = fit.normal[l], nm = fit.normal[m];
      fit.angle_to_load = std::asin(std::min(1.0, std::abs(nl))) * kDeg;
      const double s = side == 1 ? 1.0 : -1.0;  // away from the mirror plane
      // Direction in the (m, l) plane ⟂ n: (−n_l, n_m) up to sign; tilt = its angle above the m axis,
      // oriented away from the mirror plane.
      const double sign = nl < 0.0 ? -1.0 : 1.0;
      fit.tilt = std::atan2(-s * nm * sign, std::abs(nl)) * kDeg;
    }
    st.asymmetry = std::abs(st.right.tilt - st.left.tilt);
  }
  return st;
}

CrackStats crack_statistics(const std::filesystem::path& dir, const CrackStatsOptions& opt) {
  io::RunDirectory run;
  try {
    run = io::scan_run_directory(dir);
  } catch (const io::RunDirError& e) {
    throw CrackStatsError(e.what());
  }
  const io::FrameFiles* first = nullptr;
  const io::FrameFiles* chosen = nullptr;
  for (const auto& f : run.frames) {
    if (f.surface.empty()) continue;
    if (!first) first = &f;
    if (opt.frame ? f.index == *opt.frame : true) chosen = &f;
  }
  if (!chosen)
    throw CrackStatsError(dir.string() + (opt.frame ? ": no surface file for frame " + std::to_string(*opt.frame)
                                                    : std::string(": no surface files")));
  auto read = [&](const io::FrameFiles& f) {
    io::SurfaceFrame s;
    try {
      s = io::read_surface_frame(f.surface);
    } catch (const io::RunDirError& e) {
      throw CrackStatsError(e.what());
    }
    if (s.crack.size() != s.triangle.size() || s.reference.size() != s.vertex.size())
      throw CrackStatsError(f.surface.string() + ": needs per-face crack flags and per-vertex reference positions "
                                                 "(rx ry rz): a surface PLY written by perifx");
    return s;
  };
  // A crack face = the pair of tets on its two sides (a face of a dropped piece: its one tet twice).
  auto face_tets = [](const io::SurfaceFrame& s) {
    std::map<std::array<double, 9>, std::vector<std::uint32_t>> by_geometry;
    for (std::size_t f = 0; f < s.triangle.size(); ++f) {
      if (!s.crack[f]) continue;
      by_geometry[reference_key(s, f)].push_back(s.tet.size() == s.triangle.size() ? s.tet[f] : static_cast<std::uint32_t>(f));
    }
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> out;
    for (auto& [key, tets] : by_geometry) out[{*std::min_element(tets.begin(), tets.end()), *std::max_element(tets.begin(), tets.end())}] = 1;
    return out;
  };
  const io::SurfaceFrame s = read(*chosen);
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> initial;
  if (opt.exclude_initial && first != chosen && s.tet.size() == s.triangle.size()) initial = face_tets(read(*first));
  CrackSurface surface;
  surface.vertex = s.reference;
  // Pair each crack triangle with its twin (same reference triangle) to find the tets it separates.
  std::map<std::array<double, 9>, std::vector<std::uint32_t>> twins;
  for (std::uint32_t f = 0; f < s.triangle.size(); ++f) {
    if (!s.crack[f]) continue;
    twins[reference_key(s, f)].push_back(f);
  }
  for (const auto& [key, fs] : twins) {
    if (!initial.empty()) {
      std::uint32_t lo = 0xFFFFFFFFu, hi = 0;
      for (auto f : fs) lo = std::min(lo, s.tet[f]), hi = std::max(hi, s.tet[f]);
      if (initial.count({lo, hi})) continue;
    }
    surface.triangle.push_back(s.triangle[fs[0]]);
  }
  CrackStats st = crack_statistics(surface, opt);
  st.frame = chosen->index;
  return st;
}

void print_crack_stats(std::ostream& out, const CrackStats& s, const CrackStatsOptions& opt) {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "frame %llu: %zu crack faces%s, area %.6g m^2\n"
                "axis-aligned (normal within %.3g deg of an axis): %.2f %% of the crack area\n"
                "roughness: area ratio %.4f (neighbourhood radius %.4g m), mean dihedral %.3f deg over %zu edges\n",
                static_cast<unsigned long long>(s.frame), s.faces, opt.exclude_initial ? " (frame-0 faces left out)" : "",
                s.area, opt.axis_tolerance_deg, 100.0 * s.axis_aligned_fraction, s.area_ratio, s.radius,
                s.mean_dihedral, s.dihedral_edges);
  out << buf;
  if (!s.mirror) return;
  const char axis[3] = {'x', 'y', 'z'};
  for (int side = 0; side < 2; ++side) {
    const CrackSideFit& f = side == 0 ? s.left : s.right;
    std::snprintf(buf, sizeof buf,
                  "%s side (%c %s %.4g): %zu faces, area %.6g m^2, normal (%.4f, %.4f, %.4f), angle to %c axis %.3f deg, "
                  "tilt %.3f deg\n",
                  side == 0 ? "left " : "right", axis[opt.mirror_axis], side == 0 ? "<" : ">", opt.mirror_at, f.faces,
                  f.area, f.normal.x(), f.normal.y(), f.normal.z(), axis[opt.load_axis], f.angle_to_load, f.tilt);
    out << buf;
  }
  std::snprintf(buf, sizeof buf, "mirror asymmetry |tilt right - tilt left|: %.3f deg\n", s.asymmetry);
  out << buf;
}

}  // namespace perifx
