// Domain decomposition plan (engine/distributed/decomposition.hpp): the split and the ghost layers
// against brute force.
#include <doctest/doctest.h>

#include <algorithm>
#include <set>
#include <stdexcept>

#include "distributed/decomposition.hpp"
#include "support.hpp"
#include "systems/systems.hpp"

using namespace perifx;

namespace {

// Two boxes 4 mm apart (less than the contact reach), so ghosts come from bonds inside a box and
// from contact across the gap; the second box is finer, so the work per particle differs.
scene::Scene two_boxes() {
  auto sc = test::box_scene(Vec3(0.06, 0.04, 0.04), 0.01, 3e6, 2e6);
  sc.bodies[0].transform.translation = Vec3(-0.032, 0.0, 0.0);
  scene::Body b = sc.bodies[0];
  b.name = "right";
  b.geometry.size = Vec3(0.04, 0.04, 0.04);
  b.geometry.edge_length = 0.008;
  b.transform.translation = Vec3(0.022, 0.0, 0.0);
  sc.bodies.push_back(b);
  sc.contact.mode = scene::Contact::Mode::on;
  return sc;
}

}  // namespace

TEST_CASE("decomposition: contiguous domains of equal work, within one particle's work of the share") {
  World world(two_boxes());
  const WorldState& w = world.state();
  const std::size_t n = w.particles.count();
  std::uint64_t largest_particle = 0, total = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint64_t work = w.bonds.offsets[i + 1] - w.bonds.offsets[i] + distributed::kParticleWork;
    largest_particle = std::max(largest_particle, work);
    total += work;
  }
  for (int ranks : {1, 2, 3, 5, 8}) {
    const auto domains = distributed::split_by_work(w, ranks);
    REQUIRE(domains.size() == std::size_t(ranks));
    std::uint32_t next = 0;
    std::uint64_t summed = 0;
    for (const auto& d : domains) {
      CHECK(d.first == next);  // contiguous, in order, covering every particle once
      CHECK(d.last > d.first);
      next = d.last;
      summed += d.work;
      // Each cut lands on the first particle at or past its share, so a domain's work is off the
      // share by less than one particle's work at either end.
      CHECK(double(d.work) <= double(total) / ranks + 2.0 * double(largest_particle));
      CHECK(double(d.work) >= double(total) / ranks - 2.0 * double(largest_particle));
    }
    CHECK(next == n);
    CHECK(summed == total);
  }
  CHECK_THROWS_AS(distributed::split_by_work(w, 0), std::invalid_argument);
  CHECK_THROWS_AS(distributed::split_by_work(w, int(n) + 1), std::invalid_argument);
}

TEST_CASE("decomposition: each rank's ghosts are exactly the far ends of its bonds and the particles in contact reach") {
  World world(two_boxes());
  WorldState& w = world.state_mutable();
  REQUIRE(w.contact.enabled);
  // Move the particles off the lattice a little, so the contact test sees real current positions.
  for (std::size_t i = 0; i < w.particles.count(); ++i)
    w.particles.position[i] += 1e-3 * Vec3(std::sin(1.3 * double(i)), std::cos(0.7 * double(i)), std::sin(2.1 * double(i)));
  const std::size_t n = w.particles.count();
  const double reach = w.contact.largest_distance + w.contact.pairs.skin;
  std::uint64_t contact_ghosts_seen = 0, bond_ghosts_seen = 0;
  for (int ranks : {2, 3, 4}) {
    const auto domains = distributed::decompose(w, ranks);
    for (std::size_t r = 0; r < domains.size(); ++r) {
      const auto& d = domains[r];
      auto owned = [&](std::size_t j) { return j >= d.first && j < d.last; };
      std::set<std::uint32_t> by_bond, by_contact;
      for (std::uint32_t i = d.first; i < d.last; ++i) {
        for (std::uint32_t k = w.bonds.offsets[i]; k < w.bonds.offsets[i + 1]; ++k)
          if (!owned(w.bonds.neighbor[k])) by_bond.insert(w.bonds.neighbor[k]);
        for (std::uint32_t j = 0; j < n; ++j)
          if (!owned(j) && (w.particles.position[j] - w.particles.position[i]).norm() < reach) by_contact.insert(j);
      }
      std::set<std::uint32_t> all = by_bond;
      all.insert(by_contact.begin(), by_contact.end());
      CHECK(std::vector<std::uint32_t>(all.begin(), all.end()) == d.ghosts);
      CHECK(d.bond_ghosts == by_bond.size());
      CHECK(d.contact_ghosts == all.size() - by_bond.size());
      CHECK(d.halo_bytes_per_step == d.ghosts.size() * distributed::kGhostBytesPerStep);
      std::set<std::uint32_t> ranks_read;
      for (std::uint32_t j : d.ghosts)
        for (std::size_t s = 0; s < domains.size(); ++s)
          if (j >= domains[s].first && j < domains[s].last) ranks_read.insert(std::uint32_t(s));
      CHECK(std::vector<std::uint32_t>(ranks_read.begin(), ranks_read.end()) == d.neighbor_ranks);
      contact_ghosts_seen += d.contact_ghosts;
      bond_ghosts_seen += d.bond_ghosts;
    }
  }
  CHECK(contact_ghosts_seen > 0);  // the gap between the boxes is crossed by contact reach only
  CHECK(bond_ghosts_seen > 0);
}

