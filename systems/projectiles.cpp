// Rigid projectiles with mass (spheres), two-way coupled to the particles by a penalty contact.
// They use the same velocity Verlet as the particles:
//   projectile_drift:   v ← v + (dt/2) a,  ω ← ω + (dt/2) α,  c ← c + dt v        (with the particles' drift)
//   projectile_contact: forces, then a ← F/M + g,  α ← τ/I,  v ← v + (dt/2) a,  ω ← ω + (dt/2) α
// Contact: particle i is in contact with sphere (c, R) when |y_i − c| < R + d_c,i/2, with
// d_c,i = distance_factor·∛V_i (the particle's half of the particle–particle contact distance, so a
// sphere touches particles the way a body surface does). With n = (y_i − c)/|y_i − c|, penetration
// g = R + d_c,i/2 − |y_i − c| and the relative velocity of the particle against the sphere surface
// (v_s = v_c + ω × R n):
//   f_n = max(0, k g − c_d v_n),  k = stiffness_factor·m_i/dt²,  c_d = 2ζ√(k m_ip), m_ip = m_i M/(m_i + M)
//   friction f_t = min(μ f_n, ¼ m_ip |v_t|/dt) against the sliding,
// from the scene's contact settings (contact.cpp explains the stiffness choice; the law is
// contact_law.hpp, shared with particle–particle contact). The particle gets
// +f (added to contact_force); the projectile gets −Σ_i f_i and the torque Σ_i R n_i × (−f_i), summed
// serially in particle index order: deterministic, and momentum is exchanged exactly pair by pair.
// Projectiles do not touch each other or the kinematic colliders.
// projectile_drift    reads time;                               writes projectiles.
// projectile_contact  reads position, velocity, flags;           writes projectiles, contact_force.
#include <algorithm>
#include <cmath>

#include "contact_law.hpp"
#include "huge_pages.hpp"
#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {

void setup_projectiles(WorldState& w) {
  auto& set = w.projectiles;
  set.bodies.clear();
  for (const auto& sp : w.settings.projectiles) {
    Projectile pr;
    pr.radius = sp.radius;
    pr.mass = sp.mass;
    pr.inertia = 0.4 * sp.mass * sp.radius * sp.radius;
    pr.friction = sp.friction;
    pr.center = sp.center;
    pr.velocity = sp.velocity;
    pr.angular_velocity = sp.angular_velocity;
    pr.acceleration = w.settings.gravity;
    set.bodies.push_back(pr);
  }
  const std::size_t slots = w.particles.count() * set.bodies.size();
  // n × projectiles each (130 MB at 9e5 particles and 3 projectiles): cleared by all threads.
  assign_huge_pages(set.particle_force, slots, Vec3(Vec3::Zero()));
  assign_huge_pages(set.torque, slots, Vec3(Vec3::Zero()));
}

SystemDecl projectile_drift_system(WorldState& w) {
  return {"projectile_drift", {Component::time}, {Component::projectiles}, [&w] {
            const double dt = w.clock.dt, half = 0.5 * dt;
            for (auto& pr : w.projectiles.bodies) {
              pr.velocity += half * pr.acceleration;
              pr.angular_velocity += half * pr.angular_acceleration;
              pr.center += dt * pr.velocity;
            }
          }};
}

SystemDecl projectile_contact_system(WorldState& w) {
  return {"projectile_contact",
          {Component::position, Component::velocity, Component::flags},
          {Component::projectiles, Component::contact_force},
          [&w] {
            auto& set = w.projectiles;
            const auto& c = w.contact;
            const auto& p = w.particles;
            const std::size_t n = p.count(), np = set.bodies.size();
            const double dt = w.clock.dt, half = 0.5 * dt;
            const double inv_dt = 1.0 / dt, inv_dt2 = inv_dt * inv_dt;
            // Particle–particle contact wrote contact_force this step when it is on; otherwise it is ours.
            const bool add = c.enabled;
            parallel_for_each(n, [&](std::size_t i) {
              Vec3 total = Vec3::Zero();
              const Vec3 yi = p.position[i];
              const double mi = p.mass[i];
              const double reach = 0.5 * c.distance_factor * c.size[i];
              for (std::size_t k = 0; k < np; ++k) {
                const Projectile& pr = set.bodies[k];
                Vec3& f_out = set.particle_force[i * np + k];
                Vec3& t_out = set.torque[i * np + k];
                const Vec3 r = yi - pr.center;
                const double d2 = r.squaredNorm();
                const double contact = pr.radius + reach;
                if (d2 >= contact * contact) {
                  f_out = Vec3::Zero();
                  t_out = Vec3::Zero();
                  continue;
                }
                const double d = std::sqrt(d2);
                const Vec3 nrm = d > 0.0 ? Vec3(r / d) : Vec3(Vec3::UnitY());
                const Vec3 arm = pr.radius * nrm;
                const double m_pair = mi * pr.mass / (mi + pr.mass);
                const double kk = c.stiffness_factor * mi * inv_dt2;
                const Vec3 vrel = p.velocity[i] - (pr.velocity + pr.angular_velocity.cross(arm));
                const ContactForce cf =
                    contact_force(contact - d, nrm, vrel, kk, m_pair, c.damping_ratio, pr.friction, inv_dt);
                Vec3 f = cf.normal * nrm;
                if (cf.sliding) f -= cf.friction;
                f_out = f;
                t_out = arm.cross(Vec3(-f));
                total += f;
              }
              w.state.contact_force[i] = add ? Vec3(w.state.contact_force[i] + total) : total;
            }, 1024);
            for (std::size_t k = 0; k < np; ++k) {
              Projectile& pr = set.bodies[k];
              Vec3 force = Vec3::Zero(), torque = Vec3::Zero();
              for (std::size_t i = 0; i < n; ++i) {  // fixed order: deterministic
                force -= set.particle_force[i * np + k];
                torque += set.torque[i * np + k];
              }
              pr.contact_force = force;
              pr.acceleration = force / pr.mass + w.settings.gravity;
              pr.angular_acceleration = torque / pr.inertia;
              pr.velocity += half * pr.acceleration;
              pr.angular_velocity += half * pr.angular_acceleration;
            }
          }};
}

}  // namespace perifx::systems
