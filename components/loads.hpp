// External loads as plain data (systems/external_loads.cpp, systems/README.md §8.6): the bodies'
// boundary split into surface patches, and each scene load's particles and patches, found once at
// setup on the reference configuration (engine/setup/loads.cpp), so the step only walks index lists.
#pragma once
#include <cstdint>
#include <array>
#include <vector>

#include "components/math.hpp"
#include "perifx/scene.hpp"

namespace perifx {

// The boundary faces of the reference tet mesh, as patches owned by particles, CSR by particle.
// Peridynamics: a boundary face is one patch of its tet's particle. FEM (particles = vertices): each
// face gives one patch per corner, a third of its area; a traction with a depth adds layer shares.
// Built when a surface load, a projectile or a collider needs them (empty otherwise): the loads push
// on them, and projectiles and colliders meet a body's surface at its faces (systems/projectiles.cpp,
// systems/colliders.cpp).
struct SurfacePatches {
  std::vector<std::uint32_t> offsets;  // particle count + 1; patches of i: [offsets[i], offsets[i+1])
  std::vector<double> area;            // m²
  std::vector<Vec3> normal;            // outward unit normal (reference orientation)
  std::vector<Vec3> offset;            // patch point − particle reference position, m (the load is
                                       // evaluated at current position + offset)
  std::vector<double> radius;          // a whole face of a peridynamic body: its largest centroid-to-
                                       // corner distance, m (a disc around the point that covers the
                                       // face); 0 for the FEM corner thirds and the layer shares
  std::vector<std::array<Vec3, 3>> corner;  // a whole face: its corners − particle reference position, m
                                            // (the colliders' contact geometry); zero where radius is 0
};

// The faces of each particle's tet that a crack may open, for the colliders (systems/colliders.cpp,
// systems/README.md §8.3): a body broken on the ground rests on its crack faces as it does on its
// original surface. Per particle (= tet), only in peridynamic worlds with colliders that can break
// (empty otherwise); built at set-up (engine/setup/loads.cpp, resolve_openable_faces).
//   corner[i][c]:    the tet's corner c − the particle's reference position, m (float: contact
//                    geometry only, placed to ~1e-7 of a tet size); face k is the triangle opposite k.
//   bond_slot[i][k]: where, in particle i's bond row, its bond to the tet across face k is (bonds.neighbor
//                    [offsets[i] + slot]): face k is an open crack face while that bond is broken.
//                    kBoundary for an original boundary face (SurfacePatches has it) or a row too long
//                    to index; kAlwaysOpen for a face-adjacent tet without a bond (an initial crack).
// Rows are never reordered, only sliced whole (distributed local worlds), so a slot stays valid.
struct OpenableFaces {
  static constexpr std::uint16_t kBoundary = 0xFFFF;
  static constexpr std::uint16_t kAlwaysOpen = 0xFFFE;
  std::vector<std::array<Eigen::Vector3f, 4>> corner;
  std::vector<std::array<std::uint16_t, 4>> bond_slot;
};

// The scene's loads, each with the particles it acts on (sorted) and, for surface loads, the
// patches of each of those particles it acts on (CSR over `particles`).
struct LoadSet {
  std::vector<scene::Load> loads;
  std::vector<std::vector<std::uint32_t>> particles;      // per load
  std::vector<std::vector<std::uint32_t>> patch_offsets;  // per load: particles.size() + 1 (surface loads)
  std::vector<std::vector<std::uint32_t>> patches;        // per load: indices into SurfacePatches
};

}  // namespace perifx
