// The scene spec table, the validator that walks JSON against it, and the markdown reference
// generated from it. Adding a key means adding one line to build_spec() (and reading it in
// load.cpp); its checks, default, error messages and documentation all follow from that line.
#include "scene/schema.hpp"

#include <algorithm>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <sstream>

#include "perifx/scene.hpp"
#include "scene/presets.hpp"
#include "systems/field_registry.hpp"

namespace perifx::scene::detail {

// ---------------------------------------------------------------------------------------------
// Spec table
// ---------------------------------------------------------------------------------------------
namespace {

Key key(std::string name, Type type, std::string doc) {
  Key k;
  k.name = std::move(name);
  k.type = type;
  k.doc = std::move(doc);
  return k;
}
Key number(std::string n, std::string d) { return key(std::move(n), Type::number, std::move(d)); }
Key integer(std::string n, std::string d) { return key(std::move(n), Type::integer, std::move(d)); }
Key text(std::string n, std::string d) { return key(std::move(n), Type::string, std::move(d)); }
Key vec3(std::string n, std::string d) { return key(std::move(n), Type::vec3, std::move(d)); }
Key mat3(std::string n, std::string d) { return key(std::move(n), Type::mat3, std::move(d)); }
Key points(std::string n, std::string d) { return key(std::move(n), Type::vec3_list, std::move(d)); }
Key choice(std::string n, std::vector<std::string> choices, std::string d) {
  Key k = key(std::move(n), Type::enumeration, std::move(d));
  k.choices = std::move(choices);
  return k;
}
Key strings(std::string n, std::vector<std::string> choices, std::string d) {
  Key k = key(std::move(n), Type::string_list, std::move(d));
  k.choices = std::move(choices);
  return k;
}
Key nested(std::string n, Type t, std::string label, std::string d, std::vector<Key> keys) {
  Key k = key(std::move(n), t, std::move(d));
  k.label = std::move(label);
  k.keys = std::move(keys);
  return k;
}
Key object(std::string n, std::string label, std::string d, std::vector<Key> keys) {
  return nested(std::move(n), Type::object, std::move(label), std::move(d), std::move(keys));
}
Key rotation(std::string n, std::string d) {
  return object(std::move(n), "rotation", std::move(d),
                {vec3("axis", "Rotation axis, any length (normalized on load).").not_zero().req(),
                 number("degrees", "Angle about `axis`, degrees, right-handed.").req()});
}

Key region_key(std::string doc) {
  return object("region", "region", std::move(doc), {
      choice("type", {"all", "box", "sphere", "halfspace"}, "Region shape.").req(),
      vec3("min", "Lower corner, m.").req().only({"box"}),
      vec3("max", "Upper corner, m; greater than `min` in every component.").req().only({"box"}),
      vec3("center", "Center, m.").req().only({"sphere"}),
      number("radius", "Radius, m.").gt(0).req().only({"sphere"}),
      vec3("point", "A point on the bounding plane, m.").req().only({"halfspace"}),
      vec3("normal", "Normal (normalized on load); selects (x − point)·normal ≥ 0.")
          .not_zero().req().only({"halfspace"}),
      text("body", "Only particles of the body with this name; omitted = every body."),
  });
}

const Json kZero = Json::array({0, 0, 0});
const std::vector<std::string> kMeshers = {"box", "sphere", "cylinder", "surface"};  // take a resolution

Key build_spec() {
  Key material = nested("materials", Type::map, "material",
      "Named materials; bodies refer to them by name (names cannot start with `_`). Give the moduli "
      "(`bulk_modulus` + `shear_modulus`, or `youngs_modulus` + `poisson_ratio`), or a `preset`.", {
      choice("preset", preset_names(),
             "Real-world values (see Material presets below): fills density, moduli, fracture_energy, the yield "
             "(offset_yield_stress for the metals, yield_stress for clay) and, for wood, the grain anisotropy; every "
             "other key given in this material overrides the preset's value (a moduli pair replaces both moduli; "
             "critical_stretch replaces fracture_energy; yield_energy, yield_stress or offset_yield_stress replaces "
             "the preset's yield)."),
      number("density", "Mass density ρ, kg/m³.").ge(1e-3).le(1e6).def_text("1000, or the preset's"),
      number("bulk_modulus", "Bulk modulus κ, Pa.").gt(0),
      number("shear_modulus", "Shear modulus μ, Pa.").gt(0),
      number("youngs_modulus", "Young's modulus E, Pa. With ν: κ = E/(3(1−2ν)), μ = E/(2(1+ν)).").gt(0),
      number("poisson_ratio", "Poisson's ratio ν.").gt(-1).lt(0.5),
      number("yield_energy", "Plastic yield energy Ψ0 (Eq 13), in model units that depend on the horizon; "
                             "\"inf\" = purely elastic. Prefer `yield_stress` or `offset_yield_stress`; not "
                             "with either.")
          .gt(0).or_inf().def_text("\"inf\" (or from `yield_stress`)"),
      number("yield_stress", "Yield stress σ_y, Pa (uniaxial tension flow stress); perifx derives the yield "
                             "parameter for each body's horizon, so the material yields at σ_y at any "
                             "resolution (systems/README.md §12). The paper's per-bond law yields gradually, "
                             "so its 0.2 % offset yield stress is lower: 0.98 σ_y at steel's σ_y/E, 0.93 at "
                             "aluminium's (§12.2); give `offset_yield_stress` instead for a datasheet's yield "
                             "strength. \"inf\" = purely elastic. Not with `yield_energy` or `offset_yield_stress`.")
          .gt(0).or_inf(),
      number("offset_yield_stress", "0.2 % offset yield stress σ_p0.2 (proof stress R_p0.2), Pa: what datasheets "
                                    "list as yield strength. perifx finds the flow stress σ_y at which the paper's "
                                    "per-bond law has this offset yield (1.02 × it for the steel preset, 1.08 × for "
                                    "aluminium; systems/README.md §12.2) and yields from it as from `yield_stress`. "
                                    "\"inf\" = purely elastic. Not with `yield_energy` or `yield_stress`.")
          .gt(0).or_inf(),
      number("plastic_cap_ratio", "Plastic cap γ/|ξ| (Eq 16); \"inf\" = no cap.").ge(0).or_inf()
          .def_text("0 (no plastic flow), or \"inf\" when the yield comes from `yield_stress`, "
                    "`offset_yield_stress` or a preset"),
      number("critical_stretch", "Critical bond stretch s_c (Eq 19), in model units that depend on the horizon; "
                                 "\"inf\" = unbreakable. Prefer `fracture_energy`. Not with `fracture_energy`.")
          .gt(0).or_inf().def_text("\"inf\" (or from `fracture_energy`)"),
      number("fracture_energy", "Fracture energy G_c, J/m² (energy per unit area of new crack); perifx derives s_c "
                                "for each body's horizon, so the same scene breaks at the same load at any "
                                "resolution (systems/README.md §12). \"inf\" = unbreakable. Not with `critical_stretch`.")
          .gt(0).or_inf(),
      number("damage_alpha", "Damage parameter α (Eq 19).").ge(0).def(0),
      object("anisotropy", "anisotropy", "Anisotropy tensor G (Eq 17); omitted = identity (wood preset: grain along x).", {
          mat3("matrix", "G itself, as rows; must be invertible."),
          vec3("axis", "Direction a (normalized on load): "
                       "G = ratio_along·a aᵀ + ratio_across·(I − a aᵀ).").not_zero(),
          number("ratio_along", "Factor along `axis`.").gt(0).def(1),
          number("ratio_across", "Factor across `axis`.").gt(0).def(1),
      }).one_of({{"matrix"}, {"axis", "ratio_along", "ratio_across"}}, false),
      number("damping", "Mass-proportional velocity damping, 1/s; 0 = none.").ge(0).def(0),
      object("strength", "strength",
             "Spatially varying strength (systems/README.md §12.4): the break threshold s_c is multiplied by "
             "each `regions` factor whose region holds the particle and by 1 + amplitude·n(x) (seeded value "
             "noise, n in [−1, 1]); bonds crossing a `weak_planes` polygon break at `factor` times their "
             "threshold. Only meaningful for a breakable material.", {
          nested("regions", Type::array, "strength region", "Regions with a strength multiplier.", {
              region_key("Where the factor applies, tested on reference positions (after the body transform).").req(),
              number("factor", "Multiplier of s_c for particles in the region.").gt(0).req(),
          }).def(Json::array()),
          object("noise", "noise", "Seeded 3D value noise on s_c; the same seed gives the same bits.", {
              number("amplitude", "s_c × (1 + amplitude·n(x)), n in [−1, 1].").ge(0).lt(1).req(),
              number("feature_size", "Noise lattice spacing, m.").gt(0).req(),
              integer("seed", "Noise seed.").ge(0).def(1),
          }),
          nested("weak_planes", Type::array, "weak plane",
                 "Planar polygons: bonds whose reference segment crosses one keep `factor` of their strength "
                 "(an initial crack with factor 0 would remove them; see `cracks`).", {
              points("polygon", "Vertices of a planar polygon, m, in order around its boundary.").at_least(3).req(),
              number("factor", "Multiplier of the crossing bonds' s_c.").gt(0).le(1).req(),
          }).def(Json::array()),
      }),
  }).one_of({{"bulk_modulus", "shear_modulus"}, {"youngs_modulus", "poisson_ratio"}}, false);

  Key body = nested("bodies", Type::array, "body", "The deformable bodies.", {
      text("name", "Unique body name.").def_text("`\"body<k>\"`, k = index in `bodies`"),
      text("material", "Name of one of `materials`.").req(),
      object("geometry", "geometry", "Shape, meshed into tets; primitives are centered at the origin.", {
          choice("type", {"box", "sphere", "cylinder", "tetgen", "gmsh", "surface"},
                 "A primitive for the built-in structured mesher; a tet mesh file (`tetgen`, `gmsh`); or "
                 "a closed triangle surface (`surface`) filled with tets by the external `tetgen` program "
                 "(apt-get install tetgen).").req(),
          vec3("size", "Full edge lengths, m.").gt(0).req().only({"box"}),
          number("radius", "Radius, m.").gt(0).req().only({"sphere", "cylinder"}),
          number("height", "Length along `axis`, m.").gt(0).req().only({"cylinder"}),
          choice("axis", {"x", "y", "z"}, "Cylinder axis.").def("y").only({"cylinder"}),
          text("path", "Mesh file, relative to the scene file's folder. `tetgen`: the .node file, with the "
                       ".ele of the same stem beside it. `gmsh`: an ASCII .msh, format 2.2 or 4.1 (only its "
                       "tetrahedra are used). `surface`: .obj, .ply, .stl or .off (by extension); it must be "
                       "closed, manifold and one piece. A tet mesh in several pieces (sharing no vertex) is "
                       "an error: make them separate bodies.").req().only({"tetgen", "gmsh", "surface"}),
          number("edge_length", "Target cell size of the structured mesh, m; for `surface`, the edge of "
                                "a regular tet whose volume is TetGen's bound (in the file's units, "
                                "before `transform`).").gt(0).only(kMeshers),
          integer("resolution", "Cells along the longest extent of the structured mesh; for `surface`, "
                                "edge_length = longest bounding-box extent / resolution.")
              .ge(1).def(20).only(kMeshers),
          integer("particles", "Target tet (particle) count: TetGen's volume bound is enclosed volume / "
                               "particles, rescaled up to twice toward the count. Coarse targets come out "
                               "higher: the surface's triangles set a floor.").ge(1).only({"surface"}),
          number("jitter", "Random offset of the structured mesh's vertices, as a fraction of each vertex's "
                           "shortest edge (boundary vertices slide within their flat face). Removes the "
                           "grid's preferred crack directions. Omitted: 0.3 when the body's material can "
                           "break (finite critical_stretch or fracture_energy), else 0.").ge(0).le(0.4).only({"box", "sphere", "cylinder"}),
          integer("seed", "Seed of the jitter: the same seed gives the same mesh, bit for bit.")
              .ge(0).def(1).only({"box", "sphere", "cylinder"}),
          strings("mirror", {"x", "y", "z"}, "Make the structured mesh and its jitter mirror-symmetric about the body's "
                  "centre plane normal to each listed axis (before `transform`): on that axis the cubes of the lower "
                  "half are split around the mirror image of the upper half's diagonal, and mirror-image vertices get "
                  "mirror-image offsets (vertices on the plane stay on it). A load and notch mirror-symmetric about "
                  "that plane then give mirror-symmetric cracks; the default grid splits every cube around the same "
                  "diagonal and jitters each vertex independently, so it is not symmetric. Needs an even number of "
                  "cells along the axis. A crack running in a mirror plane follows it (the plane is flat).")
              .def(Json::array()).only({"box", "sphere", "cylinder"}),
      }).one_of({{"edge_length"}, {"resolution"}, {"particles"}}, false).req(),
      object("transform", "transform", "Placement of the mesh: x ↦ R·(scale·x) + translate.", {
          vec3("translate", "Translation, m.").def(kZero),
          rotation("rotate", "Rotation R; omitted = none."),
          number("scale", "Uniform scale factor.").gt(0).def(1),
      }).def(Json::object()),
      vec3("velocity", "Initial velocity, m/s.").def(kZero),
      vec3("angular_velocity", "Initial angular velocity about the reference centroid, rad/s.")
          .def(kZero),
      nested("horizon", Type::number_or_object, "horizon",
             "Horizon δ. A number f means δ = f·λ (λ = mean tet edge length); "
             "or an object with `factor` (the same) or `length` (δ in metres).", {
          number("factor", "δ = factor·λ.").gt(0).le(20),
          number("length", "δ in metres.").gt(0),
      }).gt(0).le(20).def(1.45).one_of({{"factor"}, {"length"}}, true),
  }).at_least(1).req();

  Key condition = nested("boundary_conditions", Type::array, "boundary condition",
      "Prescribed motion of particle regions. Strength is 0 before `start`, rises linearly to 1 "
      "over `ramp` seconds, stays 1 until `end`, then the condition is released.", {
      choice("type", {"anchor", "velocity", "displacement"},
             "`anchor` holds particles at their reference positions; `velocity` and "
             "`displacement` prescribe them.").req(),
      region_key("The particles it acts on, tested on reference positions (after the body transform).").req(),
      number("start", "Start time, s.").ge(0).def(0),
      number("ramp", "Ramp-up duration after `start`, s.").ge(0).def(0),
      number("end", "Release time, s; after `start`. \"inf\" = never.").gt(0).or_inf().def("inf"),
      vec3("velocity", "v = ramp·(velocity + angular_velocity × (x − center)), m/s.")
          .def(kZero).only({"velocity"}),
      vec3("angular_velocity", "Angular velocity about `center`, rad/s.").def(kZero).only({"velocity"}),
      vec3("center", "Center of the rotational part, m.").def(kZero).only({"velocity", "displacement"}),
      vec3("displacement", "u = ramp·(displacement + (R − I)(x − center)), m.")
          .def(kZero).only({"displacement"}),
      rotation("rotation", "Rotation R about `center`; omitted = none.").only({"displacement"}),
      strings("axes", {"x", "y", "z"},
              "The world axes it prescribes; the others keep their free motion under the forces. [\"x\"] "
              "is a roller: a grip that pulls along x and lets the section contract, or (`anchor`) a "
              "symmetry plane normal to x.").at_least(1).def(Json::array({"x", "y", "z"})),
  }).def(Json::array());


  const std::vector<std::string> kSurfaceLoads = {"traction", "blast", "radial_impulse", "directional"};
  const std::vector<std::string> kBlasts = {"blast", "radial_impulse"};
  Key load = nested("loads", Type::array, "load",
      "External loads on top of gravity (systems/README.md §8.6). Each has the time window of the boundary "
      "conditions (strength 0 before `start`, a linear ramp to 1 over `ramp` seconds, 1 until `end`); a step "
      "applies the window's mean over the time its force stands for, so the impulse delivered is exact for "
      "any `dt`. Surface loads (`traction`, `blast`, `radial_impulse`, `directional`) act on the boundary "
      "faces of the bodies' tet meshes (in their reference orientation), each face on its tet's particle; "
      "body loads (`body_force`, `noise`) on particles.", {
      choice("type", {"traction", "body_force", "blast", "radial_impulse", "directional", "noise"},
             "`traction`: a stress on the boundary faces in `region`. `body_force`: a force density or "
             "acceleration. `blast` / `radial_impulse`: a pressure pulse from `center` on the faces that face "
             "it, p = P·(radius/max(r, radius))^falloff·(1 − s/duration) for 0 ≤ s < duration, s = t − start − "
             "r/front_speed, r the face's distance to `center`; `radial_impulse` gives the impulse per area I "
             "at `radius` instead (P = 2I/duration; duration 0 delivers it at once). `directional`: wind; on "
             "each face turned towards the relative wind u = velocity − v (particle velocity v), the force "
             "(drag + quadratic_drag·|u|)·a·(−n·û)·u (a the face's area, n its outward normal). `noise`: a "
             "seeded, smooth 3D vector field (value noise with quintic interpolation, each component in "
             "[−amplitude, amplitude]) of cell size `feature_size`, drifting at `speed` along `direction`.").req(),
      region_key("Surface loads: the boundary faces whose centroid is inside; body loads: the particles "
                 "inside (reference positions, after the body transform). Omitted = everything."),
      text("body", "Only the body with this name (besides any `region.body`); omitted = every body."),
      number("start", "Start time, s (for `blast` / `radial_impulse`: the detonation).").ge(0).def(0),
      number("ramp", "Ramp-up duration after `start`, s.").ge(0).def(0),
      number("end", "End time, s; after `start`. \"inf\" = never.").gt(0).or_inf().def("inf"),
      number("traction", "Stress, Pa: along `direction`, or along the outward normal (positive pulls, "
                         "negative presses) when `direction` is omitted.").req().only({"traction"}),
      number("depth", "Spread each face's force over the particles of its body up to this depth below it (each "
                      "to its nearest face, shared by volume), m; 0 = on the face's own particle. Peridynamic "
                      "practice applies a boundary traction in a layer about one horizon deep: on the outermost "
                      "particles alone, whose families the surface cuts, a large traction tears that layer off.")
          .ge(0).def(0).only({"traction"}),
      vec3("direction", "`traction`: its direction (normalized on load); omitted = each face's outward "
                        "normal. `noise`: the drift direction (normalized), default [1, 0, 0].")
          .not_zero().only({"traction", "noise"}),
      vec3("acceleration", "Acceleration, m/s² (force m·a).").only({"body_force"}),
      vec3("force_density", "Force per volume, N/m³ (force V·f).").only({"body_force"}),
      vec3("center", "Center of the explosion, m.").req().only(kBlasts),
      number("pressure", "Peak pressure P at distance ≤ `radius`, Pa.").gt(0).req().only({"blast"}),
      number("impulse", "Impulse per area I at distance ≤ `radius`, Pa·s.").gt(0).req().only({"radial_impulse"}),
      number("radius", "Distance within which the peak holds, m.").gt(0).req().only(kBlasts),
      number("falloff", "Exponent of the decay (radius/r)^falloff beyond `radius` (2: spherical "
                        "spreading).").ge(0).def(2).only(kBlasts),
      number("cutoff", "No pressure on faces farther than this, m. \"inf\" = none.").gt(0).or_inf().def("inf").only(kBlasts),
      number("duration", "Length of the pulse, s (triangular: the peak at arrival, decaying linearly to "
                         "0); `radial_impulse` may give 0 (an instantaneous impulse).").ge(0).def(0).only(kBlasts),
      number("front_speed", "Speed of the blast front, m/s: a face at distance r is hit r/front_speed after "
                            "`start`. \"inf\" = all at once.").gt(0).or_inf().def("inf").only(kBlasts),
      vec3("velocity", "Wind velocity, m/s.").req().only({"directional"}),
      number("drag", "Linear drag: force per projected area per m/s of relative wind, Pa·s/m.").ge(0).def(0)
          .only({"directional"}),
      number("quadratic_drag", "Quadratic drag: force per projected area per (m/s)², Pa·s²/m² "
                               "(½ρ_air·C_d: about 0.6 for air and a flat plate).").ge(0).def(0).only({"directional"}),
      number("amplitude", "Largest value of each component, m/s² (`units` acceleration) or N/m³.")
          .gt(0).req().only({"noise"}),
      choice("units", {"acceleration", "force_density"}, "What `amplitude` is.").def("acceleration").only({"noise"}),
      number("feature_size", "Size of the noise's cells, m (the distance over which it varies).")
          .gt(0).req().only({"noise"}),
      number("speed", "Speed at which the pattern drifts along `direction`, m/s.").ge(0).def(0).only({"noise"}),
      integer("seed", "Seed: the same seed gives the same field, bit for bit.").ge(0).def(0).only({"noise"}),
  }).def(Json::array());

  Key collider = nested("colliders", Type::array, "collider",
      "Kinematic obstacles with prescribed motion. A body meets them with its mesh surface (the boundary "
      "triangles of its tets, following each particle's deformation), so it rests on a ground plane with "
      "the surface you render, not a fraction of a cell inside it.", {
      choice("type", {"plane", "sphere", "box"}, "Shape.").req(),
      vec3("point", "A point on the plane, m.").def(kZero).only({"plane"}),
      vec3("normal", "Outward normal (normalized on load); the solid is on the other side.")
          .not_zero().def(Json::array({0, 1, 0})).only({"plane"}),
      vec3("center", "Initial center, m.").def(kZero).only({"sphere", "box"}),
      number("radius", "Radius, m.").gt(0).req().only({"sphere"}),
      vec3("size", "Full edge lengths, m.").gt(0).req().only({"box"}),
      rotation("rotate", "Initial orientation; omitted = axis-aligned.").only({"box"}),
      vec3("velocity", "Prescribed linear velocity, m/s.").def(kZero),
      vec3("angular_velocity", "Prescribed angular velocity about its center, rad/s.").def(kZero),
      number("friction", "Coulomb friction coefficient.").ge(0).def(0),
      number("restitution", "Normal restitution.").ge(0).le(1).def(0),
  }).def(Json::array());

  Key contact = object("contact", "contact",
      "Particle–particle contact: a short-range repulsion between particles that are not joined by an "
      "alive bond (different bodies, or fragments) once closer than d_c = distance_factor·(∛V_i + ∛V_j)/2. "
      "The pair stiffness is k = stiffness_factor·min(m_i, m_j)/τ², τ the contact time scale (below), so "
      "the contact is the same at any time step up to τ and stays stable (k·dt²/m ≤ stiffness_factor); a "
      "step longer than τ takes τ's place (k = stiffness_factor·m/dt²), and impacts then depend on the step. "
      "It also damps the normal approach and applies Coulomb friction. The projectiles use the same spring.", {
      key("enabled", Type::boolean, "Whether contact runs.")
          .def_text("true when there are at least 2 bodies or a material can break (finite `critical_stretch` or `fracture_energy`)"),
      number("distance_factor", "Contact distance d_c as a multiple of the mean particle size ∛V.")
          .gt(0).le(3).def(0.9),
      number("stiffness_factor", "k·τ²/min(m_i, m_j); small keeps the explicit step stable.")
          .gt(0).le(0.5).def(0.05),
      number("time_scale", "Contact time scale τ, s. \"auto\": the automatic time step before it is fitted to "
                           "the frames (time/dt), min(80 % of the stable limit, the time the fastest prescribed "
                           "motion takes to cross a quarter of the finest body's mean edge length or of a smaller "
                           "projectile's radius), whatever step the scene gives; it is set at set-up from the "
                           "scene alone (systems/README.md §8.4).").gt(0).or_auto().def("auto"),
      number("damping_ratio", "Normal damping, fraction of critical for the pair spring.").ge(0).le(1).def(0.1),
      number("friction", "Coulomb friction coefficient between particles.").ge(0).def(0),
  }).def(Json::object());

  Key projectile = nested("projectiles", Type::array, "projectile",
      "Rigid projectiles with mass, integrated like the particles (gravity applies); they push particles "
      "within radius + d_c/2, and the body's boundary faces they reach (so a body is touched at its mesh "
      "surface at any resolution), with the contact spring (contact's stiffness_factor and damping_ratio) and "
      "receive the opposite force. Their state is written per frame to projectiles.csv.", {
      choice("type", {"sphere"}, "Shape.").req(),
      vec3("center", "Initial center, m.").req(),
      number("radius", "Radius, m.").gt(0).req(),
      number("density", "Mass density, kg/m³ (mass = density·4/3πr³).").gt(0),
      number("mass", "Mass, kg.").gt(0),
      vec3("velocity", "Initial velocity, m/s.").def(kZero),
      vec3("angular_velocity", "Initial angular velocity, rad/s.").def(kZero),
      number("friction", "Coulomb friction coefficient against particles.").ge(0).def(0),
  }).one_of({{"density"}, {"mass"}}, true).def(Json::array());

  Key crack = nested("cracks", Type::array, "crack",
      "Initial cracks (paper Fig. 17): bonds whose reference segment crosses a crack polygon are "
      "never created, and N_i (Eq 19) counts only the bonds that exist.", {
      points("polygon", "Vertices of a planar polygon, m, in order around its boundary (convex or "
                        "not); planar within 1e-6 of its size, non-degenerate.").at_least(3).req(),
  }).def(Json::array());

  Key distributed = object("distributed", "distributed",
      "Distributed runs (`mpirun -np N perifx run`; ignored in one process). Each rank owns a contiguous "
      "piece of the particles' Morton order with an equal share of the work; as bonds break and pieces "
      "fly apart the shares drift, and the pieces are re-split when the busiest rank's work exceeds the "
      "mean by more than `rebalance_drift`. Work per particle: its alive bonds, its contact candidates "
      "and 8 (the per-particle passes), and a fifth of its alive bonds more while the split mesh steps its "
      "held rotation (a particle with a broken bond in a scene that writes the mesh). A re-split changes no "
      "result bit.", {
      number("rebalance_drift", "Largest tolerated excess of the busiest rank's work over the mean, as a "
                                "fraction; 0 re-splits at every check where the split would change.")
          .ge(0).def(0.2),
      integer("rebalance_interval", "Steps between two checks of the work per rank.").ge(1).def(100),
  }).def(Json::object());

  return object("", "scene", "A scene.", {
      text("name", "Scene name.").def_text("the scene file's name without extension"),
      text("description", "Free text for people; ignored by the engine.").empty_ok(),
      integer("threads", "Worker threads; 0 = all hardware threads.").ge(0).def(0),
      vec3("gravity", "Gravitational acceleration, m/s² (Y is up).").def(Json::array({0, -9.81, 0})),
      object("time", "time", "Time stepping.", {
          number("dt", "Time step, s; at most `duration`, at least duration/1e9 (at most 1e9 steps), and at "
                       "most the stable explicit limit (`perifx info`). \"auto\": 80 % of the stable limit "
                       "estimated for this scene's bodies at set-up, or less where the scene's prescribed motion "
                       "(initial velocities, projectiles, colliders, boundary conditions; summed) would cover more "
                       "than a quarter of the finest body's mean edge length (or of a smaller projectile's radius) "
                       "per step, shortened so that a whole "
                       "number of steps fills each frame interval; the same scene at a finer resolution then takes "
                       "a smaller step by itself (systems/README.md §7).").gt(0).or_auto().def("auto"),
          number("duration", "Simulated time, s.").gt(0).def(1),
          number("frame_rate", "Output frames per simulated second; at most 1/dt (an error, not clamped) and "
                               "at most 1e6 frames in `duration`.").gt(0).def(24),
      }).def(Json::object()),
      object("model", "model", "Peridynamic model options.", {
          choice("normalization", {"paper", "discrete", "corrected"},
                 "Normalization (systems/README.md §2.4): the paper's constants (Eq 6, 10), per-particle "
                 "discrete sums, or the discrete sums with a surface correction (the default: the most accurate at coarse "
                 "resolution; the paper scenes choose `paper`).").def("corrected"),
          choice("family", {"mesh", "distance"},
                 "Bond family: distance plus mesh face-connectivity, or distance only.").def("mesh"),
          choice("solver", {"peridynamics", "fem_linear", "fem_corotated"},
                 "Solver: the paper's peridynamics (particles at tet barycenters), or the reference FEM "
                 "on the same tet mesh (linear or corotated linear elasticity, explicit, lumped mass; "
                 "particles are the mesh vertices; elastic materials only, no contact or initial cracks). "
                 "`perifx compare` maps the two onto each other.").def("peridynamics"),
      }).def(Json::object()),
      material.at_least(1).req(),
      body,
      condition,
      load,
      collider,
      contact,
      projectile,
      crack,
      distributed,
      object("output", "output", "What is written, and where.", {
          text("directory", "Output folder, relative to the current working directory.").def("out"),
          strings("formats", {"vtu", "ply", "obj", "surface_ply", "surface_vtp", "tets_vtu", "cache", "gltf"},
                  "`vtu`: VTU files and a .pvd series (ParaView); `ply`: binary PLY points. Embedded tet "
                  "mesh (split along cracks, paper §5.2): `obj`: surface.NNNN.obj (groups and materials "
                  "`surface` and `crack`, surface.mtl); `surface_ply`: surface.NNNN.ply (binary, per-face "
                  "`crack` and `fragment`); `surface_vtp`: surface.NNNN.vtp + surface.pvd; `tets_vtu`: "
                  "tets.NNNN.vtu + tets.pvd (per-tet damage and fragment). At the end of the run: `cache`: "
                  "animation.obj (the final surface once: groups per piece, crack-face UVs) + animation.pc2 (every "
                  "vertex's position at every frame, for Blender's Mesh Cache modifier); `gltf`: animation.glb (binary "
                  "glTF 2.0, one node per piece animated by its best-fit rigid motion); either also writes "
                  "pieces.csv (per piece and frame: mass, centre of mass, rigid motion, velocities, birth frame, "
                  "parent). When `formats` is not given, `obj`, `surface_ply` and `cache` are added to the default "
                  "(peridynamics; FEM runs have no split mesh).")
              .at_least(1).def(Json::array({"vtu", "ply"})),
          strings("fields", {}, "Particle fields to write; empty = all. Names: see Particle fields below.").def(Json::array()),
          integer("smooth_cracks", "Smoothing of the crack faces on the surface files (systems/README.md §6.6): this "
                  "many iterations (two Laplacian steps each) move the crack surface's vertices in the reference configuration towards a "
                  "smooth surface, so cracks through the tet mesh do not show its stair-steps. Both sides of a crack "
                  "move together, every tet keeps at least 0.2 of its volume, the outer surface stays flat. Particles "
                  "and physics are not affected. 0 = off (crack faces are tet faces).").ge(0).le(50).def(3),
          integer("checkpoint_every", "Write checkpoint.bin (the complete world state, for `perifx run --resume`) "
                  "every this many frames, and after the last frame; 0 = never.").ge(0).def(10),
          integer("min_piece_tets", "Pieces (components of alive bonds, `fragment_id`) with fewer tets than this "
                  "are left out of the surface files (obj, surface_ply, surface_vtp, cache, gltf) and pieces.csv: dust. 0 keeps every piece; "
                  "the particle files keep every particle.").ge(0).def(0),
          choice("dust", {"drop", "points"}, "What becomes of the pieces `min_piece_tets` leaves out of the surface "
                 "files: `drop` writes them nowhere but the particle files; `points` writes them each frame as "
                 "dust.NNNN.ply (binary PLY points, one per particle of a dropped piece: x y z, velocity_x/y/z in "
                 "m/s, radius in m of the sphere with the particle's (tet's) volume, piece = its `fragment_id`); nothing when `min_piece_tets` is 0.")
              .def("drop"),
      }).def(Json::object()),
  });
}

// ---------------------------------------------------------------------------------------------
// Text helpers
// ---------------------------------------------------------------------------------------------
std::string fmt(double x) {
  std::ostringstream s;
  s << std::setprecision(12) << x;
  return s.str();
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool contains(const std::vector<std::string>& items, const std::string& item) {
  return std::find(items.begin(), items.end(), item) != items.end();
}

std::string quoted(const std::vector<std::string>& items, const char* quote = "\"") {
  std::vector<std::string> q;
  for (const auto& s : items) q.push_back(quote + s + quote);
  return join(q);
}

// Keys starting with '_' are comments (JSON has none), ignored at every level.
bool is_comment(const std::string& name) { return !name.empty() && name.front() == '_'; }

const Key* find_key(const Key& spec, const std::string& name) {
  for (const Key& k : spec.keys)
    if (k.name == name) return &k;
  return nullptr;
}

std::string range_text(const Key& k) {
  const bool has_lo = std::isfinite(k.lo), has_hi = std::isfinite(k.hi);
  if (has_lo && has_hi)
    return std::string(" in ") + (k.lo_open ? "(" : "[") + fmt(k.lo) + ", " + fmt(k.hi) +
           (k.hi_open ? ")" : "]");
  if (has_lo) return (k.lo_open ? " > " : " >= ") + fmt(k.lo);
  if (has_hi) return (k.hi_open ? " < " : " <= ") + fmt(k.hi);
  return "";
}

bool in_range(const Key& k, double x) {
  const bool lo_ok = k.lo_open ? x > k.lo : x >= k.lo;
  const bool hi_ok = k.hi_open ? x < k.hi : x <= k.hi;
  return lo_ok && hi_ok;
}

// "'axis' (+ optional 'ratio_along', 'ratio_across')": members with a default may be left out.
std::string group_text(const Key& spec, const std::vector<std::string>& group) {
  std::vector<std::string> needed, optional;
  for (const auto& n : group)
    (find_key(spec, n)->default_value.is_null() ? needed : optional).push_back("'" + n + "'");
  if (needed.empty()) return join(optional, " + ");
  return join(needed, " + ") + (optional.empty() ? "" : " (+ optional " + join(optional) + ")");
}

std::string groups_list(const Key& spec) {
  std::vector<std::string> parts;
  for (const auto& g : spec.groups) parts.push_back(group_text(spec, g));
  return join(parts, " or ");
}
std::string groups_text(const Key& spec) {
  return (spec.groups.size() > 1 ? "either " : "") + groups_list(spec);
}

std::string count_text(std::size_t n) { return n ? ", at least " + std::to_string(n) : ""; }

// What a key accepts, in words; used by error messages and by the reference alike.
std::string expected(const Key& k) {
  switch (k.type) {
    case Type::number:
      return "a number" + range_text(k) + (k.allow_inf ? " or \"inf\"" : "") + (k.allow_auto ? " or \"auto\"" : "");
    case Type::integer: return "an integer" + range_text(k);
    case Type::boolean: return "true or false";
    case Type::string: return k.allow_empty ? "a string" : "a non-empty string";
    case Type::enumeration: return "one of " + quoted(k.choices);
    case Type::vec3: {
      const std::string r = range_text(k);
      return "an array of 3 numbers" + (r.empty() ? "" : ", each" + r) +
             (k.nonzero ? ", not all zero" : "");
    }
    case Type::mat3: return "a 3x3 matrix: an array of 3 rows of 3 numbers";
    case Type::vec3_list: return "an array of points [x, y, z]" + count_text(k.min_items);
    case Type::object: return "an object";
    case Type::map: return "an object of named " + k.label + "s" + count_text(k.min_items);
    case Type::array: return "an array of " + k.label + " objects" + count_text(k.min_items);
    case Type::string_list:
      return "an array of strings" + (k.choices.empty() ? "" : " from " + quoted(k.choices)) +
             count_text(k.min_items);
    case Type::number_or_object:
      return "a number" + range_text(k) + " or an object with " + groups_text(k);
  }
  return "";
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

// ---------------------------------------------------------------------------------------------
// Validator
// ---------------------------------------------------------------------------------------------
class Validator {
 public:
  explicit Validator(const std::string& file) : file_(file) {}

  void value(const Key& k, Json& v, const std::string& ptr) const {
    switch (k.type) {
      case Type::number:
      case Type::integer: number(k, v, ptr); return;
      case Type::number_or_object:
        if (v.is_object()) object(k, v, ptr);
        else number(k, v, ptr);
        return;
      case Type::boolean:
        if (!v.is_boolean()) wrong(k, v, ptr);
        return;
      case Type::string:
        if (!v.is_string()) wrong(k, v, ptr);
        if (!k.allow_empty && v.get_ref<const std::string&>().empty()) wrong(k, v, ptr, "empty string");
        return;
      case Type::enumeration: {
        if (!v.is_string()) wrong(k, v, ptr);
        const auto& s = v.get_ref<const std::string&>();
        if (contains(k.choices, s)) return;
        const std::string guess = closest(s, k.choices);
        wrong(k, v, ptr, "invalid value" + (guess.empty() ? "" : "; did you mean '" + guess + "'?"));
      }
      case Type::vec3: {
        if (!is_numbers(v, 3)) wrong(k, v, ptr);
        bool all_zero = true;
        for (const Json& c : v) {
          const double x = c.get<double>();
          if (!std::isfinite(x)) wrong(k, v, ptr, "not a finite number");
          if (!in_range(k, x)) wrong(k, v, ptr, "out of range");
          all_zero = all_zero && x == 0.0;
        }
        if (k.nonzero && all_zero) wrong(k, v, ptr, "zero vector");
        return;
      }
      case Type::mat3: {
        if (!v.is_array() || v.size() != 3) wrong(k, v, ptr);
        for (const Json& row : v) {
          if (!is_numbers(row, 3)) wrong(k, v, ptr);
          for (const Json& c : row)
            if (!std::isfinite(c.get<double>())) wrong(k, v, ptr, "not a finite number");
        }
        return;
      }
      case Type::vec3_list: {
        if (!v.is_array()) wrong(k, v, ptr);
        for (const Json& point : v) {
          if (!is_numbers(point, 3)) wrong(k, v, ptr);
          for (const Json& c : point)
            if (!std::isfinite(c.get<double>())) wrong(k, v, ptr, "not a finite number");
        }
        if (v.size() < k.min_items) wrong(k, v, ptr, "too few points");
        return;
      }
      case Type::object:
        if (!v.is_object()) wrong(k, v, ptr);
        object(k, v, ptr);
        return;
      case Type::map: {
        if (!v.is_object()) wrong(k, v, ptr);
        std::size_t count = 0;
        for (auto& [name, item] : v.items()) {
          if (is_comment(name)) continue;
          const std::string p = child_pointer(ptr, name);
          if (name.empty()) fail(p, "empty " + k.label + " name (expected a non-empty name)");
          if (!item.is_object())
            fail(p, "wrong type (got " + show(item) + "; expected an object describing a " +
                        k.label + ")");
          object(k, item, p);
          ++count;
        }
        if (count < k.min_items) wrong(k, v, ptr, "too few entries");
        return;
      }
      case Type::array: {
        if (!v.is_array()) wrong(k, v, ptr);
        for (std::size_t i = 0; i < v.size(); ++i) {
          const std::string p = ptr + "/" + std::to_string(i);
          if (!v[i].is_object())
            fail(p, "wrong type (got " + show(v[i]) + "; expected an object describing a " +
                        k.label + ")");
          object(k, v[i], p);
        }
        if (v.size() < k.min_items) wrong(k, v, ptr, "too few entries");
        return;
      }
      case Type::string_list: {
        if (!v.is_array()) wrong(k, v, ptr);
        std::vector<std::string> seen;
        for (const Json& s : v) {
          if (!s.is_string()) wrong(k, v, ptr);
          const auto& str = s.get_ref<const std::string&>();
          if (!k.choices.empty() && !contains(k.choices, str)) wrong(k, v, ptr, "invalid entry '" + str + "'");
          if (contains(seen, str)) wrong(k, v, ptr, "duplicate entry '" + str + "'");
          seen.push_back(str);
        }
        if (v.size() < k.min_items) wrong(k, v, ptr, "too few entries");
        return;
      }
    }
  }

  // `spec` describes the object: its keys, its "type" discriminator, its key groups.
  void object(const Key& spec, Json& obj, const std::string& ptr) const {
    const Key* type_key = find_key(spec, "type");
    std::string type;
    if (type_key) {  // first, because it decides which other keys belong here
      const std::string p = child_pointer(ptr, "type");
      if (!obj.contains("type")) fail(p, "missing required key 'type' (expected " + expected(*type_key) + ")");
      value(*type_key, obj["type"], p);
      type = obj["type"].get<std::string>();
    }
    const auto applies = [&](const Key& k) { return k.only_for.empty() || contains(k.only_for, type); };

    std::vector<std::string> all, usable;
    for (const Key& k : spec.keys) {
      all.push_back(k.name);
      if (applies(k)) usable.push_back(k.name);
    }
    for (const auto& item : obj.items()) {
      const std::string& name = item.key();
      if (is_comment(name)) continue;
      const std::string p = child_pointer(ptr, name);
      const Key* k = find_key(spec, name);
      if (!k) {
        std::string guess = closest(name, usable);
        if (guess.empty()) guess = closest(name, all);
        if (!guess.empty()) fail(p, "unknown key '" + cut(name) + "'; did you mean '" + guess + "'?");
        fail(p, "unknown key '" + cut(name) + "' (expected one of: " + join(usable) + ")");
      }
      if (!applies(*k))
        fail(p, "key '" + cut(name) + "' is not used by " + spec.label + " type '" + type + "' (used by: " +
                    join(k->only_for) + ")");
    }

    // Exclusive groups: which one is given (at most one), and is it complete?
    int active = -1;
    std::string active_key;
    for (std::size_t g = 0; g < spec.groups.size(); ++g) {
      for (const auto& n : spec.groups[g]) {
        if (!obj.contains(n) || !applies(*find_key(spec, n))) continue;
        if (active >= 0)
          fail(child_pointer(ptr, n), "'" + active_key + "' and '" + n + "' cannot both be given (expected " +
                                          groups_text(spec) + ")");
        active = static_cast<int>(g);
        active_key = n;
        break;
      }
    }
    if (active >= 0) {
      for (const auto& n : spec.groups[static_cast<std::size_t>(active)])
        if (!obj.contains(n) && find_key(spec, n)->default_value.is_null())
          fail(child_pointer(ptr, n), "missing key '" + n + "', which goes with '" + active_key +
                                          "' (expected " + groups_text(spec) + ")");
    } else if (spec.need_group) {
      fail(ptr, "missing keys (got " + show(obj) + "; expected " + groups_text(spec) + ")");
    }

    for (const Key& k : spec.keys) {
      if (&k == type_key || !applies(k)) continue;
      const std::string p = child_pointer(ptr, k.name);
      if (obj.contains(k.name)) {
        value(k, obj[k.name], p);
        continue;
      }
      if (k.required)
        fail(p, "missing required key '" + k.name + "'" +
                    (k.only_for.empty() ? "" : " for " + spec.label + " type '" + type + "'") +
                    " (expected " + expected(k) + ")");
      if (k.default_value.is_null()) continue;
      // A grouped key's default applies when its group is the one given, or when no group is
      // given and every member of its group has a default (geometry: resolution 20).
      const int g = group_of(spec, k.name);
      if (g >= 0 && g != active && (active >= 0 || !all_defaulted(spec, static_cast<std::size_t>(g))))
        continue;
      obj[k.name] = k.default_value;
      value(k, obj[k.name], p);  // fills nested defaults, turns "inf" into +∞
    }
  }

 private:
  [[noreturn]] void fail(const std::string& ptr, const std::string& problem) const {
    throw SceneError(file_, ptr, problem);
  }
  [[noreturn]] void wrong(const Key& k, const Json& v, const std::string& ptr,
                          const std::string& problem = "wrong type") const {
    fail(ptr, problem + " (got " + show(v) + "; expected " + expected(k) + ")");
  }

  static bool is_numbers(const Json& v, std::size_t n) {
    return v.is_array() && v.size() == n &&
           std::all_of(v.begin(), v.end(), [](const Json& c) { return c.is_number(); });
  }
  static int group_of(const Key& spec, const std::string& name) {
    for (std::size_t g = 0; g < spec.groups.size(); ++g)
      if (contains(spec.groups[g], name)) return static_cast<int>(g);
    return -1;
  }
  static bool all_defaulted(const Key& spec, std::size_t g) {
    return std::all_of(spec.groups[g].begin(), spec.groups[g].end(),
                       [&](const std::string& n) { return !find_key(spec, n)->default_value.is_null(); });
  }

  void number(const Key& k, Json& v, const std::string& ptr) const {
    if (k.allow_auto && v.is_string() && lower(v.get<std::string>()) == "auto") {
      v = "auto";
      return;
    }
    if (k.allow_inf && v.is_string()) {
      const std::string s = lower(v.get<std::string>());
      if (s == "inf" || s == "infinity") {
        v = std::numeric_limits<double>::infinity();
        return;
      }
    }
    if (!v.is_number()) wrong(k, v, ptr);
    const double x = v.get<double>();
    if (!std::isfinite(x)) wrong(k, v, ptr, "not a finite number");  // the parser rejects 1e999; defensive
    if (k.type == Type::integer) {
      if (x != std::floor(x)) wrong(k, v, ptr);
      if (x < INT_MIN || x > INT_MAX) wrong(k, v, ptr, "out of range");
      v = static_cast<int>(x);  // 20.0 -> 20, so the converter can read an int
    }
    if (!in_range(k, x)) wrong(k, v, ptr, "out of range");
  }

  const std::string& file_;
};

}  // namespace

// ---------------------------------------------------------------------------------------------
// Shared helpers
// ---------------------------------------------------------------------------------------------
std::string join(const std::vector<std::string>& items, const std::string& separator) {
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i) out += (i ? separator : "") + items[i];
  return out;
}

// Echoed input is cut to kEcho bytes (at a UTF-8 character boundary) with "…", so a huge value or
// key never floods a message; control characters are escaped so a message stays one line.
constexpr std::size_t kEcho = 80;

std::string cut(const std::string& text) {
  std::string out;
  std::size_t used = 0;
  for (; used < text.size() && out.size() < kEcho; ++used) {
    const auto c = static_cast<unsigned char>(text[used]);
    if (c < 0x20 || c == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    } else {
      out += static_cast<char>(c);
    }
  }
  if (used == text.size()) return out;
  // Drop a multi-byte character the cut went through.
  std::size_t end = out.size();
  if ((static_cast<unsigned char>(text[used]) & 0xC0) == 0x80) {
    while (end > 0 && (static_cast<unsigned char>(out[end - 1]) & 0xC0) == 0x80) --end;
    if (end > 0) --end;
  }
  return out.substr(0, end) + "…";
}

std::string show(const Json& value) {
  if (value.is_string() && value.get_ref<const std::string&>().size() > 4 * kEcho)
    return cut("\"" + value.get_ref<const std::string&>().substr(0, 4 * kEcho));
  if ((value.is_object() || value.is_array()) && value.size() > 64) {
    Json head = value.is_array() ? Json::array() : Json::object();
    std::size_t k = 0;
    for (auto it = value.begin(); it != value.end() && k < 8; ++it, ++k)
      if (value.is_array()) head.push_back(*it);
      else head[it.key()] = *it;
    return cut(head.dump() + "…");
  }
  return cut(value.dump(-1, ' ', false, Json::error_handler_t::replace));
}

std::string child_pointer(const std::string& pointer, const std::string& key) {
  std::string out = pointer + "/";
  for (char c : cut(key)) {
    if (c == '~') out += "~0";
    else if (c == '/') out += "~1";
    else out += c;
  }
  return out;
}

std::string closest(const std::string& word, const std::vector<std::string>& candidates) {
  if (word.size() > kEcho) return "";  // no typo of a known key is that long (and edit distance is quadratic)
  std::string best;
  std::size_t best_distance = SIZE_MAX;
  for (const auto& c : candidates) {
    const std::size_t d = edit_distance(lower(word), lower(c));
    if (d < best_distance) best = c, best_distance = d;
  }
  // Plausibly a typo: a few edits, and not a rewrite of the whole word.
  const bool close = best_distance <= std::max<std::size_t>(2, word.size() / 3) &&
                     best_distance < std::min(word.size(), best.size());
  return close ? best : "";
}

const Key& scene_spec() {
  static const Key spec = build_spec();
  return spec;
}

void validate(Json& root, const std::string& file) {
  const Validator v(file);
  if (!root.is_object())
    throw SceneError(file, "", "the scene must be a JSON object (got " + show(root) + "; expected an object)");
  v.object(scene_spec(), root, "");
}

const std::string& example_scene() {
  static const std::string text = R"({
  "name": "cantilever",
  "description": "A steel beam clamped at one end; a rubber ball drops onto it.",
  "_comment": "keys starting with an underscore are ignored",
  "threads": 0,
  "gravity": [0, -9.81, 0],
  "time": { "dt": "auto", "duration": 0.5, "frame_rate": 60 },
  "model": { "normalization": "paper", "family": "mesh" },
  "materials": {
    "steel": { "density": 7850, "youngs_modulus": 2e11, "poisson_ratio": 0.3,
               "yield_energy": "inf", "critical_stretch": 0.01 },
    "rubber": { "density": 1100, "bulk_modulus": 2e7, "shear_modulus": 1e6, "damping": 5,
                "anisotropy": { "axis": [1, 0, 0], "ratio_along": 2 } }
  },
  "bodies": [
    { "name": "beam", "material": "steel",
      "geometry": { "type": "box", "size": [1.0, 0.1, 0.1], "resolution": 40 },
      "transform": { "translate": [0, 0.5, 0] } },
    { "name": "ball", "material": "rubber",
      "geometry": { "type": "sphere", "radius": 0.05, "edge_length": 0.01 },
      "transform": { "translate": [0.4, 0.7, 0], "rotate": { "axis": [0, 0, 1], "degrees": 30 } },
      "velocity": [0, -1, 0], "horizon": { "factor": 1.6 } }
  ],
  "boundary_conditions": [
    { "type": "anchor",
      "region": { "type": "box", "min": [-0.6, 0.4, -0.1], "max": [-0.45, 0.6, 0.1], "body": "beam" } },
    { "type": "velocity", "start": 0.1, "ramp": 0.05, "end": 0.3, "velocity": [0, -0.1, 0],
      "region": { "type": "halfspace", "point": [0.45, 0, 0], "normal": [1, 0, 0], "body": "beam" } }
  ],
  "colliders": [
    { "type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "friction": 0.5 }
  ],
  "output": { "directory": "out/cantilever", "formats": ["vtu", "ply"], "fields": [] }
}
)";
  return text;
}

}  // namespace perifx::scene::detail

