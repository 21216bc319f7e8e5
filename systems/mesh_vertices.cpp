// Mesh vertices system (paper Eq 20–22, systems/README.md §6.5): moves the embedded mesh's vertices
// with the particles, after mesh_split, so every vertex copy follows only its own tet group.
//   VertexMotion::deformation (default): per particle p, over its alive bonds j (ξ = x_j − x_p,
//     η = y_j − y_p, ω the influence weight, V_j the volume), in the neighbour list's fixed order:
//     the family's affine least-squares fit η ≈ c_p + F_p ξ, v_j − v_p ≈ ċ_p + Ḟ_p ξ (weights ω V_j,
//     sums about the family's weighted centre, affine_family_fit; y_p and v_p cancel), then once more
//     with each weight times s²|ξ|² / (s²|ξ|² + |η − c_p − F_p ξ|²), s = 1/4 (a bond far off the
//     family's motion weighs less); p's vertices are placed from o_p = y_p + c_p, the fit's value at p.
//     Through y_p (K = Σ ω ξ⊗ξ V_j, F_p = (Σ ω η⊗ξ V_j) K⁻¹, as until 2026-12-06) a particle jostled
//     off its family's motion (an impact's contact layer) carried its tet's vertices with it, and a
//     neighbour hanging on by a stretched bond tilted F_p (the finer fig16 preview: 27 triangles
//     stretched past the particles around; with the fit, 8). The reweighting keeps such a neighbour
//     from moving the centred fit's origin. A family too flat about its centre keeps the fit through y_p.
//     F_p is used when p has ≥ 4 alive bonds, K is well conditioned (‖K‖‖K⁻¹‖ ≤ 1e4, Frobenius) and
//     F_p is well conditioned (det > 0, ‖F‖², ‖F⁻¹‖² ≤ 12, i.e. no stretch beyond ~3.5×). Where it is
//     not (a remnant family: < 8 alive bonds, or < 1/8 of the original ones; too few bonds; a badly
//     stretched or inverted fit), F_p is the mesh ring's affine fit (ring_fit below: p and the tets
//     sharing a vertex with p's tet, placed from the fit's value o_p at p instead of y_p) when that is
//     well conditioned, and counts as fitted. Else a badly stretched or inverted F_p, or one fitted to a
//     remnant family, is replaced by its own rotation; with too few bonds or K
//     ill-conditioned, F_p ← the particle's held rotation, which is step state kept by the
//     mesh_rotations system (mesh_rotations.cpp): every step, the rotation of N + μ R_old (R_old: the
//     rotation of the last step, μ = 1e-3 tr K), i.e. the rotation that best maps the few alive bonds,
//     the last rotation filling what they leave free (a lone particle keeps its last rotation; two
//     bonded particles turn with their bond). Ḟ_p ← 0 in both. A vertex v with tet group G
//     (the tets that currently hold v; tet t is particle t), weights w_t = c_t m_t / Σ_G c m:
//       x_v = Σ w_t (o_t + F_t (X_v − x_t)),   v_v = Σ w_t (ȯ_t + Ḟ_t (X_v − x_t))   (o_t, ȯ_t the
//       value at t of the fit that gave F_t and Ḟ_t; y_t, v_t for a fallback rotation),
//     c_t = 1 where F_t is t's own fitted gradient and 1e-3 where it is a fallback rotation, so a
//     poorly bonded particle inside a piece follows its fitted neighbours at shared vertices rather
//     than pulling them apart (its tet would otherwise stretch far more than the particles around it).
//     Then render components (tets joined through shared vertices) of at most 8 tets are placed
//     rigidly instead, or by their best-fit affine map when their particles have moved apart
//     (rigid_small_components below), so debris cannot turn inside out.
//     Rigid and affine motion with full families give F exact to round-off, so x_v is exact; a vertex
//     is a convex combination of its group's predictions, each within |F_t| |X_v − x_t| (≤ ~3.5 tet
//     sizes) of its particle, so it never extrapolates away from its group.
//   VertexMotion::paper (Eq 20–22 as written): v_v = Σ_t (m_t/4) v_t / Σ_t (m_t/4) over the tets t
//     that currently hold v, then x_v += dt·v_v (v_t: end-of-step particle velocities).
//     Exact for translation; for a rotation the explicit update leaves the circle (radius grows by
//     ~½(ω dt)² per step) and boundary vertices, whose tet star is lopsided, turn with the star's
//     centroid rather than with themselves. Measured in tests/systems/test_embedded_mesh.cpp.
//   VertexMotion::embedded: x_v = X_v + Σ_p w_vp (y_p − x_p), v_v = Σ_p w_vp v_p with the affine-fit
//     weights of systems/embedded_mesh.cpp (fixed at setup/split; extrapolates once the support
//     particles separate, kept for comparison).
// In the step graph the deformation mode does nothing here (mesh_rotations keeps the held rotations):
// the engine evaluates it when the mesh is read (World::surface, World::tet_mesh), so its cost is per
// output frame, not per step. The evaluation is a pure function of the state: it writes only F_p, Ḟ_p
// and the vertex positions and velocities, which nothing else reads, so reading the mesh twice gives
// the same bits and does not change the run.
// Parallel over particles, then over vertices, each element written by one task: deterministic.
// Reads:  position, velocity, bond_alive, mesh (held rotations).
// Writes: mesh (F, Ḟ, vertex positions and velocities: derived, not state, in the deformation mode).
#include <algorithm>

