// Rigid projectiles with mass (spheres), two-way coupled to the particles by a penalty contact.
// They use the same velocity Verlet as the particles:
//   projectile_drift:   v ← v + (dt/2) a,  ω ← ω + (dt/2) α,  c ← c + dt v        (with the particles' drift)
//   projectile_contact: forces, then a ← F/M + g,  α ← τ/I,  v ← v + (dt/2) a,  ω ← ω + (dt/2) α
// Contact: particle i is in contact with sphere (c, R) when |y_i − c| < R + d_c,i/2, with
// d_c,i = distance_factor·∛V_i (the particle's half of the particle–particle contact distance, so a
// sphere touches particles the way a body surface does): penetration g = R + d_c,i/2 − |y_i − c|
// along n = (y_i − c)/|y_i − c|. A particle whose tet has original boundary faces is also touched
// through each, a disc moved with the particle's displacement (WorldState::surface, set up as the
// surface loads' patches; the disc covers the face):
// g = R − |p − c| along n = (p − c)/|p − c|, p the disc's point nearest c, when c is outside the face.
// The deeper of the two counts, except that the sphere of reach is left out while the sphere's centre
// is outside one of the particle's faces (the face is then the body's surface there, and the sphere of
// reach, whose radius does not depend on how deep the centroid lies, can reach past it). Why: the particle's sphere of reach lies a resolution-dependent
// distance inside or outside the body's surface, and under the sphere's pole the nearest particle can
// be half a cell off to the side, so a coarse body was first touched later than a fine one (the glass
// walls' 0.05 m preview 33 µs later than the full scene at 60 m/s, 2 mm of travel; accuracy.md 12.5).
// The discs cover the mesh surface, so an intact flat face is touched when the sphere reaches it, at
// any resolution. A rotated piece's disc is only translated, not turned: off by at most the tet's
// size, the error the sphere of reach has anyway. With the relative velocity of the particle against
// the sphere surface (v_s = v_c + ω × R n):
//   f_n = max(0, k g − c_d v_n),  k = stiffness_factor·m_i/max(τ, dt)²,  c_d = 2ζ√(k m_ip), m_ip = m_i M/(m_i + M)
//   friction f_t = min(μ f_n, ¼ m_ip |v_t|/dt) against the sliding,
// from the scene's contact settings (contact.cpp explains the stiffness choice; the law is
// contact_law.hpp, shared with particle–particle contact). The particle gets
// +f (added to contact_force); the projectile gets −Σ_i f_i and the torque Σ_i R n_i × (−f_i), summed
// serially in particle index order over the touching particles (ProjectileSet::contacts): deterministic,
// and momentum is exchanged exactly pair by pair. A distributed run computes the owned particles'
// contacts on each rank and sums every rank's list in rank order (the `gather` hook), the same order.
// Projectiles do not touch each other or the kinematic colliders.
// projectile_drift    reads time;                               writes projectiles.
// projectile_contact  reads position, velocity, flags;           writes projectiles, contact_force.
// (Static set-up data also read: mass, contact size, the surface patches.)
#include <algorithm>
#include <cmath>
#include <functional>

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
  resize_projectiles(w);
}

