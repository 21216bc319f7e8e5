// Integration systems: explicit velocity Verlet (kick–drift–kick), symplectic and second order.
//   kick_begin:  v ← v·exp(−c dt/2) + (dt/2) a        (free particles)
//   drift:       y ← y + dt v                          (all particles)
//   kick_end:    a ← F/m;  v ← v·exp(−c dt/2) + (dt/2) a   (free particles),
//                then, for a particle a collider held this step, v_n ← max(v_n, 0) relative to the
//                collider's surface (the support constraint, below)
// c is the material's mass-proportional damping rate (0 by default: undamped, energy-conserving).
// The velocity components a boundary condition prescribes this step (flags kPrescribed{X,Y,Z}) are
// not kicked: the boundary condition system owns them. A particle prescribed on some axes only (a
// roller) is kicked on the others.
// kick_begin  reads acceleration, flags; writes velocity.
// drift       reads velocity;            writes position.
// kick_end    reads internal_force, external_force, contact_force, flags, time, collider_contact;
//             writes velocity, acceleration.
//             Support constraint: the colliders project positions and velocities after the drift, so
//             the force of this step is kicked in after them. At a particle resting on a collider that
//             force is its support load, which the collider takes: kicked in, it left the particle
//             moving into the collider at (dt/2)|a| (3–4 mm/s at the bottom of a resting 12 cm box)
//             though it does not move, and every exported frame carried that velocity (motion blur,
//             velocity-driven effects). The part of the velocity moving into the colliders that held
//             the particle this step (ParticleState::collider_contact, up to three, each relative to
//             its surface velocity) is removed: the nearest velocity that moves into none of them
//             (held by two, as along the edge of a floor and a wall, that can be the motion along the
//             line where both surfaces meet); a particle moving away keeps all of its velocity.
//             It also checks every particle's new state (the step's health, part of velocity): a
//             non-finite position or velocity, or a free particle faster than settings.max_speed, is
//             recorded as the lowest such index in state.unstable_particle (an atomic minimum: the
//             same for any thread count; no cost beyond a compare while the run is healthy).
// (contact_force stays zero when neither contact nor projectiles run.)
#include <atomic>
#include <cmath>

#include "collider_shapes.hpp"
#include "parallel.hpp"
#include "field_registry.hpp"
#include "systems.hpp"