// ---------------------------------------------------------------------------------------------
// Markdown reference
// ---------------------------------------------------------------------------------------------
namespace perifx::scene {
namespace {

using detail::Json;
using detail::Key;
using detail::Type;

std::string cell(std::string s) {  // a table cell cannot hold a raw '|'
  std::string out;
  for (char c : s) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

bool has_children(const Key& k) {
  return k.type == Type::object || k.type == Type::map || k.type == Type::array ||
         k.type == Type::number_or_object;
}

void rows(std::ostringstream& md, const Key& k, const std::string& path) {
  std::string def = "—";
  if (k.required) def = "**required**";
  else if (!k.default_doc.empty()) def = k.default_doc;
  else if (!k.default_value.is_null()) def = "`" + k.default_value.dump() + "`";

  std::string doc;
  if (!k.only_for.empty()) doc += "*Only for type " + detail::join(k.only_for, ", ") + ".* ";
  doc += k.doc;
  if (!k.groups.empty()) {
    const std::string whose = k.type == Type::map || k.type == Type::array ? "Each " + k.label + ": give "
                              : k.type == Type::number_or_object      ? "As an object, give "
                                                                      : "Give ";
    doc += " " + whose + (k.need_group ? "exactly one of " : "at most one of ") + detail::groups_list(k) + ".";
  }
  md << "| `" << path << "` | " << cell(detail::expected(k)) << " | " << cell(def) << " | " << cell(doc)
     << " |\n";

  if (!has_children(k)) return;
  const std::string base =
      path + (k.type == Type::map ? "/<name>" : k.type == Type::array ? "/<k>" : "");
  for (const Key& c : k.keys) rows(md, c, base + "/" + c.name);
}

void table_header(std::ostringstream& md) {
  md << "| Key | Expected | Default | Meaning |\n|---|---|---|---|\n";
}

}  // namespace

std::string scene_format_markdown() {
  std::ostringstream md;
  md << R"(# Scene format

<!-- Generated by perifx::scene::scene_format_markdown() from the spec table in
     engine/scene/schema.cpp (`perifx spec` prints it). Do not edit: a test checks this file
     against the code. -->

A scene is one JSON object. Keys are listed below as JSON pointers: `<name>` stands for a
material name, `<k>` for an array index.

- **Units**: SI throughout (m, kg, s, Pa); angular velocities in rad/s; the only angles, the
  `degrees` keys, are in degrees. **Y is up.**
- **Vectors** are arrays of 3 finite numbers `[x, y, z]`; matrices are arrays of 3 rows.
- **Infinity**: JSON has no `Infinity`. Keys that accept infinity take the string `"inf"` (or
  `"infinity"`, any letter case); omitting them gives their default, which is `"inf"`.
- **Comments**: JSON has none. Any key that starts with `_` (e.g. `"_comment"`) is ignored at every
  level, including in `materials`, so material names cannot start with `_`. The top-level
  `description` is free text, also ignored.
- **Strictness**: unknown keys are errors (with a suggestion when it looks like a typo), and so
  are keys that belong to another `type` (e.g. `radius` on a box), duplicate keys in one object,
  and non-finite numbers. Keys marked *Only for type ...* apply when the enclosing object's
  `type` is one of those.
- **Key groups**: "give exactly/at most one of" lists alternatives that cannot be mixed; a group
  that is given must be complete, except members with a default.
- **Paths**: `/bodies/<k>/geometry/path` is relative to the scene file's folder;
  `/output/directory` is relative to the current working directory.
- **Errors** are one line: `<file>: <json pointer>: <problem> (got <value>; expected <what>)`;
  malformed JSON is reported with its line and column.

## Example

```json
)" << detail::example_scene()
     << "```\n";

  const Key& root = detail::scene_spec();
  md << "\n## Top level\n\n";
  table_header(md);
  for (const Key& k : root.keys)
    if (!has_children(k)) rows(md, k, "/" + k.name);
  for (const Key& k : root.keys) {
    if (!has_children(k)) continue;
    md << "\n## " << k.name << "\n\n";
    table_header(md);
    rows(md, k, "/" + k.name);
  }
  // The fields list comes from the systems that register them (systems/field_registry.hpp).
  md << "\n## Particle fields\n\nWhat `output.fields` may name (all of them when it is empty), in the order they are "
        "written. Vectors have 3 components.\n\n| Field | Type | Components | Unit | Meaning |\n|---|---|---|---|---|\n";
  for (const auto& f : systems::step_fields()) {
    const char* type = f.info.type == FieldType::f64 ? "float64" : f.info.type == FieldType::f32 ? "float32"
                     : f.info.type == FieldType::u32 ? "uint32" : f.info.type == FieldType::u16 ? "uint16" : "uint8";
    std::string doc;
    for (char c : f.info.doc) doc += c == '|' ? std::string("\\|") : std::string(1, c);  // markdown cell
    md << "| `" << f.info.name << "` | " << type << " | " << f.info.components << " | " << f.info.unit << " | "
       << doc << (f.derived ? " (derived on output)" : "") << " |\n";
  }
  md << "\n## Material presets\n\n`/materials/<name>/preset` fills these values (keys given beside it win). "
        "G_c is `fracture_energy`; the yield is the metals' datasheet yield strength as `offset_yield_stress` "
        "(σ_p0.2) and clay's flow stress as `yield_stress` (σ_y) (\"inf\": elastic up to fracture; with a finite "
        "yield the plastic cap defaults to \"inf\"). Handbook values of a material class, rounded, room temperature and "
        "quasi-static; not a particular grade. The stable time step scales with √(ρ/E)·λ: stiff presets "
        "(steel, ceramic) need small steps (`perifx info` prints the limit).\n\n"
        "| preset | ρ (kg/m³) | E (Pa) | ν | G_c (J/m²) | yield (Pa) | anisotropy | source |\n|---|---|---|---|---|---|---|---|\n";
  for (const auto& p : detail::material_presets()) {
    auto num = [](double x) {
      std::ostringstream o;
      o << std::setprecision(6) << x;
      return std::isfinite(x) ? o.str() : std::string("inf");
    };
    md << "| `" << p.name << "` | " << num(p.density) << " | " << num(p.youngs_modulus) << " | " << num(p.poisson_ratio)
       << " | " << num(p.fracture_energy) << " | "
       << (std::isfinite(p.yield_stress) ? (p.yield_is_offset ? "σ_p0.2 " : "σ_y ") + num(p.yield_stress) : num(p.yield_stress))
       << " | "
       << (p.grain_ratio != 1.0 ? "grain along x: axis [1, 0, 0], ratio_along " + num(p.grain_ratio) + ", ratio_across 1"
                                : std::string("—"))
       << " | " << cell(p.source) << " |\n";
  }
  return md.str();
}

}  // namespace perifx::scene
