// Collider geometry (systems/README.md §8.3), shared by the colliders, the surface frames they read and
// kick_end: where a kinematic collider is at a time, how far a point is from it, how deep a triangle (a
// boundary face of a particle's tet, placed by the particle's frame) reaches into it, and the nearest
// velocity that moves into none of the colliders holding a particle (support_projection). A point (the
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

// The velocity nearest to v that moves into none of the colliders that held the particle, each
// relative to its surface velocity at y: for constraints (v − s_c)·n_c ≥ 0, the Euclidean projection
// onto their half-spaces, by active sets in order of size. Each candidate is the projection of v onto
// the planes of its set, u = v − Σ λ_c n_c with (u − s_c)·n_c = 0: one plane (for a constraint v
// breaks), two planes' common line, the three planes' common point. A candidate is accepted when it
// moves into no collider and pushes out of each plane it lies on (λ ≤ 0: the projection's optimality
// conditions, so the first found is the projection); the set of all the constraints, reached only
// when no smaller set would do, is the projection without a test. Two normals near parallel (the
// same surface twice) are taken one after the other; three near one plane (a singular corner) by
// Dykstra's alternating projections when one pass does not satisfy all three.
// "Allowed" is within rounding (1e-12 relative): a velocity projected onto a plane reads −1e-17 there.
// n: the count (1–3) constraints' outward normals (need not be unit), surface: their surface velocities.
inline Vec3 support_projection(const Vec3& v, const Vec3* n, const Vec3* surface, int count) {
  auto gap = [&](const Vec3& u, int c) { return (u - surface[c]).dot(n[c]); };  // < 0: moving into c
  auto onto = [&](const Vec3& u, int c) {  // onto constraint c's plane when u violates it
    const double g = gap(u, c);
    return g < 0.0 ? Vec3(u - g * n[c]) : u;
  };
  if (count == 1) return onto(v, 0);
  auto allowed_by = [&](const Vec3& u, int c) { return !(gap(u, c) < -1e-12 * (1.0 + u.norm())); };
  // u allowed by every constraint not in `on` (a bit per constraint: the planes u was put on, which
  // it satisfies by construction; tested, they would read the normals' float rounding, ~1e-7 |g|).
  auto allowed = [&](const Vec3& u, unsigned on) {
    for (int c = 0; c < count; ++c)
      if (!(on >> c & 1u) && !allowed_by(u, c)) return false;
    return true;
  };
  if (allowed(v, 0u)) return v;
  for (int c = 0; c < count; ++c) {  // one plane, of a constraint v breaks
    if (allowed_by(v, c)) continue;
    const Vec3 u = onto(v, c);
    if (allowed(u, 1u << c)) return u;
  }
  for (int c = 0; c < (count == 2 ? 1 : count); ++c) {  // two planes: c and d, their common line
    const int d = (c + 1) % count;
    const double cos_cd = n[c].dot(n[d]), det = 1.0 - cos_cd * cos_cd;
    if (!(det > 1e-6)) continue;
    // v − a n_c − b n_d on both planes: [1 cos; cos 1] (a, b) = (gap_c, gap_d).
    const double g_c = gap(v, c), g_d = gap(v, d);
    const double a = (g_c - cos_cd * g_d) / det, b = (g_d - cos_cd * g_c) / det;
    const Vec3 u = v - a * n[c] - b * n[d];
    if (count == 2) return u;  // every constraint active
    if (a > 0.0 || b > 0.0) continue;
    if (allowed(u, 1u << c | 1u << d)) return u;
  }
  if (count == 3) {  // the three planes' common point: Gram G λ = gap
    Mat3 gram;
    for (int c = 0; c < 3; ++c)
      for (int d = 0; d < 3; ++d) gram(c, d) = n[c].dot(n[d]);
    // det G is the squared volume of the unit normals (1e-12: within ~6e-5° of one plane).
    if (std::abs(gram.determinant()) > 1e-12) {
      const Vec3 lambda = gram.inverse() * Vec3(gap(v, 0), gap(v, 1), gap(v, 2));
      return v - lambda[0] * n[0] - lambda[1] * n[1] - lambda[2] * n[2];
    }
  }
  // A degenerate set: one plane after another. That pass is the first round of Dykstra's alternating
  // projections (which converge to the projection onto the intersection); three normals near one
  // plane (a singular corner) that it leaves unsatisfied take further rounds from its corrections.
  Vec3 u = v, correction[3];
  for (int c = 0; c < count; ++c) {
    const Vec3 before = u;
    u = onto(before, c);
    correction[c] = before - u;
  }
  if (count == 2 || allowed(u, 0u)) return u;
  for (int round = 1; round < 64; ++round)
    for (int c = 0; c < 3; ++c) {
      const Vec3 before = u + correction[c];
      u = onto(before, c);
      correction[c] = before - u;
    }
  return u;
}

// A point: the triangle with three equal corners.
inline Penetration point_penetration(const PlacedCollider& pc, const Vec3& y) { return triangle_penetration(pc, {y, y, y}); }

}  // namespace perifx::systems