TEST_CASE("decomposition: the public plan matches the internal one") {
  World world(two_boxes());
  const auto internal = distributed::decompose(world.state(), 3);
  const auto plan = world.decompose(3);
  REQUIRE(plan.size() == 3);
  for (std::size_t r = 0; r < 3; ++r) {
    CHECK(plan[r].first_particle == internal[r].first);
    CHECK(plan[r].particle_count == internal[r].last - internal[r].first);
    CHECK(plan[r].ghosts == internal[r].ghosts.size());
    CHECK(plan[r].halo_bytes_per_step == internal[r].halo_bytes_per_step);
  }
}

TEST_CASE("decomposition: a re-balance weighs the held rotations of damaged particles") {
  // A box with an embedded mesh (its held rotations are stepped for particles with a broken bond):
  // every other bond of the first half of the particles broken. current_work gives those particles
  // their alive bonds plus alive/kHeldRotationDivisor, so an equal-work split of two ranks gives the
  // damaged rank fewer particles than it would if held rotations cost nothing.
  auto sc = test::box_scene(Vec3(0.08, 0.04, 0.04), 0.01, 3e6, 2e6);
  sc.output.obj = true;
  World world(sc);
  WorldState& w = world.state_mutable();
  const std::uint32_t n = static_cast<std::uint32_t>(w.particles.count());
  for (std::uint32_t i = 0; i < n / 2; ++i)
    for (std::uint32_t k = w.bonds.offsets[i]; k < w.bonds.offsets[i + 1]; k += 2) w.bonds.alive[k] = 0;
  systems::init_held_rotations(w);
  REQUIRE(w.embedded.held_tracked.size() == n);
  const auto work = distributed::current_work(w, 0, n);
  std::uint32_t tracked = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    std::uint32_t alive = 0;
    for (std::uint32_t k = w.bonds.offsets[i]; k < w.bonds.offsets[i + 1]; ++k) alive += w.bonds.alive[k];
    const std::uint32_t base = alive + std::uint32_t(distributed::kParticleWork);  // contact is off here
    CHECK(work[i] == base + (w.embedded.held_tracked[i] ? alive / distributed::kHeldRotationDivisor : 0u));
    tracked += w.embedded.held_tracked[i];
  }
  CHECK(tracked == n / 2);  // the particles with a broken bond
  const auto weighted = distributed::split_by_work(work, 2);
  std::fill(w.embedded.held_tracked.begin(), w.embedded.held_tracked.end(), std::uint8_t{0});
  const auto unweighted = distributed::split_by_work(distributed::current_work(w, 0, n), 2);
  MESSAGE("rank 0 owns " << weighted[0].last << " of " << n << " particles (" << unweighted[0].last
                         << " without the held rotations' cost)");
  CHECK(weighted[0].last < unweighted[0].last);
}

TEST_CASE("decomposition: FEM ranks own vertices; their ghosts are the other vertices of their tets") {
  // FEM mode has no bonds: a vertex's force sums the corner forces of the tets at it, so a rank needs
  // the motion of every vertex of those tets; the work counts the corners. Against brute force over
  // every tet.
  auto sc = test::box_scene(Vec3(0.12, 0.06, 0.04), 0.01, 3e6, 2e6);
  sc.solver = scene::Solver::fem_corotated;
  World world(sc);
  const WorldState& w = world.state();
  REQUIRE(w.bonds.count() == 0);
  const std::size_t n = w.particles.count();
  for (int ranks : {2, 3, 5}) {
    CAPTURE(ranks);
    const auto domains = distributed::decompose(w, ranks);
    std::uint64_t corners = 0;
    for (const auto& d : domains) {
      std::uint64_t mine = 0;
      for (std::uint32_t i = d.first; i < d.last; ++i) mine += w.fem.vertex_offsets[i + 1] - w.fem.vertex_offsets[i];
      CHECK(d.work == mine + distributed::kParticleWork * (d.last - d.first));
      corners += mine;
      std::set<std::uint32_t> expected;
      for (const auto& tet : w.mesh.tets) {
        const bool touches = std::any_of(tet.begin(), tet.end(), [&](std::uint32_t v) { return v >= d.first && v < d.last; });
        if (touches)
          for (std::uint32_t v : tet)
            if (v < d.first || v >= d.last) expected.insert(v);
      }
      CHECK(d.ghosts == std::vector<std::uint32_t>(expected.begin(), expected.end()));
      CHECK(d.bond_ghosts == expected.size());
      CHECK(d.halo_bytes_per_step == expected.size() * distributed::kFemGhostBytesPerStep);
    }
    CHECK(corners == 4 * w.mesh.tets.size());
    CHECK(domains.back().last == n);
  }
}
