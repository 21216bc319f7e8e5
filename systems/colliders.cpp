// Collider system: static and kinematic colliders (ground plane, sphere, box with prescribed linear
// and angular velocity), by projection: a particle found inside a collider after the drift is moved
// out along the collider's normal, and its velocity relative to the collider surface loses its
// approaching normal part (times −restitution) and, by Coulomb friction, up to friction·|Δv_n| of its
// tangential part. Projection never lets a particle penetrate, needs no stiffness, and so
// does not limit the time step. Particles a boundary condition prescribes on any axis are left alone (a
// projection would move their prescribed components).
// What meets the collider: the particle's centre and, for a particle whose tet has original boundary
// faces (peridynamic worlds), those triangles (WorldState::surface), each corner placed at y + F·(X − x)
// by the particle's surface frame F of the last step's end (surface_frames.cpp: held while the particle
// touches a collider, so a push-out does not move the faces it meets next; zero → the face moves
// with the particle only). The deepest of them decides the push (collider_shapes.hpp). So a body
// rests on the ground with its mesh surface, the surface an artist renders, rather than with its
// particle centres, which sit a resolution-dependent fraction of a cell inside it (a 12-cell ball
// dropped on a plane sank 1.1 cm, 0.45 cell, into it). The faces of its tet that a crack opened
// (ParticleState::open_faces, from the bonds at the end of the last step; WorldState::openable_faces)
// are met the same way, so a piece lying on its fracture surface rests on it. Where a particle has
// no face, original or cracked, turned toward the collider (seen along the normal at its centre: a tet
// exposed where its own faces are still bonded), its sphere of reach (half the contact distance)
// takes part instead: in the bunny preview broken pieces lay up to 7 cm (0.6 cell) deep in the ground
// on their centres, 2.6 cm with the spheres of reach alone.
// Depth a particle already had when the step began (before this step's drift) is not this step's
// motion but a change of the contact geometry: a frame refitted, or a sphere of reach taking over
// where a crack exposed a tet. It is taken out at no more than kDepenetrationSpeed (0.5 m/s), as game
// engines cap depenetration: a push-out that does not change the velocity does work against whatever
// holds the particle there. Taken out at once, it shattered the fig15 preview's glass plate (2 % of
// its bonds left against 90 % in the full scene, the 5 m/s ball rebounding at 6.4 m/s): each crack at
// the ground pushed a tet up by up to half a cell in one step, into the fragments above it.
// Each particle's holding colliders (the first three) and their normals of this step go to
// ParticleState::collider_contact, for kick_end's support constraint (integration.cpp).
// Reads: time, flags, surface_frames.   Writes: position, velocity, collider_contact.
#include <cmath>

#include "collider_shapes.hpp"
#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {
namespace {

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

// The fastest a particle found already inside a collider at the start of a step is moved out, m/s.
constexpr double kDepenetrationSpeed = 0.5;

}  // namespace

double collider_lookahead(const WorldState& w, std::size_t i, double drift) {
  const auto& colliders = w.settings.colliders;
  const double dt = w.clock.dt;
  if (colliders.empty()) return drift;
  // One static plane (a ground): the push out of it is the depth the drift made (≤ D, along the
  // normal, so |drift + push| ≤ D) plus the earlier depth at kDepenetrationSpeed.
  if (colliders.size() == 1 && colliders[0].kind == scene::Collider::Kind::plane &&
      colliders[0].velocity.isZero(0.0) && colliders[0].angular_velocity.isZero(0.0))
    return drift + kDepenetrationSpeed * dt;
  // Otherwise each collider may push by the depth of the drift (≤ D) plus its own motion over the
  // step at the particle and the depenetration cap: a bound, not tight, for several at once.
  double reach = 2.0 * drift;
  const double t = w.clock.time + dt;  // where the next step's colliders will be
  const Vec3& y = w.particles.position[i];
  for (const auto& c : colliders) {
    const Vec3 centre = (c.kind == scene::Collider::Kind::plane ? c.point : c.center) + t * c.velocity;
    reach += dt * (kDepenetrationSpeed + c.velocity.norm() + c.angular_velocity.norm() * (y - centre).norm());
  }
  return reach;
}

