// Plasticity system: Eq 11–16 with the consistent return of systems/README.md §3.
// Per directed alive bond k = i→j (e^p_ij is a state of particle i on that bond):
//   e, Λ   from the positions                                                   (Eq 7, bond_geometry)
//   A_dev  = ω_ij b4_i (e − β_i Λ θ_i − e^p_ij)  = 4 ω b (e^d − e^p)            (Eq 12, trial)
//   |A_dev| > A_c = √(2Ψ0):  e^p += (A_dev − A_c sign A_dev)/(ω_ij b4_i)        (Eq 13–15, consistent)
//   e^p   ← clamp(e^p, ±γ),  γ = plastic_cap·|ξ|                                (Eq 16)
// (plastic_return in bond_rules.hpp, which evaluates it divided through by ω b4). Particle i's loop
// updates both sides of its bond k: its own e^p_ij (plastic_extension[k]) and, with j's constants,
// e^p_ji (plastic_extension_mirror[k]); j's loop computes the same two numbers for its mirror slot,
// so the copies stay bit-identical and every slot is written only by its owner: in place, no
// atomics, independent of thread count. Ψ0 = ∞ never yields.
// Reads:  position, dilatation, plastic_extension, bond_alive.   Writes: plastic_extension.
// Not scheduled: bond_pass.cpp applies the same rule in its fused pass; this separate system (after
// dilatation, before elastic_force) is the tests' oracle for it.
#include "bond_rules.hpp"
#include "parallel.hpp"
#include "field_registry.hpp"
#include "systems.hpp"

namespace perifx::systems {
namespace {

template <bool kAnisotropic>
void plastic_pass(WorldState& w, const std::vector<Vec3>& y) {
  Bonds& b = w.bonds;
  const auto& x = w.particles.reference_position;
  parallel_for_each(w.particles.count(), [&](std::size_t i) {
    const Vec3 yi = y[i], xi = x[i];
    const SideConstants side_i = side_constants(w.model, w.state, i);
    const AnisotropyMetric& g_i = particle_metric(w.model.anisotropy_metric, i);
    for (std::uint32_t k = b.offsets[i], end = b.offsets[i + 1]; k < end; ++k) {
      if (!b.alive[k]) continue;
      const std::uint32_t j = b.neighbor[k];
      const Vec3 dxi = x[j] - xi;
      const double r = reference_length(dxi);
      BondGeometry g;
      if (!bond_geometry(y[j] - yi, dxi, r, g)) continue;
      const AnisotropyMetric& g_j = particle_metric(w.model.anisotropy_metric, j);
      const SideLengths weighted = side_lengths<kAnisotropic>(g_i, g_j, r, dxi.x(), dxi.y(), dxi.z());
      const SideConstants side_j = side_constants(w.model, w.state, j);
      // Stored as float (components/bonds.hpp); both ends round the same double.
      b.plastic_extension[k] = static_cast<float>(side_plastic_extension(g, r, weighted.ij, b.plastic_extension[k], side_i));
      b.plastic_extension_mirror[k] =
          static_cast<float>(side_plastic_extension(g, r, weighted.ji, b.plastic_extension_mirror[k], side_j));
    }
  }, 256);
}

}  // namespace

void update_plastic_extension(WorldState& w, const std::vector<Vec3>& y) {
  dispatch_flags([&](auto aniso) { plastic_pass<decltype(aniso)::value>(w, y); }, w.any_anisotropic);
}

SystemDecl plasticity_system(WorldState& w) {
  return {"plasticity",
          {Component::position, Component::dilatation, Component::plastic_extension, Component::bond_alive},
          {Component::plastic_extension},
          [&w] { update_plastic_extension(w, w.particles.position); }};
}


void register_plasticity_fields(FieldRegistry& r) {
  r.push_back(make_field("plastic_strain", FieldType::f64, 1, "1", "mean |e^p|/|ξ| over alive bonds (Eq 11–16)",
                         [](WorldState& w, FieldView& v) {
    const Bonds& b = w.bonds;
    const std::size_t n = w.particles.count();
    w.derived.plastic_strain.assign(n, 0.0);
    if (b.plastic_extension.empty()) return view_array(v, w.derived.plastic_strain);  // no material yields
    parallel_for_each(n, [&](std::size_t i) {
      std::uint32_t alive = 0;
      double plastic = 0.0;
      for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k) {
        if (!b.alive[k]) continue;
        ++alive;
        plastic += std::abs(double(b.plastic_extension[k])) /
                   reference_length(w.particles.reference_position[b.neighbor[k]] - w.particles.reference_position[i]);
      }
      w.derived.plastic_strain[i] = alive ? plastic / double(alive) : 0.0;
    });
    view_array(v, w.derived.plastic_strain);
  }, true));
}

}  // namespace perifx::systems
