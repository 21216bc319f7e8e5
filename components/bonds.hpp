// Bonds in compressed sparse rows. Bond k in [offsets[i], offsets[i+1]) is the directed bond i→j with
// j = neighbor[k]; every bond i→j has its mirror j→i at reverse[k]. Neighbours of a particle are
// sorted by index, so sums over a family always run in the same order (bit-identical results).
#pragma once
#include <vector>

#include "components/math.hpp"

namespace perifx {

struct Bonds {
  std::vector<std::uint32_t> offsets;        // length particles + 1
  std::vector<std::uint32_t> neighbor;       // length bonds: j
  std::vector<std::uint32_t> reverse;        // length bonds: index of the mirror bond j→i
  std::vector<double> reference_length;      // |ξ| = |x_j − x_i|, m (double: rigid motion must give e = 0)
  std::vector<double> weight;                // ω_ij = δ_i/|G_i ξ| (Eq 5, 17), dimensionless
  std::vector<std::uint8_t> alive;           // 1 while the bond holds, 0 once broken (never heals)
  std::vector<double> plastic_extension;     // e^p_ij, m (Eq 11–16), state of particle i on bond i→j
  // e^p_ji on slot k: a copy of plastic_extension[reverse[k]], kept equal bit for bit because both
  // particles update both sides of the bond with the same operations (systems/bond_rules.hpp). It lets
  // the force and fracture passes read the mirror side's plastic extension as a stream instead of a
  // gather through `reverse`, and lets each particle update its own slots in place.
  std::vector<double> plastic_extension_mirror;
  std::vector<std::uint32_t> initial_count;  // N_i per particle (Eq 19)
  // Per-bond multiplier of the break threshold (weak planes, systems/strength_field.cpp); the same
  // number on k and reverse[k]. Length bonds whenever the world can fracture (1 where no plane).
  std::vector<float> break_scale;

  std::size_t count() const { return neighbor.size(); }
  std::size_t particle_count() const { return offsets.empty() ? 0 : offsets.size() - 1; }
};

}  // namespace perifx
