// Bonds in compressed sparse rows. Bond k in [offsets[i], offsets[i+1]) is the directed bond i→j with
// j = neighbor[k]. Neighbours of a particle are sorted by index, so sums over a family always run in
// the same order (bit-identical results), and the mirror bond j→i is found by a binary search in j's
// row (systems::mirror_bond, setup and tests only: the step never needs it).
//
// What a bond stores is only its state (issue 16: bytes per directed bond): the neighbour (4 B), the
// alive flag (1 B) and, when some material can yield, e^p on both sides (2 × 4 B). The reference
// length |ξ| = |x_j − x_i| and the weight ω_ij = δ_i/|G_i ξ| (Eq 5, 17) are functions of the reference
// positions and per-particle constants; the kernels recompute them (systems/bond_rules.hpp,
// reference_length and weighted_length) instead of streaming 16 B per bond from memory.
#pragma once
#include <vector>

#include "components/math.hpp"

namespace perifx {

struct Bonds {
  std::vector<std::uint32_t> offsets;        // length particles + 1
  std::vector<std::uint32_t> neighbor;       // length bonds: j
  std::vector<std::uint8_t> alive;           // 1 while the bond holds, 0 once broken (never heals)
  // e^p_ij, m (Eq 11–16), state of particle i on bond i→j; empty when no material can yield. float:
  // 7 significant digits of a plastic extension are far below what the yield and break tests resolve
  // (systems/README.md §3 says which tests bound it); both ends round the same double to the same float.
  std::vector<float> plastic_extension;
  // e^p_ji on slot k: a copy of the mirror slot's e^p, kept equal bit for bit because both particles
  // update both sides of the bond with the same operations (systems/bond_rules.hpp). It lets the force
  // and fracture passes read the mirror side's plastic extension as a stream instead of a gather, and
  // lets each particle update its own slots in place.
  std::vector<float> plastic_extension_mirror;
  std::vector<std::uint32_t> initial_count;  // N_i per particle (Eq 19)
  // Per-bond multiplier of the break threshold (weak planes, systems/strength_field.cpp); the same
  // number on both directions of a bond. Length bonds when a weak plane cuts some bond, else empty (1).
  std::vector<float> break_scale;

  std::size_t count() const { return neighbor.size(); }
  std::size_t particle_count() const { return offsets.empty() ? 0 : offsets.size() - 1; }
};

}  // namespace perifx