void resize_projectiles(WorldState& w) {
  auto& set = w.projectiles;
  const std::size_t n = set.bodies.empty() ? 0 : w.particles.count();
  // Each block's list is reserved for 64 touching particles, so a step rarely grows one.
  const std::size_t blocks = (n + ProjectileSet::kBlock - 1) / ProjectileSet::kBlock;
  set.block_contacts.resize(blocks);
  for (auto& block : set.block_contacts) {
    block.clear();
    block.reserve(64 * 6 * set.bodies.size());
  }
  set.contacts.clear();
  set.contacts.reserve(std::min<std::size_t>(n, 4096) * 6 * set.bodies.size());
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

SystemDecl projectile_contact_system(WorldState& w, const std::function<void(std::vector<double>&)>* gather) {
  return {"projectile_contact",
          {Component::position, Component::velocity, Component::flags},
          {Component::projectiles, Component::contact_force},
          [&w, gather] {
            auto& set = w.projectiles;
            const auto& c = w.contact;
            const auto& p = w.particles;
            const std::size_t n = p.count(), np = set.bodies.size();
            const double dt = w.clock.dt, half = 0.5 * dt;
            const double inv_dt = 1.0 / dt, per_mass = contact_stiffness_per_mass(c.time_scale, dt);
            // Particle–particle contact wrote contact_force this step when it is on; otherwise it is ours.
            const bool add = c.enabled;
            const SurfacePatches& sf = w.surface;
            const bool faces = w.settings.solver == scene::Solver::peridynamics && !sf.radius.empty();
            // By fixed blocks of particles (ProjectileSet::kBlock), each block's touching particles
            // appended to its own list in index order: the joined lists are in particle index order
            // for any thread count.
            const std::size_t blocks = set.block_contacts.size();
            parallel_for_each(blocks, [&](std::size_t b) {
              std::vector<double>& out = set.block_contacts[b];
              out.clear();
              for (std::size_t i = b * ProjectileSet::kBlock, end = std::min(n, (b + 1) * ProjectileSet::kBlock);
                   i < end; ++i) {
                if (!w.owns(i)) continue;  // a ghost: its owner computes its contacts
                const Vec3 yi = p.position[i];
                const double reach = 0.5 * c.distance_factor * c.size[i];
                // i's boundary faces (none for interior particles, and none in FEM worlds).
                std::uint32_t face_begin = 0, face_end = 0;
                double far = reach;
                if (faces) {
                  face_begin = sf.offsets[i];
                  face_end = sf.offsets[i + 1];
                  for (std::uint32_t q = face_begin; q < face_end; ++q)
                    far = std::max(far, sf.offset[q].norm() + sf.radius[q]);
                }
                bool near = false;  // within some projectile's bound: the only particles that can touch
                for (std::size_t k = 0; k < np; ++k) {
                  const double bound = set.bodies[k].radius + far;
                  near = near || (yi - set.bodies[k].center).squaredNorm() < bound * bound;
                }
                if (!near) {  // as a touch-free particle below (+ 0.0 turns a −0.0 into +0.0)
                  w.state.contact_force[i] = add ? Vec3(w.state.contact_force[i] + Vec3::Zero()) : Vec3(Vec3::Zero());
                  continue;
                }
                const std::size_t mark = out.size();
                out.resize(mark + 6 * np, 0.0);
                Vec3 total = Vec3::Zero();
                const double mi = p.mass[i];
                bool touched = false;
                for (std::size_t k = 0; k < np; ++k) {
                  const Projectile& pr = set.bodies[k];
                  const Vec3 r = yi - pr.center;
                  const double d2 = r.squaredNorm();
                  const double contact = pr.radius + reach;
                  const double bound = pr.radius + far;
                  if (d2 >= bound * bound) continue;
                  // The particle's boundary faces (discs, moved with the particle's displacement), then
                  // its sphere of reach: the deepest penetration, along its direction.
                  double penetration = 0.0;
                  Vec3 nrm = Vec3::UnitY();
                  bool outside_a_face = false;
                  for (std::uint32_t q = face_begin; q < face_end; ++q) {
                    const double radius = sf.radius[q];
                    if (radius == 0.0) continue;  // a layer share of a traction, not a face
                    const Vec3 centre = yi + sf.offset[q];
                    const Vec3& normal = sf.normal[q];
                    const Vec3 rel = pr.center - centre;
                    const double height = rel.dot(normal);
                    if (!(height > 0.0)) continue;  // the sphere's centre is not outside the face
                    outside_a_face = true;
                    Vec3 lateral = rel - height * normal;
                    const double spread = lateral.norm();
                    if (spread > radius) lateral *= radius / spread;
                    const Vec3 to_face = centre + lateral - pr.center;  // sphere centre → nearest disc point
                    const double gap = to_face.norm();
                    if (pr.radius - gap > penetration && gap > 0.0) {
                      penetration = pr.radius - gap;
                      nrm = to_face / gap;
                    }
                  }
                  // The sphere of reach only where no face of the particle stands between it and the
                  // projectile: seen from outside a face, the face is the body's surface, and the sphere
                  // of reach can reach past it (by 2.8 mm on the 5 cm cells of the fig07 preview, which
                  // then broke 43 % earlier than its final).
                  if (!outside_a_face && d2 < contact * contact) {
                    const double d = std::sqrt(d2);
                    if (contact - d > penetration) {
                      penetration = contact - d;
                      nrm = d > 0.0 ? Vec3(r / d) : Vec3(Vec3::UnitY());
                    }
                  }
                  if (!(penetration > 0.0)) continue;
                  const Vec3 arm = pr.radius * nrm;
                  const double m_pair = mi * pr.mass / (mi + pr.mass);
                  const double kk = c.stiffness_factor * mi * per_mass;
                  const Vec3 vrel = p.velocity[i] - (pr.velocity + pr.angular_velocity.cross(arm));
                  const ContactForce cf =
                      contact_force(penetration, nrm, vrel, kk, m_pair, c.damping_ratio, pr.friction, inv_dt);
                  Vec3 f = cf.normal * nrm;
                  if (cf.sliding) f -= cf.friction;
                  const Vec3 t = arm.cross(Vec3(-f));
                  double* slot = out.data() + mark + 6 * k;
                  slot[0] = f.x(), slot[1] = f.y(), slot[2] = f.z(), slot[3] = t.x(), slot[4] = t.y(), slot[5] = t.z();
                  total += f;
                  touched = true;
                }
                if (!touched) out.resize(mark);  // particles that touch nothing would add exact zeros
                w.state.contact_force[i] = add ? Vec3(w.state.contact_force[i] + total) : total;
              }
            }, 1);
            set.contacts.clear();
            for (const auto& block : set.block_contacts) set.contacts.insert(set.contacts.end(), block.begin(), block.end());
            if (gather && *gather) (*gather)(set.contacts);  // every rank's list, in rank order
            const std::size_t entries = set.contacts.size() / (6 * std::max<std::size_t>(np, 1));
            for (std::size_t k = 0; k < np; ++k) {
              Projectile& pr = set.bodies[k];
              Vec3 force = Vec3::Zero(), torque = Vec3::Zero();
              for (std::size_t e = 0; e < entries; ++e) {  // fixed order: deterministic
                const double* c6 = set.contacts.data() + (e * np + k) * 6;
                force -= Vec3(c6[0], c6[1], c6[2]);
                torque += Vec3(c6[3], c6[4], c6[5]);
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
