// Collider geometry (systems/README.md §8.3), shared by the colliders and the surface frames they read:
// where a kinematic collider is at a time, how far a point is from it, and how deep a triangle (a
// boundary face of a particle's tet, placed by the particle's frame) reaches into it. A point (the
// particle's centre) is a triangle with three equal corners. The penetration is the push along one
// outward normal that takes the triangle out of the collider:
//   plane (P, N): depth = −min_c (v_c − P)·N, the lowest corner below the plane; exact.
//   sphere (C, R): q the triangle's point nearest C; depth = R − |q − C| along (q − C)/|q − C|; exact.
//   box (centre, orientation, half extents h): per box axis a, with the corners in box coordinates,
//     the push out through the +a face is h_a − min_c v_c,a and through the −a face h_a + max_c v_c,a;
//     the triangle overlaps the box when every one of the six is positive, and is pushed by the least.
//     Separating axes are the box's only (not the face normal or the edge cross products): near a box
//     edge or corner a triangle that only comes close can be pushed, by less than its size. For a point
//     this is the point projection of earlier versions.
// Why triangles and not discs (projectiles use covering discs): a disc that covers a side face reaches
// below the bottom face it borders, so a body resting on a plane was lifted at its edges every step
// and jumped (tried: a box resting on the ground left it at 0.12 m/s).
#pragma once
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>

#include "components/world_state.hpp"

