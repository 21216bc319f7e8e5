// Contact system: short-range repulsion between particles that are not joined by an alive bond
// (particles of different bodies, or fragments after fracture), the usual peridynamic practice
// (notes.md, "What the paper leaves out": contact).
//
// Pair (i, j), r = y_j − y_i, d = |r|, n = r/d, contact distance
//   d_c = distance_factor·(s_i + s_j)/2,  s = ∛V (a particle's size; ≈ the mean particle spacing),
// and for two particles of the same body d_c ≤ |x_j − x_i| too, so a broken bond's ends at their
// reference distance are not pushed apart. With penetration g = d_c − d > 0:
//   normal   f_n = max(0, k·g − c·v_n),  v_n = (v_j − v_i)·n,  c = 2ζ√(k·m_ij),  m_ij = m_i m_j/(m_i+m_j)
//   friction f_t = min(μ·f_n, ¼·m_ij·|v_t|/dt) along v_t = (v_j − v_i) − v_n n (Coulomb, capped so it
//            cannot reverse the relative sliding within one step)
//   force on i: −f_n n + f_t v_t/|v_t|.
// Stiffness: k = stiffness_factor·min(m_i, m_j)/dt². One contact spring alone then has
// ω²dt² = k/m_ij·dt² ≤ 2·stiffness_factor, so with the default 0.05 and the handful of contacts a
// surface particle has, contact adds only a small fraction to the (ω·dt)² ≤ 4 budget of the explicit
// step, whatever the material: it never forces a smaller time step. The price is that the contact
// is softer for larger dt (penetration under an impact at speed v is ≈ v·dt/√stiffness_factor).
//
// Neighbour search: a hashed uniform grid with cell = the largest d_c, rebuilt every step by a
// counting sort (stable: particles in a bucket stay in index order). Each particle gathers the
// forces on itself from its neighbours (no scatter, no atomics), visiting the 27 cells in a fixed
// order, so the result does not depend on the thread count. Every scalar of the pair term is
// symmetric in (i, j) and every vector flips sign exactly with r and v_j − v_i, so the force j
// computes on itself is bit-for-bit the negative of the one i computes: momentum is conserved.
// "Bonded": binary search of j in i's sorted neighbour list, then the alive flag.
//
// Reads: position, velocity, bond_alive.   Writes: contact_force.
#include <algorithm>
#include <cmath>

#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {
namespace {

using Cell = std::array<std::int32_t, 3>;

Cell cell_of(const Vec3& y, double inv_cell) {
  Cell c;
  for (int a = 0; a < 3; ++a) {
    // Clamp: a particle flung far away must not overflow int32 (it then shares a far cell; the
    // distance test still rejects every false neighbour).
    const double q = std::clamp(std::floor(y[a] * inv_cell), -1.0e9, 1.0e9);
    c[static_cast<std::size_t>(a)] = static_cast<std::int32_t>(q);
  }
  return c;
}

std::uint32_t hash_cell(const Cell& c, std::uint32_t mask) {
  const auto x = static_cast<std::uint32_t>(c[0]), y = static_cast<std::uint32_t>(c[1]),
             z = static_cast<std::uint32_t>(c[2]);
  return ((x * 73856093u) ^ (y * 19349663u) ^ (z * 83492791u)) & mask;
}

bool bonded(const Bonds& b, std::uint32_t i, std::uint32_t j) {
  const auto first = b.neighbor.begin() + b.offsets[i], last = b.neighbor.begin() + b.offsets[i + 1];
  const auto it = std::lower_bound(first, last, j);
  return it != last && *it == j && b.alive[static_cast<std::size_t>(it - b.neighbor.begin())];
}

}  // namespace

void setup_contact(WorldState& w) {
  const auto& sc = w.scene.contact;
  auto& c = w.contact;
  c.enabled = sc.mode == scene::Contact::Mode::on ||
              (sc.mode == scene::Contact::Mode::automatic && (w.bodies.size() >= 2 || w.any_fracture));
  c.distance_factor = sc.distance_factor;
  c.stiffness_factor = sc.stiffness_factor;
  c.damping_ratio = sc.damping_ratio;
  c.friction = sc.friction;
  const std::size_t n = w.particles.count();
  c.size.resize(n);
  double largest = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    c.size[i] = std::cbrt(w.particles.volume[i]);
    largest = std::max(largest, c.size[i]);
  }
  if (!c.enabled) return;
  auto& g = c.grid;
  g.cell = c.distance_factor * largest;
  std::uint32_t table = 1024;
  while (table < 2 * n) table <<= 1;
  g.mask = table - 1;
  g.cell_of.resize(n);
  g.bucket.resize(n);
  g.sorted.resize(n);
  g.start.assign(table + 1, 0);
  g.cursor.assign(table, 0);
}

