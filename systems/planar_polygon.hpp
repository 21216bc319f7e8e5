// A planar polygon prepared for segment-crossing tests, shared by initial cracks (initial_cracks.cpp)
// and weak planes (strength_field.cpp). The test is described in initial_cracks.cpp.
#pragma once
#include <array>
#include <vector>

#include "components/math.hpp"

namespace perifx::systems {

struct PlanarPolygon {
  Vec3 normal, point;
  int u = 0, v = 1;                       // the two coordinates kept by the projection
  std::vector<std::array<double, 2>> p;   // projected vertices
  Vec3 lo, hi;                            // bounding box (padded), for a quick reject
};

inline PlanarPolygon prepare_polygon(const std::vector<Vec3>& poly) {
  PlanarPolygon out;
  Vec3 n = Vec3::Zero(), centroid = Vec3::Zero();
  out.lo = out.hi = poly[0];
  for (std::size_t a = 0; a < poly.size(); ++a) {
    const Vec3& p = poly[a];
    const Vec3& q = poly[(a + 1) % poly.size()];
    n += Vec3((p.y() - q.y()) * (p.z() + q.z()), (p.z() - q.z()) * (p.x() + q.x()), (p.x() - q.x()) * (p.y() + q.y()));
    centroid += p;
    out.lo = out.lo.cwiseMin(p);
    out.hi = out.hi.cwiseMax(p);
  }
  out.normal = n.normalized();
  out.point = centroid / double(poly.size());
  int drop = 0;
  out.normal.cwiseAbs().maxCoeff(&drop);
  out.u = (drop + 1) % 3;
  out.v = (drop + 2) % 3;
  for (const Vec3& p : poly) out.p.push_back({p[out.u], p[out.v]});
  const double pad = 1e-9 * (out.hi - out.lo).norm();
  out.lo.array() -= pad;
  out.hi.array() += pad;
  return out;
}

inline bool crosses(const PlanarPolygon& poly, const Vec3& a, const Vec3& b) {
  if ((a.cwiseMax(b).array() < poly.lo.array()).any() || (a.cwiseMin(b).array() > poly.hi.array()).any()) return false;
  const double da = (a - poly.point).dot(poly.normal), db = (b - poly.point).dot(poly.normal);
  if ((da > 0.0 && db > 0.0) || (da < 0.0 && db < 0.0) || da == db) return false;
  const Vec3 q = a + (da / (da - db)) * (b - a);
  const double qu = q[poly.u], qv = q[poly.v];
  bool inside = false;
  for (std::size_t s = 0, t = poly.p.size() - 1; s < poly.p.size(); t = s++) {
    const auto& ps = poly.p[s];
    const auto& pt = poly.p[t];
    if ((ps[1] > qv) != (pt[1] > qv) && qu < (pt[0] - ps[0]) * (qv - ps[1]) / (pt[1] - ps[1]) + ps[0]) inside = !inside;
  }
  return inside;
}

}  // namespace perifx::systems
