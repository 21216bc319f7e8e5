// Collider system: static and kinematic colliders (ground plane, sphere, box with prescribed linear
// and angular velocity), by projection: a particle found inside a collider after the drift is moved
// to the nearest point of its surface, and its velocity relative to the collider surface loses its
// approaching normal part (times −restitution) and, by Coulomb friction, up to friction·|Δv_n| of its
// tangential part. Projection never lets a particle center penetrate, needs no stiffness, and so
// does not limit the time step. Particles a boundary condition prescribes on any axis are left alone (a
// projection would move their prescribed components).
// Reads: time, flags.   Writes: position, velocity.
#include <Eigen/Geometry>
#include <cmath>

#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {
namespace {

struct Placed {  // a collider at the end of the step
  const scene::Collider* spec;
  Vec3 center;
  Mat3 orientation;
};

void respond(Vec3& v, const Vec3& surface_velocity, const Vec3& normal, const scene::Collider& c) {
  Vec3 rel = v - surface_velocity;
  const double vn = rel.dot(normal);
  if (vn >= 0.0) return;  // already separating
  Vec3 vt = rel - vn * normal;
  const double dvn = -(1.0 + c.restitution) * vn;  // > 0
  const double vt_len = vt.norm();
  if (vt_len > 0.0) vt *= std::max(0.0, 1.0 - c.friction * dvn / vt_len);
  v = surface_velocity + vt - c.restitution * vn * normal;
}

}  // namespace

SystemDecl collider_system(WorldState& w) {
  return {"colliders", {Component::time, Component::flags}, {Component::position, Component::velocity}, [&w] {
            const auto& colliders = w.settings.colliders;
            if (colliders.empty()) return;
            const double t = w.clock.time + w.clock.dt;
            std::vector<Placed> placed;  // a handful of colliders; allocation outside the particle loop
            placed.reserve(colliders.size());
            for (const auto& c : colliders) {
              const double angle = c.angular_velocity.norm() * t;
              const Mat3 spin = angle > 0.0 ? Eigen::AngleAxisd(angle, c.angular_velocity.normalized()).toRotationMatrix()
                                            : Mat3::Identity();
              const Vec3 origin = c.kind == scene::Collider::Kind::plane ? c.point : c.center;
              placed.push_back({&c, origin + t * c.velocity, spin * c.orientation});
            }
            auto& p = w.particles;
            parallel_for_each(p.count(), [&](std::size_t i) {
              if (p.flags[i] & kPrescribed) return;
              Vec3& y = p.position[i];
              Vec3& v = p.velocity[i];
              for (const Placed& pc : placed) {
                const scene::Collider& c = *pc.spec;
                Vec3 normal = Vec3::Zero();
                switch (c.kind) {
                  case scene::Collider::Kind::plane: {
                    const Vec3 nrm = pc.orientation * c.normal;
                    const double d = (y - pc.center).dot(nrm);
                    if (d >= 0.0) continue;
                    y -= d * nrm;
                    normal = nrm;
                    break;
                  }
                  case scene::Collider::Kind::sphere: {
                    const Vec3 rel = y - pc.center;
                    const double dist = rel.norm();
                    if (dist >= c.radius) continue;
                    normal = dist > 0.0 ? Vec3(rel / dist) : Vec3(Vec3::UnitY());
                    y = pc.center + c.radius * normal;
                    break;
                  }
                  case scene::Collider::Kind::box: {
                    const Vec3 local = pc.orientation.transpose() * (y - pc.center);
                    const Vec3 depth = c.half_extents - local.cwiseAbs();
                    if (depth.minCoeff() <= 0.0) continue;
                    int axis = 0;
                    depth.minCoeff(&axis);
                    Vec3 local_n = Vec3::Zero();
                    local_n[axis] = local[axis] >= 0.0 ? 1.0 : -1.0;
                    normal = pc.orientation * local_n;
                    y += depth[axis] * normal;
                    break;
                  }
                }
                const Vec3 surface_velocity = c.velocity + c.angular_velocity.cross(y - pc.center);
                respond(v, surface_velocity, normal, c);
              }
            }, 2048);
          }};
}

}  // namespace perifx::systems