SystemDecl contact_system(WorldState& w) {
  return {"contact", {Component::position, Component::velocity, Component::bond_alive}, {Component::contact_force}, [&w] {
            auto& c = w.contact;
            auto& g = c.grid;
            const auto& p = w.particles;
            const auto& b = w.bonds;
            const std::size_t n = p.count();
            const double inv_cell = 1.0 / g.cell;
            // 1. Cells and buckets (parallel), 2. counting sort (serial, stable, O(n + table)).
            parallel_for_each(n, [&](std::size_t i) {
              g.cell_of[i] = cell_of(p.position[i], inv_cell);
              g.bucket[i] = hash_cell(g.cell_of[i], g.mask);
            }, 4096);
            std::fill(g.start.begin(), g.start.end(), 0u);
            for (std::size_t i = 0; i < n; ++i) ++g.start[g.bucket[i] + 1];
            for (std::size_t k = 1; k < g.start.size(); ++k) g.start[k] += g.start[k - 1];
            std::copy(g.start.begin(), g.start.end() - 1, g.cursor.begin());
            for (std::size_t i = 0; i < n; ++i) g.sorted[g.cursor[g.bucket[i]]++] = static_cast<std::uint32_t>(i);

            // 3. Gather.
            const double inv_dt2 = 1.0 / (w.clock.dt * w.clock.dt);
            const double inv_dt = 1.0 / w.clock.dt;
            const double max_dc2 = g.cell * g.cell;
            parallel_for_each(n, [&](std::size_t ii) {
              const auto i = static_cast<std::uint32_t>(ii);
              const Vec3 yi = p.position[i], vi = p.velocity[i];
              const Cell ci = g.cell_of[i];
              Vec3 f = Vec3::Zero();
              for (int dz = -1; dz <= 1; ++dz)
                for (int dy = -1; dy <= 1; ++dy)
                  for (int dx = -1; dx <= 1; ++dx) {
                    const Cell cc = {ci[0] + dx, ci[1] + dy, ci[2] + dz};
                    const std::uint32_t bk = hash_cell(cc, g.mask);
                    for (std::uint32_t q = g.start[bk]; q < g.start[bk + 1]; ++q) {
                      const std::uint32_t j = g.sorted[q];
                      if (j == i || g.cell_of[j] != cc) continue;  // other cells hashed to this bucket
                      const Vec3 r = p.position[j] - yi;
                      const double d2 = r.squaredNorm();
                      if (d2 >= max_dc2) continue;
                      double dc = c.distance_factor * (0.5 * (c.size[i] + c.size[j]));
                      if (p.body_id[i] == p.body_id[j])
                        dc = std::min(dc, (p.reference_position[j] - p.reference_position[i]).norm());
                      if (d2 >= dc * dc || bonded(b, i, j)) continue;
                      const double d = std::sqrt(d2);
                      if (!(d > 0.0)) continue;  // coincident: no direction (never happens in practice)
                      const Vec3 nrm = r / d;
                      const double mi = p.mass[i], mj = p.mass[j];
                      const double m_pair = (mi * mj) / (mi + mj);
                      const double k = c.stiffness_factor * std::min(mi, mj) * inv_dt2;
                      const double damp = 2.0 * c.damping_ratio * std::sqrt(k * m_pair);
                      const Vec3 vrel = p.velocity[j] - vi;
                      const double vn = vrel.dot(nrm);
                      const double fn = std::max(0.0, k * (dc - d) - damp * vn);
                      f -= fn * nrm;
                      if (c.friction > 0.0) {
                        const Vec3 vt = vrel - vn * nrm;
                        const double vt_len = vt.norm();
                        if (vt_len > 0.0) {
                          const double ft = std::min(c.friction * fn, 0.25 * m_pair * vt_len * inv_dt);
                          f += (ft / vt_len) * vt;
                        }
                      }
                    }
                  }
              w.state.contact_force[i] = f;
            }, 256);
          }};
}

}  // namespace perifx::systems