namespace perifx::systems {

SystemDecl kick_begin_system(WorldState& w) {
  return {"kick_begin", {Component::acceleration, Component::flags}, {Component::velocity}, [&w] {
            const double half = 0.5 * w.clock.dt;
            auto& p = w.particles;
            parallel_for_each(p.count(), [&](std::size_t i) {
              // Partly prescribed particles are kicked whole: the boundary condition system, which
              // runs next, writes their prescribed components over it.
              if ((p.flags[i] & kPrescribed) == kPrescribed) return;
              const double c = w.model.damping[i];
              const double decay = c > 0.0 ? std::exp(-c * half) : 1.0;
              p.velocity[i] = decay * p.velocity[i] + half * p.acceleration[i];
            }, 4096);
          }};
}

SystemDecl drift_system(WorldState& w) {
  return {"drift", {Component::velocity}, {Component::position}, [&w] {
            const double dt = w.clock.dt;
            auto& p = w.particles;
            parallel_for_each(p.count(), [&](std::size_t i) { p.position[i] += dt * p.velocity[i]; }, 4096);
          }};
}

namespace {
// The support constraint's inputs for particle i: its holding colliders' normals (as the colliders
// stored them, in float) and surface velocities at y, then the projection (collider_shapes.hpp).
Vec3 supported_velocity(const Vec3& v, const Vec3& y, const ColliderContact& held, const std::vector<PlacedCollider>& placed) {
  Vec3 n[ColliderContact::kSlots], surface[ColliderContact::kSlots];
  int count = 0;
  for (int c = 0; c < ColliderContact::kSlots && held.collider[c] != ColliderContact::kNone; ++c, ++count) {
    const PlacedCollider& pc = placed[static_cast<std::size_t>(held.collider[c])];
    n[c] = Vec3(held.normal[c][0], held.normal[c][1], held.normal[c][2]);
    surface[c] = pc.spec->velocity + pc.spec->angular_velocity.cross(y - pc.center);
  }
  return support_projection(v, n, surface, count);
}
}  // namespace

SystemDecl kick_end_system(WorldState& w) {
  return {"kick_end",
          {Component::internal_force, Component::external_force, Component::contact_force, Component::flags,
           Component::time, Component::collider_contact},
          {Component::velocity, Component::acceleration},
          [&w] {
            const double half = 0.5 * w.clock.dt;
            auto& p = w.particles;
            auto& s = w.state;
            // The colliders where the colliders system placed them this step (a handful; allocated
            // outside the particle loop, as there).
            std::vector<PlacedCollider> placed;
            if (!s.collider_contact.empty()) {
              placed.reserve(w.settings.colliders.size());
              for (const auto& c : w.settings.colliders) placed.push_back(place_collider(c, w.clock.time + w.clock.dt));
            }
            const double max_speed2 = w.settings.max_speed * w.settings.max_speed;
            s.unstable_particle = ParticleState::kAllStable;
            std::atomic_ref<std::uint64_t> unstable(s.unstable_particle);
            const auto report = [&](std::uint64_t i) {
              std::uint64_t seen = unstable.load(std::memory_order_relaxed);
              while (i < seen && !unstable.compare_exchange_weak(seen, i, std::memory_order_relaxed)) {
              }
            };
            parallel_for_each(p.count(), [&](std::size_t i) {
              const Vec3 a = (s.internal_force[i] + s.external_force[i] + s.contact_force[i]) / p.mass[i];
              p.acceleration[i] = a;
              const Vec3& y = p.position[i];
              const std::uint8_t prescribed = p.flags[i] & kPrescribed;
              if (prescribed == kPrescribed) {
                // The boundary condition owns this velocity: only finiteness is checked.
                const Vec3& v = p.velocity[i];
                if (!std::isfinite(y.x() + y.y() + y.z() + v.x() + v.y() + v.z())) report(i);
                return;
              }
              const double c = w.model.damping[i];
              const double decay = c > 0.0 ? std::exp(-c * half) : 1.0;
              Vec3 v = decay * p.velocity[i] + half * a;
              if (prescribed) {  // a roller: its prescribed components keep the condition's value
                for (int ax = 0; ax < 3; ++ax)
                  if (prescribed & (kPrescribedX << ax)) v[ax] = p.velocity[i][ax];
              }
              if (!placed.empty() && s.collider_contact[i].collider[0] != ColliderContact::kNone)
                v = supported_velocity(v, y, s.collider_contact[i], placed);
              p.velocity[i] = v;
              // NaN fails the comparison too; the position sum is finite unless a coordinate is not.
              if (!(v.squaredNorm() <= max_speed2) || !std::isfinite(y.x() + y.y() + y.z())) report(i);
            }, 4096);
          }};
}


void register_integration_fields(FieldRegistry& r) {
  r.push_back(make_field("position", FieldType::f64, 3, "m", "current position y",
                         [](WorldState& w, FieldView& v) { view_array(v, w.particles.position); }));
  r.push_back(make_field("velocity", FieldType::f64, 3, "m/s", "velocity",
                         [](WorldState& w, FieldView& v) { view_array(v, w.particles.velocity); }));
  r.push_back(make_field("displacement", FieldType::f64, 3, "m", "y − x", [](WorldState& w, FieldView& v) {
    const auto& p = w.particles;
    w.derived.displacement.resize(p.count());
    parallel_for_each(p.count(), [&](std::size_t i) { w.derived.displacement[i] = p.position[i] - p.reference_position[i]; });
    view_array(v, w.derived.displacement);
  }, true));
  r.push_back(make_field("acceleration", FieldType::f64, 3, "m/s^2", "acceleration from the last force evaluation",
                         [](WorldState& w, FieldView& v) { view_array(v, w.particles.acceleration); }));
}

}  // namespace perifx::systems