namespace perifx::systems {

struct PlacedCollider {  // a collider at one time
  const scene::Collider* spec;
  Vec3 center;       // plane: its point
  Mat3 orientation;  // the spin since t = 0 times the scene's orientation
};

inline PlacedCollider place_collider(const scene::Collider& c, double t) {
  const double angle = c.angular_velocity.norm() * t;
  const Mat3 spin = angle > 0.0 ? Eigen::AngleAxisd(angle, c.angular_velocity.normalized()).toRotationMatrix()
                                : Mat3::Identity();
  const Vec3 origin = c.kind == scene::Collider::Kind::plane ? c.point : c.center;
  return {&c, origin + t * c.velocity, spin * c.orientation};
}

// Distance from y to the collider's surface, negative inside; for a box, the distance to the box when
// outside and minus the least depth when inside.
inline double collider_distance(const PlacedCollider& pc, const Vec3& y) {
  const scene::Collider& c = *pc.spec;
  switch (c.kind) {
    case scene::Collider::Kind::plane: return (y - pc.center).dot(pc.orientation * c.normal);
    case scene::Collider::Kind::sphere: return (y - pc.center).norm() - c.radius;
    case scene::Collider::Kind::box: {
      const Vec3 gap = (pc.orientation.transpose() * (y - pc.center)).cwiseAbs() - c.half_extents;
      return gap.maxCoeff() > 0.0 ? gap.cwiseMax(0.0).norm() : gap.maxCoeff();
    }
  }
  return 0.0;
}

struct Penetration {
  double depth = 0.0;  // > 0: the push along `normal` that takes the triangle out
  Vec3 normal = Vec3::Zero();
};

// The point of triangle (a, b, c) nearest p: by the region of the triangle's plane p projects into
// (a corner, an edge, or the inside), from the barycentric coordinates of its projection.
inline Vec3 nearest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return a;
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + (d1 / (d1 - d3)) * ab;
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

// How far the triangle with corners v[0..2] is inside the collider (depth ≤ 0: not inside).
inline Penetration triangle_penetration(const PlacedCollider& pc, const std::array<Vec3, 3>& v) {
  const scene::Collider& c = *pc.spec;
  Penetration out;
  switch (c.kind) {
    case scene::Collider::Kind::plane: {
      const Vec3 nrm = pc.orientation * c.normal;
      out.depth = -std::min({(v[0] - pc.center).dot(nrm), (v[1] - pc.center).dot(nrm), (v[2] - pc.center).dot(nrm)});
      out.normal = nrm;
      break;
    }
    case scene::Collider::Kind::sphere: {
      const Vec3 rel = nearest_on_triangle(pc.center, v[0], v[1], v[2]) - pc.center;
      const double dist = rel.norm();
      out.depth = c.radius - dist;
      out.normal = dist > 0.0 ? Vec3(rel / dist) : Vec3(Vec3::UnitY());
      break;
    }
    case scene::Collider::Kind::box: {
      const Mat3& R = pc.orientation;
      Vec3 lo = Vec3::Constant(kInfinity), hi = Vec3::Constant(-kInfinity);
      for (const Vec3& corner : v) {
        const Vec3 local = R.transpose() * (corner - pc.center);
        lo = lo.cwiseMin(local), hi = hi.cwiseMax(local);
      }
      out.depth = kInfinity;
      for (int a = 0; a < 3; ++a) {
        const double up = c.half_extents[a] - lo[a], down = c.half_extents[a] + hi[a];
        const double push = std::min(up, down);
        if (push < out.depth) {
          out.depth = push;
          Vec3 local_n = Vec3::Zero();
          local_n[a] = up <= down ? 1.0 : -1.0;
          out.normal = R * local_n;
        }
      }
      break;
    }
  }
  return out;
}

// A boundary face of a particle at x (its corners relative to the particle's reference position),
// placed by the particle's frame F (nullptr: moved with the particle only, not turned), and how deep
// it is in the collider. The colliders and the surface frames' touching test place faces alike.
inline Penetration face_penetration(const PlacedCollider& pc, const Vec3& x, const Mat3* F,
                                    const std::array<Vec3, 3>& corner) {
  std::array<Vec3, 3> placed;
  for (int k = 0; k < 3; ++k) placed[k] = x + (F ? Vec3(*F * corner[k]) : corner[k]);
  return triangle_penetration(pc, placed);
}

// The crack faces a particle meets colliders with (WorldState::openable_faces): bit k set when face k
// of its tet is open, i.e. the bond to the tet across it is broken (or never was: an initial crack).
// From the bonds as they are; the surface frames store it at the end of each step for the colliders.
inline std::uint8_t open_crack_faces(const OpenableFaces& of, const Bonds& b, std::size_t i) {
  std::uint8_t open = 0;
  for (int k = 0; k < 4; ++k) {
    const std::uint16_t slot = of.bond_slot[i][static_cast<std::size_t>(k)];
    if (slot == OpenableFaces::kBoundary) continue;
    if (slot == OpenableFaces::kAlwaysOpen || !b.alive[b.offsets[i] + slot]) open = static_cast<std::uint8_t>(open | (1u << k));
  }
  return open;
}
// Face k of particle i's tet, opposite corner k, as corner offsets from the particle's reference
// position (as SurfacePatches::corner), and its outward normal in the reference orientation (not unit).
struct TetFace {
  std::array<Vec3, 3> corner;
  Vec3 normal;
};
inline TetFace openable_face(const OpenableFaces& of, std::size_t i, int k) {
  TetFace f;
  std::size_t m = 0;
  for (std::size_t c = 0; c < 4; ++c)
    if (c != static_cast<std::size_t>(k)) f.corner[m++] = of.corner[i][c].cast<double>();
  f.normal = (f.corner[1] - f.corner[0]).cross(f.corner[2] - f.corner[0]);
  if (f.normal.dot(of.corner[i][static_cast<std::size_t>(k)].cast<double>() - f.corner[0]) > 0.0) f.normal = -f.normal;
  return f;
}

// Calls visit(corner, normal) for every face particle i meets the colliders with: its original
// boundary faces, patches [face_begin, face_end) of SurfacePatches that have a radius (unit normal),
// then the crack faces `open` marks (OpenableFaces; normal not unit). Corners are offsets from the
// particle's reference position, to be placed by its frame. One list for the colliders and the
// surface frames, so both see the same faces in the same order.
template <class Visit>
inline void for_each_contact_face(const SurfacePatches& sf, std::uint32_t face_begin, std::uint32_t face_end,
                                  const OpenableFaces& of, std::size_t i, std::uint8_t open, Visit&& visit) {
  for (std::uint32_t q = face_begin; q < face_end; ++q)
    if (sf.radius[q] > 0.0) visit(sf.corner[q], sf.normal[q]);  // else a layer share of a traction
  for (int k = 0; k < 4; ++k)
    if (open >> k & 1u) {
      const TetFace face = openable_face(of, i, k);
      visit(face.corner, face.normal);
    }
}

// A point: the triangle with three equal corners.
inline Penetration point_penetration(const PlacedCollider& pc, const Vec3& y) { return triangle_penetration(pc, {y, y, y}); }

}  // namespace perifx::systems