SystemDecl collider_system(WorldState& w) {
  return {"colliders", {Component::time, Component::flags, Component::surface_frames},
          {Component::position, Component::velocity, Component::collider_contact}, [&w] {
            const auto& colliders = w.settings.colliders;
            if (colliders.empty()) return;
            const double t = w.clock.time + w.clock.dt;
            std::vector<PlacedCollider> placed;  // a handful of colliders; allocation outside the particle loop
            placed.reserve(colliders.size());
            for (const auto& c : colliders) placed.push_back(place_collider(c, t));
            std::vector<PlacedCollider> placed_before;  // where they were at the start of the step
            placed_before.reserve(colliders.size());
            for (const auto& c : colliders) placed_before.push_back(place_collider(c, w.clock.time));
            const double dt = w.clock.dt;
            auto& p = w.particles;
            const SurfacePatches& sf = w.surface;
            const auto& frames = w.state.surface_frame;
            const auto& open_faces = w.state.open_faces;
            const OpenableFaces& openable = w.openable_faces;
            auto& held = w.state.collider_contact;
            parallel_for_each(p.count(), [&](std::size_t i) {
              held[i] = ColliderContact{};
              if (p.flags[i] & kPrescribed) return;
              Vec3& y = p.position[i];
              Vec3& v = p.velocity[i];
              // i's boundary faces, placed by its frame (none for interior particles and FEM worlds).
              const std::uint32_t face_begin = frames.empty() ? 0 : sf.offsets[i];
              const std::uint32_t face_end = frames.empty() ? 0 : sf.offsets[i + 1];
              const std::uint8_t open = open_faces.empty() ? 0 : open_faces[i];  // its open crack faces
              const Mat3 F = face_end > face_begin || open ? Mat3(frames[i].cast<double>()) : Mat3::Zero();
              const bool framed = !F.isZero(0.0);
              const Mat3 normal_map = framed ? Mat3(F.inverse().transpose()) : Mat3::Identity();
              // Peridynamic worlds: the particle's sphere of reach (the projectiles' and the contact's,
              // half the contact distance) for where it has no face toward the collider: a tet exposed by a
              // crack or a piece resting on a crack face would otherwise sink to its centroid, up to half a
              // cell (tens of mm in a preview) into the ground.
              const double reach = frames.empty() ? 0.0 : 0.5 * w.contact.distance_factor * w.contact.size[i];
              // The deepest of centre, faces and sphere of reach in collider pc for the particle at x.
              const auto deepest_at = [&](const PlacedCollider& pc, const Vec3& x, bool& centre) {
                const Penetration at_centre = point_penetration(pc, x);
                Penetration deepest = at_centre;
                bool facing = false;
                centre = true;
                for_each_contact_face(sf, face_begin, face_end, openable, i, open,
                                      [&](const std::array<Vec3, 3>& corner, const Vec3& normal) {
                  // A face turned toward the collider is the surface there (then no sphere of reach).
                  facing = facing || (normal_map * normal).dot(at_centre.normal) < 0.0;
                  const Penetration pen = face_penetration(pc, x, framed ? &F : nullptr, corner);
                  if (pen.depth > deepest.depth) deepest = pen, centre = false;
                });
                if (reach > 0.0 && !facing) {
                  Penetration sphere = at_centre;
                  sphere.depth += reach;
                  if (sphere.depth > deepest.depth) deepest = sphere, centre = false;
                }
                return deepest;
              };
              for (std::size_t k = 0; k < placed.size(); ++k) {
                const PlacedCollider& pc = placed[k];
                const scene::Collider& c = *pc.spec;
                bool centre = true;
                const Penetration deepest = deepest_at(pc, y, centre);
                if (!(deepest.depth > 0.0)) continue;
                // How deep it was before this step's drift (the collider where it was then): that part
                // of the depth is not this step's motion but a change of the contact geometry (a frame
                // refitted, a sphere of reach taking over where a crack exposed a tet). It is resolved
                // at no more than kDepenetrationSpeed, as a push-out that does not change the velocity
                // does work against whatever holds the particle there.
                bool centre_before = true;
                const double before = deepest_at(placed_before[k], y - dt * v, centre_before).depth;
                double push = deepest.depth;
                if (before > 0.0) push = std::min(push, std::max(0.0, push - before) + std::min(before, kDepenetrationSpeed * dt));
                // The centre alone on a sphere: placed on the surface (the projection of earlier versions).
                if (centre && c.kind == scene::Collider::Kind::sphere && push == deepest.depth) y = pc.center + c.radius * deepest.normal;
                else y += push * deepest.normal;
                const Vec3 surface_velocity = c.velocity + c.angular_velocity.cross(y - pc.center);
                respond(v, surface_velocity, deepest.normal, c);
                ColliderContact& h = held[i];  // the first kSlots colliders (in scene order) that held it
                int slot = 0;
                while (slot < ColliderContact::kSlots - 1 && h.collider[slot] != ColliderContact::kNone) ++slot;
                if (h.collider[slot] == ColliderContact::kNone) {
                  h.collider[slot] = static_cast<std::int32_t>(k);
                  for (int a = 0; a < 3; ++a) h.normal[slot][a] = static_cast<float>(deepest.normal[a]);
                }
              }
            }, 2048);
          }};
}

}  // namespace perifx::systems
