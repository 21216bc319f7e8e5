// Surface frames system (contact geometry for the colliders, systems/README.md §8.3).
// A particle whose tet has original boundary faces meets a collider with those triangles
// (WorldState::surface), not only with its centre. For the faces to follow a piece that
// turns or stretches, each such particle near a collider keeps the deformation of its family,
//   K = Σ ω ξ⊗ξ V_j,  N = Σ ω η⊗ξ V_j  (alive bonds, family_sums),  F = N K⁻¹,
// the fit mesh_vertices.cpp places the rendered surface with: F itself when the family fits and F is
// well conditioned, its rotation when F is badly stretched or inverted, and, when the family does not
// fit (fewer than 4 alive bonds or K singular), the rotation the rendered mesh holds for the particle
// (EmbeddedMesh::held_deformation, mesh_rotations.cpp, as of the last step), or zero (the face then
// only moves with the particle) where it holds none. Before the held rotation took part, debris of one
// or a few tets met the ground with its faces in their reference orientation while the renderer drew
// them turned, and sank up to 2 cm into it (the bunny preview's last frame).
// The colliders of the next step place each face corner X at y + F·(X − x).
// Why at the end of the step, not in the colliders: the colliders move particles while they run, so
// a neighbour's position read there would race; and in a distributed run the ghosts' positions are
// current at the end of the step (after halo_motion), not before it. The frame lags by one step, a
// change of F of order dt·|∇v|.
// Held while touching: a particle whose faces touch a collider (within a step's motion of it plus
// 2 % of its reach, so one that hovers at the surface is not refitted at each lift-off) keeps the
// frame it touched with, until the fit moves more than kHoldTolerance from it. Refitting every
// step made the faces follow the neighbours' positions, so each push-out moved the faces the next
// push-out met: a follower load that does work the velocity never sees, and a ball resting on the
// ground kept moving (its energy of motion fell 13× over 0.1 s where the damping alone gives 55×,
// and a rounder ball spun up in place). A held frame is contact geometry fixed to the particle while
// it touches, as a centre is; a piece that turns or stretches while touching is refitted past the
// tolerance, and every piece is refitted as it comes in.
// Crack faces (WorldState::openable_faces, in a breakable world): the faces of a particle's tet whose
// bond to the tet across broke are written to ParticleState::open_faces here, from the bonds at the
// end of the step, and count as faces below (so a piece lying on a crack face is framed too).
// Which particles: those with a face whose farthest corner could reach a collider
// (√12·|X − x|, ‖F‖ ≤ √12 for a conditioned F) plus one step of the particle's and the
// collider's motion (a margin of 2×); the others get zero and cost nothing but the distance test.
// Reads: time, position, velocity, acceleration, bond_alive, surface_frames (the held frame), mesh
// (the held rotations, written later in the step by mesh_rotations: last step's).
// Writes: surface_frames (the frames and the open crack faces).
// Parallel over particles, each frame written by its own particle's task: deterministic.
#include <cmath>

#include "collider_shapes.hpp"
#include "parallel.hpp"
#include "systems.hpp"

namespace perifx::systems {
namespace {

// ‖F‖₂ ≤ ‖F‖_F ≤ √12 for a conditioned F (deformation_conditioned), and 1 for its rotation.
constexpr double kMaxStretch = 3.4641016151377544;
// A touching particle's frame is refitted only when the fit has moved this far from it (Frobenius
// norm; a turn of about 4°, or a 10 % stretch). Measured on the resting-ball test
// (tests/systems/test_colliders.cpp, the cut 12-cell ball): 0.05 kept the ball moving with one
// release distance and not with another (its energy of motion fell 1.2× or 55× over 0.1 s), never
// refitting left it falling only 13–17×; 0.1 decayed 43–72× (the damping gives 55×) on every mesh
// and release distance tried (0.001, 0.02, 0.05 of the reach).
constexpr double kHoldTolerance = 0.1;

}  // namespace

void update_surface_frames(WorldState& w) {
  auto& frames = w.state.surface_frame;
  if (frames.empty()) return;
  const SurfacePatches& sf = w.surface;
  const auto& p = w.particles;
  const double dt = w.clock.dt;
  const double t = w.clock.time + dt;  // where this step's colliders were
  std::vector<PlacedCollider> placed;  // a handful; outside the particle loop
  placed.reserve(w.settings.colliders.size());
  for (const auto& c : w.settings.colliders) placed.push_back(place_collider(c, t));
  const OpenableFaces& openable = w.openable_faces;
  const auto& held_rotation = w.embedded.held_deformation;  // the rendered mesh's frame (mesh_rotations.cpp)
  const auto& tracked = w.embedded.held_tracked;
  auto& open_faces = w.state.open_faces;
  parallel_for_each(p.count(), [&](std::size_t i) {
    Eigen::Matrix3f& out = frames[i];
    const Eigen::Matrix3f held = out;
    out.setZero();
    if (!open_faces.empty()) open_faces[i] = 0;
    if (!w.owns(i)) return;  // a ghost: its owner computes its frame
    // The crack faces open now (their bonds broke by the end of this step), met like boundary faces.
    const std::uint8_t open = open_faces.empty() ? 0 : open_crack_faces(openable, w.bonds, i);
    if (!open_faces.empty()) open_faces[i] = open;
    const std::uint32_t face_begin = sf.offsets[i], face_end = sf.offsets[i + 1];
    double reach = -1.0;  // over the corners, not the faces: a crack face's corners are its tet's
    for (std::uint32_t q = face_begin; q < face_end; ++q)
      if (sf.radius[q] > 0.0)
        for (const Vec3& corner : sf.corner[q]) reach = std::max(reach, kMaxStretch * corner.norm());
    if (open)
      for (const auto& corner : openable.corner[i]) reach = std::max(reach, kMaxStretch * double(corner.norm()));
    if (reach < 0.0) return;  // no faces (or only load shares)
    const double motion = dt * (p.velocity[i].norm() + dt * p.acceleration[i].norm());
    bool near = false, touching = false;
    const Mat3 F_held = held.cast<double>();
    const bool was_held = !held.isZero(0.0f);
    for (const PlacedCollider& pc : placed) {
      const scene::Collider& c = *pc.spec;
      const double arm = (p.position[i] - pc.center).norm();
      const double collider_motion = dt * (c.velocity.norm() + c.angular_velocity.norm() * arm);
      const double margin = 2.0 * (motion + collider_motion);
      if (collider_distance(pc, p.position[i]) < reach + margin) near = true;
      if (was_held && near && !touching)
        for_each_contact_face(sf, face_begin, face_end, openable, i, open, [&](const std::array<Vec3, 3>& corner, const Vec3&) {
          if (face_penetration(pc, p.position[i], &F_held, corner).depth > -(margin + 0.02 * reach)) touching = true;
        });
    }
    if (!near) return;
    Mat3 K, N, F;
    const std::uint32_t alive = family_sums(w, i, true, K, N);
    const bool fitted = fitted_deformation(K, N, alive, F);
    if (touching && (!fitted || (F - F_held).norm() <= kHoldTolerance)) out = held;
    else if (fitted) out = F.cast<float>();
    else if (tracked.size() == p.count() && held_rotation.size() == p.count() && tracked[i])
      out = held_rotation[i].cast<float>();
  }, 1024);
}

SystemDecl surface_frame_system(WorldState& w) {
  return {"surface_frames",
          {Component::time, Component::position, Component::velocity, Component::acceleration, Component::bond_alive,
           Component::surface_frames, Component::mesh},
          {Component::surface_frames},
          [&w] { update_surface_frames(w); }};
}

}  // namespace perifx::systems