#include "bond_rules.hpp"
#include "parallel.hpp"
#include "systems.hpp"
#include "union_find.hpp"

namespace perifx::systems {

namespace {

// Weight (relative to its mass) of a tet whose particle's F_p is a fallback rotation, where it shares
// a vertex with tets that have their own fitted F: the fitted neighbours place the vertex, so a
// poorly bonded particle's rotation cannot pull its tet's vertices apart from theirs.
constexpr double kFallbackWeight = 1e-3;
constexpr std::uint32_t kRemnantBonds = 8;

// The mass-weighted least-squares affine map of a set of particles, y ≈ ȳ + F (x − x̄) with F = A S⁻¹
// (and v ≈ v̄ + Ḟ (x − x̄), Ḟ = Ȧ S⁻¹), for the mesh ring's fit and the small render components.
// `for_each(f)` calls f(t) for every member in a fixed order, twice (the centres, then the moments
// about them); a member visited k times weighs k times its mass.
struct ParticleSetFit {
  double mass = 0.0;
  std::uint32_t count = 0;  // visits
  Vec3 xbar = Vec3::Zero(), ybar = Vec3::Zero(), vbar = Vec3::Zero();
  Mat3 S = Mat3::Zero();     // Σ m (x − x̄)(x − x̄)ᵀ
  Mat3 A = Mat3::Zero();     // Σ m (y − ȳ)(x − x̄)ᵀ
  Mat3 Adot = Mat3::Zero();  // Σ m (v − v̄)(x − x̄)ᵀ
};
template <class ForEach>
ParticleSetFit particle_set_fit(const WorldState& w, ForEach&& for_each) {
  const auto& x = w.particles.reference_position;
  const auto& y = w.particles.position;
  const auto& vel = w.particles.velocity;
  const auto& mass = w.particles.mass;
  ParticleSetFit fit;
  for_each([&](std::uint32_t t) {
    fit.mass += mass[t];
    fit.xbar += mass[t] * x[t];
    fit.ybar += mass[t] * y[t];
    fit.vbar += mass[t] * vel[t];
    ++fit.count;
  });
  if (!(fit.mass > 0.0)) return fit;
  fit.xbar /= fit.mass;
  fit.ybar /= fit.mass;
  fit.vbar /= fit.mass;
  for_each([&](std::uint32_t t) {
    const Vec3 d = x[t] - fit.xbar;
    fit.S += mass[t] * d * d.transpose();
    fit.A += mass[t] * (y[t] - fit.ybar) * d.transpose();
    fit.Adot += mass[t] * (vel[t] - fit.vbar) * d.transpose();
  });
  return fit;
}

// The mesh ring's fit, for a particle whose own bonds cannot give F_p (a remnant family, or too few
// bonds): the least-squares affine map of p and the particles of the tets that share a vertex with p's
// tet in the current (split) mesh (each counted once per shared vertex, weighed by its mass; p itself
// once: without it a ring on one side of p's tet, as at the edge of a tear, extrapolated to the tet's
// free vertex with a 2.75× stretch, fig01 ductile walls):
//   x̄, ȳ, v̄ the weighted centres, S = Σ m (x − x̄)⊗(x − x̄), F = Σ m (y − ȳ)⊗(x − x̄) S⁻¹,
//   Ḟ = Σ m (v − v̄)⊗(x − x̄) S⁻¹, and p's vertices are placed from o_p = ȳ + F (x_p − x̄) (the fit's
//   value at p) instead of y_p, moving with ȯ_p = v̄ + Ḟ (x_p − x̄).
// The rendered surface is continuous over exactly those tets, so p's vertices move as they do. Taking
// p's tet rotation only, or fitting around y_p (a particle held by a few bonds lags its ring), pulled a
// short edge between p's tet and a stretched neighbourhood to 3–4.5× where the particles around had
// stretched 2× (fig01 ductile walls, showcase: check-surface counted it). False (nothing written) when
// the ring is too small or ill-conditioned (family_fits) or F fails deformation_conditioned.
bool ring_fit(WorldState& w, std::size_t p) {
  EmbeddedMesh& e = w.embedded;
  if (p >= e.tets.size()) return false;
  // p, and every tet of the ring once per vertex it shares with p's tet.
  const ParticleSetFit fit = particle_set_fit(w, [&](auto&& f) {
    f(static_cast<std::uint32_t>(p));
    for (const std::uint32_t v : e.tets[p])
      for_each_holding_tet(e, v, [&](std::uint32_t t, std::uint32_t) {
        if (t != p) f(t);
      });
  });
  if (!(fit.mass > 0.0) || !family_fits(fit.S, fit.count - 1)) return false;  // p and at least 4 more
  const Mat3 Sinv = fit.S.inverse();
  const Mat3 F = fit.A * Sinv;
  if (!deformation_conditioned(F)) return false;
  const Vec3 d = w.particles.reference_position[p] - fit.xbar;
  e.deformation[p] = F;
  e.deformation_rate[p] = fit.Adot * Sinv;
  e.deformation_origin[p] = fit.ybar + F * d;
  e.deformation_origin_velocity[p] = fit.vbar + e.deformation_rate[p] * d;
  e.deformation_fitted[p] = 1;
  return true;
}

// The family's affine least-squares fit η ≈ c + F ξ, v_j − v_p ≈ ċ + Ḟ ξ (weights ω V; F_p and its
// origin): the sums about the family's weighted centre ξ̄ = Σ ω V ξ / Σ ω V (η̄, v̄ likewise),
//   F = (N − W η̄ ξ̄ᵀ) K_c⁻¹,  Ḟ = (Ṅ − W v̄ ξ̄ᵀ) K_c⁻¹,  K_c = K − W ξ̄ ξ̄ᵀ,  c = η̄ − F ξ̄,  ċ = v̄ − Ḟ ξ̄,
// in which y_p and v_p cancel. False when the family is too flat about its centre (family_fits).
struct AffineFamilyFit {
  Mat3 gradient, rate;
  Vec3 offset, offset_rate;
};
bool affine_family_fit(const Mat3& K, const Mat3& N, const Mat3& Nd, const FamilyMoments& mo, std::uint32_t alive,
                       AffineFamilyFit& fit) {
  const double W = mo.weight;
  if (!(W > 0.0)) return false;
  const Vec3 xi_c = mo.xi / W, eta_c = mo.eta / W, vel_c = mo.velocity / W;
  const Mat3 Kc = K - W * xi_c * xi_c.transpose();
  if (!family_fits(Kc, alive)) return false;
  const Mat3 Kinv = Kc.inverse();
  fit.gradient = (N - W * eta_c * xi_c.transpose()) * Kinv;
  fit.rate = (Nd - W * vel_c * xi_c.transpose()) * Kinv;
  fit.offset = eta_c - fit.gradient * xi_c;
  fit.offset_rate = vel_c - fit.rate * xi_c;
  return true;
}

// F_p and Ḟ_p of one particle (see the header comment). A pure function of the state: the fallback
// reads the held rotation that the mesh_rotations system keeps current every step.
void particle_deformation(WorldState& w, std::size_t p) {
  EmbeddedMesh& e = w.embedded;
  Mat3 K, N, Nd;
  FamilyMoments moments;
  const std::uint32_t alive = family_sums(w, p, true, K, N, &Nd, &moments);
  Mat3& F = e.deformation[p];
  Mat3& Fd = e.deformation_rate[p];
  e.deformation_fitted[p] = 0;
  e.deformation_origin[p] = w.particles.position[p];
  e.deformation_origin_velocity[p] = w.particles.velocity[p];
  if (family_fits(K, alive)) {
    // A remnant family (fewer than kRemnantBonds alive, or under 1/kRemnantBonds of those it started with)
    // gives a fit ruled by its last few bonds: in a ductile tear they are the drawn-out ligament, and F read
    // 2.7–3.0× along it where the particles around had stretched 1.2–1.8× (fig05 and fig01 ductile previews,
    // families of 5 of 93 and 5 of 103 bonds; check-surface flagged their triangles). Its tet then takes the
    // fit's rotation only, as a badly stretched fit does.
    const auto& initial = w.bonds.initial_count;
    const bool remnant = alive < kRemnantBonds || (p < initial.size() && std::uint64_t{kRemnantBonds} * alive < initial[p]);
    AffineFamilyFit fit;
    const bool affine = affine_family_fit(K, N, Nd, moments, alive, fit);
    if (affine && !remnant) {
      // Once more with each bond's weight lowered by how far it lies off that fit (robust_residual_scale),
      // so that one neighbour off the family's motion (hanging on by a stretched bond, or jostled at an
      // impact) cannot move p's vertices with it.
      const FamilyFit prior{fit.offset, fit.gradient};
      Mat3 K2, N2, Nd2;
      FamilyMoments moments2;
      family_sums(w, p, true, K2, N2, &Nd2, &moments2, &prior);
      AffineFamilyFit reweighted;
      if (affine_family_fit(K2, N2, Nd2, moments2, alive, reweighted) && deformation_conditioned(reweighted.gradient))
        fit = reweighted;
    }
    const Mat3 Fnew = affine ? fit.gradient : Mat3(N * K.inverse());
    if (!remnant && deformation_conditioned(Fnew)) {
      F = Fnew;
      e.deformation_fitted[p] = 1;
      if (affine) {
        Fd = fit.rate;
        e.deformation_origin[p] += fit.offset;
        e.deformation_origin_velocity[p] += fit.offset_rate;
      } else {  // a family too flat about its centre: the fit through y_p
        Fd = Nd * K.inverse();
      }
      return;
    }
    if (ring_fit(w, p)) return;
    F = polar_rotation(Fnew);  // badly stretched or inverted: its rotation only
    Fd.setZero();
    return;
  }
  if (ring_fit(w, p)) return;
  // Too few bonds or K ill-conditioned: the held rotation of the last step (mesh_rotations.cpp: the
  // regularized-Kabsch rotation that best maps the alive bonds, the previous rotation filling what
  // they leave free).
  F = e.held_deformation[p];
  Fd.setZero();
}

// Render components (tets joined through shared vertices) of at most kRigidComponentTets tets move
// rigidly with their particles: x_v = ȳ + R (X_v − x̄), R the rotation of
//   A = Σ m_t (y_t − ȳ)(x_t − x̄)ᵀ + μ Σ m_t R_t,  μ = 1e-3 tr(Σ m_t (x_t − x̄)(x_t − x̄)ᵀ) / Σ m_t
// (R_t the rotation of F_t: the particles' own rotations fill what their positions leave free; a lone
// tet turns with R_t), x̄, ȳ the mass-weighted reference and current centres. A few tets whose
// particles are strongly and unevenly deformed (ductile debris held by longer bonds) would otherwise
// mix inconsistent per-particle predictions at their shared vertices and could turn inside out; a
// rigid copy cannot. Only components whose particles hold together (each within the component's
// reference radius of its rigid prediction; for a single tet always) are placed rigidly; the others,
// if at least 4 particles span them, by their best-fit affine map x_v = ȳ + F (X_v − x̄),
// F = A S⁻¹, S = Σ m_t (x_t − x̄)(x_t − x̄)ᵀ, used when it passes F_p's test (det > 0,
// ‖F‖², ‖F⁻¹‖² ≤ 12), rigidly otherwise: every small component is placed by one map with det > 0,
// which keeps every tet positive. (Until 2026-12-06 a fit with det > 0 that failed the test had its
// principal stretches clamped to [½, 2]; in a sliver of debris drawn out 4× and thinned to 0.3× the
// clamped map pushed a vertex a horizon away from every particle of its piece: showcase, check-surface.)
// Velocities go with the placement: the affine map's v̄ + Ḟ (X_v − x̄), Ḟ = Ȧ S⁻¹, or the rigid
// body's v̄ + ω × (x_v − ȳ), ω = I⁻¹ L of the particles about ȳ (angular_velocity); a single tet keeps
// the vertex pass's values. Until 2026-12-06 they kept the vertex pass's values, which for debris of
// fallback rotations (Ḟ = 0) carried the translation but not the spin. Serial, in tet order:
// deterministic.
constexpr std::uint32_t kRigidComponentTets = 8;

void rigid_small_components(WorldState& w) {
  EmbeddedMesh& e = w.embedded;
  const auto& x = w.particles.reference_position;
  const auto& y = w.particles.position;
  const auto& vel = w.particles.velocity;
  const auto& mass = w.particles.mass;
  const std::size_t nt = e.tets.size();
  constexpr std::uint32_t kNone = 0xFFFFFFFFu;
  std::vector<std::uint32_t> parent, first(e.vertices.size(), kNone);
  UnionFind sets(parent, nt);
  for (std::uint32_t t = 0; t < nt; ++t)
    for (std::uint32_t v : e.tets[t]) {
      if (first[v] == kNone) first[v] = t;
      else sets.unite(first[v], t);
    }
  sets.flatten();  // parent[t]: the smallest tet of t's component
  auto find = [&](std::uint32_t t) { return parent[t]; };
  std::vector<std::uint32_t> size(nt, 0);
  for (std::uint32_t t = 0; t < nt; ++t) ++size[find(t)];
  // Small components' tets, grouped by root (roots in increasing order).
  std::vector<std::pair<std::uint32_t, std::uint32_t>> small;  // (root, tet)
  for (std::uint32_t t = 0; t < nt; ++t)
    if (const std::uint32_t r = find(t); size[r] <= kRigidComponentTets) small.push_back({r, t});
  std::sort(small.begin(), small.end());
  std::vector<std::uint32_t> seen(e.vertices.size(), kNone);
  for (std::size_t a = 0; a < small.size();) {
    std::size_t b = a;
    while (b < small.size() && small[b].first == small[a].first) ++b;
    const ParticleSetFit fit = particle_set_fit(w, [&](auto&& f) {
      for (std::size_t k = a; k < b; ++k) f(small[k].second);
    });
    if (fit.mass > 0.0) {
      const double M = fit.mass;
      Vec3 xbar = fit.xbar, ybar = fit.ybar;
      const Mat3& A = fit.A;
      const Mat3& S = fit.S;
      Mat3 held = Mat3::Zero();
      for (std::size_t k = a; k < b; ++k) held += mass[small[k].second] * polar_rotation(e.deformation[small[k].second]);
      const double spread = S.trace();
      // One tet: its own rotation, its own centre (round-off in x̄ must not make A a random rank-1 term).
      const bool single = b - a == 1;
      if (single) xbar = x[small[a].second], ybar = y[small[a].second];
      const Mat3 R = polar_rotation(single ? held : Mat3(A + (1e-3 * spread / M) * held));
      // Only a component whose particles still hold together: every particle within the component's
      // reference radius of its rigid prediction. Otherwise (particles flying apart around a vertex
      // they still share) the per-particle placement stays.
      double radius = 0.0, residual = 0.0;
      for (std::size_t k = a; k < b; ++k) {
        const std::uint32_t t = small[k].second;
        radius = std::max(radius, (x[t] - xbar).norm());
        residual = std::max(residual, (y[t] - ybar - R * (x[t] - xbar)).norm());
      }
      // Particles that have moved apart (the plastically stretched bonds of ductile debris): the
      // component's best-fit affine map F = A S⁻¹ instead, when at least four particles span it and
      // it is bounded as F_p is; else the rigid placement. One map with det F > 0 cannot turn a tet
      // inside out, where mixing the particles' own predictions at shared vertices can.
      Mat3 F = R;
      bool affine = false;
      if (residual > radius && b - a >= 4 && family_fits(S, static_cast<std::uint32_t>(b - a))) {
        const Mat3 fitted = A * S.inverse();
        if (deformation_conditioned(fitted)) F = fitted, affine = true;
      }
      // Vertex velocities that go with the placement (motion blur of spinning debris): the affine
      // map's, v̄ + Ḟ (X − x̄) with Ḟ = Ȧ S⁻¹, or the rigid body's, v̄ + ω × (x_v − ȳ) with ω = I⁻¹ L of
      // the particles about ȳ. A single tet keeps its own (v_t + Ḟ_t (X − x_t), from the vertex pass):
      // one particle cannot tell its spin.
      Mat3 rate = Mat3::Zero();
      Vec3 spin = Vec3::Zero();
      if (affine) {
        rate = fit.Adot * S.inverse();
      } else if (!single) {
        Mat3 inertia = Mat3::Zero();
        Vec3 momentum = Vec3::Zero();
        for (std::size_t k = a; k < b; ++k) {
          const std::uint32_t t = small[k].second;
          const Vec3 r = y[t] - ybar;
          inertia += mass[t] * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
          momentum += mass[t] * r.cross(vel[t] - fit.vbar);
        }
        spin = angular_velocity(inertia, momentum);
      }
      for (std::size_t k = a; k < b; ++k)
        for (std::uint32_t v : e.tets[small[k].second]) {
          if (seen[v] == small[a].first) continue;
          seen[v] = small[a].first;
          e.vertices[v] = ybar + F * (e.reference_vertices[v] - xbar);
          if (affine) e.vertex_velocity[v] = fit.vbar + rate * (e.reference_vertices[v] - xbar);
          else if (!single) e.vertex_velocity[v] = fit.vbar + spin.cross(e.vertices[v] - ybar);
        }
    }
    a = b;
  }
}

}  // namespace

namespace {
// The held rotations (step state of the mesh_rotations system), made at set-up by start_mesh_vertices;
// the guard covers a world whose mesh is read without it.
void ensure_held_rotations(WorldState& w) {
  if (w.embedded.held_deformation.size() != w.particles.count()) init_held_rotations(w);
}

// The deformation motion's per-particle and per-vertex arrays (sized, not computed; their first
// evaluation writes every element).
void size_deformation_arrays(WorldState& w) {
  EmbeddedMesh& e = w.embedded;
  const std::size_t np = w.particles.count();
  ensure_held_rotations(w);
  e.deformation.resize(np);
  e.deformation_rate.resize(np);
  e.deformation_fitted.resize(np);
  e.deformation_origin.resize(np);
  e.deformation_origin_velocity.resize(np);
  e.vertex_anchored.resize(e.vertices.size());
}
}  // namespace

void start_mesh_vertices(WorldState& w) {
  // The deformation motion is a pure function of the state, evaluated when the mesh is read
  // (World::tet_mesh, World::surface); evaluating it here, with y = x, only reproduced the reference
  // vertices to round-off, at 18 % of a 9e5-particle set-up's CPU time (one fit per particle). Its
  // per-particle arrays are sized then too, by their first evaluation, which writes every element: a
  // run that never reads the mesh keeps them empty, so its checkpoints hold no uninitialized bytes
  // (sized here and never written, they differed between two runs of the same scene), and set-up
  // does not first-touch their ~190 B per particle.
  if (w.embedded.motion == VertexMotion::deformation) ensure_held_rotations(w);
  else update_mesh_vertices(w, 0.0);
}

void update_mesh_vertices(WorldState& w, double dt) {
  EmbeddedMesh& e = w.embedded;
  const auto& y = w.particles.position;
  const auto& x = w.particles.reference_position;
  const auto& vel = w.particles.velocity;
  if (e.motion == VertexMotion::deformation) {
    const std::size_t np = w.particles.count();
    size_deformation_arrays(w);
    parallel_for_each(np, [&](std::size_t p) { particle_deformation(w, p); }, 256);
    const auto& mass = w.particles.mass;
    parallel_for_each(e.vertices.size(), [&](std::size_t v) {
      const Vec3 X = e.reference_vertices[v];
      Vec3 pos = Vec3::Zero(), vv = Vec3::Zero();
      double m = 0.0;
      std::uint8_t fitted = 0;  // some tet of the group has its own fitted F
      std::uint32_t group = 0;
      for_each_holding_tet(e, static_cast<std::uint32_t>(v), [&](std::uint32_t t, std::uint32_t) {
        fitted |= e.deformation_fitted[t];
        ++group;
        const Vec3 d = X - x[t];
        const double wt = e.deformation_fitted[t] ? mass[t] : kFallbackWeight * mass[t];
        pos += wt * (e.deformation_origin[t] + e.deformation[t] * d);
        vv += wt * (e.deformation_origin_velocity[t] + e.deformation_rate[t] * d);
        m += wt;
      });
      if (m > 0.0) {
        e.vertices[v] = pos / m;
        e.vertex_velocity[v] = vv / m;
      }
      e.vertex_anchored[v] = fitted && group >= 2;
    }, 1024);
    // Loose vertices: held only by fallback tets, or by one tet alone. A loose vertex's tet that also
    // holds anchored vertices (a group of two or more tets with a fitted F) hangs from them:
    // x_v = ā_t + G_t (X_v − Ā_t) (ā_t, Ā_t: current and reference centre of t's anchored vertices),
    // G_t = F_t for a fitted tet, else the rotation of Σ (a_u − ā)(A_u − Ā)ᵀ + μ F_t,
    // μ = 1e-3 Σ |A_u − Ā|² (the rotation that best maps the anchors, t's own rotation filling what
    // they leave free; F_t with one anchor). Without this the vertex follows t's particle, which can
    // be off from where the tets around place the anchors: a particle hanging on by a few stretched
    // bonds, or a fitted particle whose F disagrees with its neighbours' across a plastic zone; its tet
    // then stretched up to 5× between them (showcase, fig05; `check-surface` counted it). Hanging keeps
    // the tet's own shape. Reads only anchored vertices, writes only loose ones: parallel, deterministic.
    parallel_for_each(e.vertices.size(), [&](std::size_t v) {
      if (e.vertex_anchored[v]) return;
      const Vec3 X = e.reference_vertices[v];
      Vec3 pos = Vec3::Zero();
      double m = 0.0;
      bool hangs = false;
      for_each_holding_tet(e, static_cast<std::uint32_t>(v), [&](std::uint32_t t, std::uint32_t) {
        Vec3 a = Vec3::Zero(), A = Vec3::Zero();
        int anchors = 0;
        for (std::uint32_t u : e.tets[t])
          if (e.vertex_anchored[u]) a += e.vertices[u], A += e.reference_vertices[u], ++anchors;
        if (anchors > 0) {
          a /= anchors;
          A /= anchors;
          // The rotation that best maps the anchors, F_t filling what they leave free.
          Mat3 H = Mat3::Zero();
          double spread = 0.0;
          for (std::uint32_t u : e.tets[t])
            if (e.vertex_anchored[u]) {
              H += (e.vertices[u] - a) * (e.reference_vertices[u] - A).transpose();
              spread += (e.reference_vertices[u] - A).squaredNorm();
            }
          const Mat3 G = e.deformation_fitted[t] || anchors == 1
                             ? e.deformation[t]
                             : polar_rotation(Mat3(H + 1e-3 * spread * e.deformation[t]));
          pos += mass[t] * (a + G * (X - A));
          hangs = true;
        } else {
          pos += mass[t] * (e.deformation_origin[t] + e.deformation[t] * (X - x[t]));
        }
        m += mass[t];
      });
      if (hangs && m > 0.0) e.vertices[v] = pos / m;
    }, 1024);
    rigid_small_components(w);
    return;
  }
  if (e.motion == VertexMotion::embedded) {
    ensure_vertex_weights(w);
    parallel_for_each(e.vertices.size(), [&](std::size_t v) {
      Vec3 u = Vec3::Zero(), vv = Vec3::Zero();
      for (std::uint32_t q = e.weight_rows[v][0]; q < e.weight_rows[v][1]; ++q) {
        const std::uint32_t p = e.weight_particle[q];
        u += e.weight_value[q] * (y[p] - x[p]);
        vv += e.weight_value[q] * vel[p];
      }
      e.vertices[v] = e.reference_vertices[v] + u;
      e.vertex_velocity[v] = vv;
    }, 1024);
    return;
  }
  const auto& mass = w.particles.mass;
  parallel_for_each(e.vertices.size(), [&](std::size_t v) {
    Vec3 momentum = Vec3::Zero();
    double m = 0.0;
    for_each_holding_tet(e, static_cast<std::uint32_t>(v), [&](std::uint32_t t, std::uint32_t) {
      momentum += 0.25 * mass[t] * vel[t];  // Eq 20: each tet contributes m_t/4
      m += 0.25 * mass[t];
    });
    if (m > 0.0) e.vertex_velocity[v] = momentum / m;  // Eq 21
    e.vertices[v] += dt * e.vertex_velocity[v];        // Eq 22
  }, 1024);
}

SystemDecl mesh_vertex_system(WorldState& w) {
  return {"mesh_vertices", {Component::position, Component::velocity, Component::bond_alive, Component::mesh},
          {Component::mesh},
          [&w] {
            // VertexMotion::deformation places vertices from the current state alone, so it is evaluated
            // on demand (World::surface, World::tet_mesh: once per output frame) rather than every step;
            // the paper's Eq 22 integrates and must run every step.
            if (w.embedded.motion != VertexMotion::deformation) update_mesh_vertices(w, w.clock.dt);
          }};
}

}  // namespace perifx::systems
