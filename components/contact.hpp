// Contact and rigid projectiles: plain data owned by the world (systems/contact.cpp and
// systems/projectiles.cpp read and write it; setup sizes every buffer once).
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "components/math.hpp"

namespace perifx {

// Particle–particle contact settings resolved at setup, and the spatial grid rebuilt every step.
// The grid is a hashed uniform grid: particle i lies in cell floor(y_i / cell); cells hash into
// `table` buckets (a power of two ≥ 2·particles) and a counting sort groups particles by bucket,
// in increasing index inside each bucket. Every buffer is sized at setup; a step never allocates.
struct ContactGrid {
  double cell = 0.0;                                 // cell edge, m (= the largest contact distance)
  std::uint32_t mask = 0;                            // table − 1
  std::vector<std::array<std::int32_t, 3>> cell_of;  // per particle: its cell
  std::vector<std::uint32_t> bucket;                 // per particle: hash of its cell
  std::vector<std::uint32_t> start;                  // table + 1: bucket b holds sorted[start[b], start[b+1])
  std::vector<std::uint32_t> cursor;                 // table: scatter cursor of the counting sort
  std::vector<std::uint32_t> sorted;                 // particle indices grouped by bucket
};

struct ContactState {
  bool enabled = false;          // particle–particle contact runs this world (scene "contact")
  double distance_factor = 0.9;  // d_c = factor·(s_i + s_j)/2,  s = ∛V
  double stiffness_factor = 0.05;// k = factor·min(m_i, m_j)/dt²
  double damping_ratio = 0.1;    // normal damping, fraction of critical for the pair spring
  double friction = 0.0;         // Coulomb coefficient
  std::vector<double> size;      // s_i = ∛V_i per particle, m
  ContactGrid grid;
};

// A rigid sphere with mass, integrated by the same velocity Verlet as the particles.
struct Projectile {
  double radius = 0.0;                 // m
  double mass = 0.0;                   // kg
  double inertia = 0.0;                // 2/5 m r², kg·m²
  double friction = 0.0;               // Coulomb coefficient against particles
  Vec3 center = Vec3::Zero();          // m
  Vec3 velocity = Vec3::Zero();        // m/s
  Vec3 angular_velocity = Vec3::Zero();// rad/s
  Vec3 acceleration = Vec3::Zero();    // m/s², from the last force evaluation
  Vec3 angular_acceleration = Vec3::Zero();  // rad/s²
  Vec3 contact_force = Vec3::Zero();   // N, −Σ of the forces it put on particles (last step)
};

struct ProjectileSet {
  std::vector<Projectile> bodies;
  // Per particle and projectile (index i·P + p): the force the projectile puts on particle i, N,
  // and its torque about the projectile's center (arm × (−f)), N·m. Sized at setup.
  std::vector<Vec3> particle_force;
  std::vector<Vec3> torque;
};

}  // namespace perifx
