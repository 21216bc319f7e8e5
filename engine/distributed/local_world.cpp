// A rank's local world (local_world.hpp has the rules).
#include "distributed/local_world.hpp"

#include <algorithm>
#include <functional>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>

#include "systems/spatial_grid.hpp"
#include "systems/systems.hpp"

namespace perifx::distributed {
namespace {

// Contact ghost skin, × the largest contact distance d_c,max. Larger: fewer refreshes, more ghosts
// (the layer is d_c,max + skin: 4 d_c,max at 3, with d_c = 0.9 ∛V by default).
// 3 received the fewest bytes per step (refreshes and the ghosts' motion) at 2 ranks on the bunny
// drop at 135,596 particles, 200 steps: 8.17 MB at 2, 7.88 at 3, 8.81 at 4 (bench/README.md).
constexpr double kContactGhostSkin = 3.0;

// Owned-and-ghost local order of rank r: ghosts below, the owned range, ghosts above.
std::vector<std::uint32_t> local_order(const Domain& d, const std::vector<std::uint32_t>& ghosts) {
  std::vector<std::uint32_t> order;
  order.reserve(ghosts.size() + (d.last - d.first));
  const auto split = std::lower_bound(ghosts.begin(), ghosts.end(), d.first);
  order.insert(order.end(), ghosts.begin(), split);
  for (std::uint32_t g = d.first; g < d.last; ++g) order.push_back(g);
  order.insert(order.end(), split, ghosts.end());
  return order;
}

// Local index of global g in an increasing order (g must be present).
std::uint32_t local_of(const std::vector<std::uint32_t>& order, std::uint32_t g) {
  return static_cast<std::uint32_t>(std::lower_bound(order.begin(), order.end(), g) - order.begin());
}

// An owned global index list (sorted) restricted to [first, last) and shifted to local indices.
std::vector<std::uint32_t> owned_part(const std::vector<std::uint32_t>& list, const Domain& d, std::uint32_t shift) {
  std::vector<std::uint32_t> out;
  for (std::uint32_t g : list)
    if (g >= d.first && g < d.last) out.push_back(g - d.first + shift);
  return out;
}

// Local CSR offsets of rows kept per global particle (bonds, surface patches): owned rows keep their
// lengths, in order, and ghost rows are empty.
std::vector<std::uint32_t> owned_row_offsets(const std::vector<std::uint32_t>& global_offsets, const LocalLayout& l) {
  std::vector<std::uint32_t> offsets(l.global_of.size() + 1, 0);
  for (std::size_t q = 0; q < l.global_of.size(); ++q) {
    const bool owned = q >= l.owned_begin && q < l.owned_begin + l.owned_count;
    const std::uint32_t g = l.global_of[q];
    offsets[q + 1] = offsets[q] + (owned ? global_offsets[g + 1] - global_offsets[g] : 0);
  }
  return offsets;
}

// The FEM part of a local world (make_local_world below).
void make_local_fem(const WorldState& full, const LocalLayout& layout, WorldState& w) {
  const FemModel& ff = full.fem;
  FemModel& f = w.fem;
  const auto& order = layout.global_of;
  const std::uint32_t owned_first = order[layout.owned_begin], owned_last = owned_first + layout.owned_count;
  std::vector<std::uint32_t> tets;  // global indices of the local tets, ascending
  for (std::uint32_t g = owned_first; g < owned_last; ++g)
    for (std::uint32_t k = ff.vertex_offsets[g]; k < ff.vertex_offsets[g + 1]; ++k) tets.push_back(ff.vertex_corners[k] / 4);
  std::sort(tets.begin(), tets.end());
  tets.erase(std::unique(tets.begin(), tets.end()), tets.end());
  const std::size_t nt = tets.size(), n = order.size();
  f.dm_inverse.resize(nt);
  f.volume.resize(nt);
  f.lame_lambda.resize(nt);
  f.lame_mu.resize(nt);
  w.mesh.tets.resize(nt);
  for (std::size_t lt = 0; lt < nt; ++lt) {
    const std::uint32_t t = tets[lt];
    f.dm_inverse[lt] = ff.dm_inverse[t];
    f.volume[lt] = ff.volume[t];
    f.lame_lambda[lt] = ff.lame_lambda[t];
    f.lame_mu[lt] = ff.lame_mu[t];
    for (int c = 0; c < 4; ++c) w.mesh.tets[lt][c] = local_of(order, full.mesh.tets[t][c]);  // owned or a ghost
  }
  w.mesh.vertices = w.particles.reference_position;  // the mesh's vertices are the particles
  f.vertex_offsets.assign(n + 1, 0);
  f.vertex_corners.clear();
  for (std::size_t l = 0; l < n; ++l) {
    if (l >= layout.owned_begin && l < layout.owned_begin + layout.owned_count) {
      const std::uint32_t g = order[l];
      for (std::uint32_t k = ff.vertex_offsets[g]; k < ff.vertex_offsets[g + 1]; ++k) {
        const std::uint32_t corner = ff.vertex_corners[k];
        const auto lt = static_cast<std::uint32_t>(std::lower_bound(tets.begin(), tets.end(), corner / 4) - tets.begin());
        f.vertex_corners.push_back(4 * lt + corner % 4);
      }
    }
    f.vertex_offsets[l + 1] = static_cast<std::uint32_t>(f.vertex_corners.size());
  }
  f.corner_force.assign(4 * nt, Vec3::Zero());
}

// The parts of a local world that are not arrays, from the whole world or from a rank's shell of it
// (World::split released its arrays; these stay): make_local_world and local_world_from set them alike.
void set_local_frame(const WorldState& full, const LocalLayout& layout, WorldState& w) {
  w.settings = full.settings;
  w.clock = full.clock;
  w.any_plastic = full.any_plastic;
  w.any_anisotropic = full.any_anisotropic;
  w.any_fracture = full.any_fracture;
  w.bodies = full.bodies;  // names and measures only; nothing in the step reads their ranges
  w.owned_first = layout.owned_begin;
  w.owned_last = layout.owned_begin + layout.owned_count;
  w.embedded.motion = full.embedded.motion;
  w.boundary.conditions = full.boundary.conditions;
  w.loads.loads = full.loads.loads;
  w.fem.corotated = full.fem.corotated;
}

// After the arrays. Contact: the scene's settings, resolved as for the whole world, and the whole
// world's largest contact distance (so every rank's list reaches as far); the pair list is built on the
// first step. Projectiles (the same spheres on every rank): their per-block buffers.
void finish_local_world(const WorldState& full, LocalLayout& layout, WorldState& w) {
  const ContactState& fc = full.contact;
  systems::setup_contact(w, fc.largest_distance);
  systems::resize_projectiles(w);
  layout.base_count = static_cast<std::uint32_t>(w.particles.count());
  layout.contact_skin = kContactGhostSkin * fc.largest_distance;
  layout.contact_layer = fc.largest_distance + layout.contact_skin;
}

// The arrays a local world sends to its rank (pack_local_world): all but the contact buffers and the
// projectiles' per-block lists, which finish_local_world makes.
bool travels(ArrayKind kind, std::string_view name) {
  return kind != ArrayKind::contact && name != "projectiles.block_contacts";
}

}  // namespace

LocalLayout make_layout(const WorldState& full, const std::vector<Domain>& domains, int rank,
                        const std::vector<std::vector<std::uint32_t>>* given) {
  std::vector<std::vector<std::uint32_t>> computed;
  if (!given) computed = bond_ghosts(full, domains);
  const auto& ghosts = given ? *given : computed;
  LocalLayout l;
  l.rank = rank;
  l.ranks = static_cast<int>(domains.size());
  l.domains = domains;
  const Domain& d = domains[static_cast<std::size_t>(rank)];
  const auto& mine = ghosts[static_cast<std::size_t>(rank)];
  l.global_of = local_order(d, mine);
  l.owned_begin = local_of(l.global_of, d.first);
  l.owned_count = d.last - d.first;
  l.bond_begin = full.bonds.offsets[d.first];
  // Receives: my ghosts grouped by owner, in increasing global order within each group.
  for (int q = 0; q < l.ranks; ++q) {
    HaloLink in{q, {}};
    const Domain& dq = domains[static_cast<std::size_t>(q)];
    for (std::uint32_t g : mine)
      if (g >= dq.first && g < dq.last) in.local.push_back(local_of(l.global_of, g));
    if (!in.local.empty()) l.receives.push_back(std::move(in));
  }
  // Sends: for every other rank, the ghosts it holds that I own, in the same order it expects them.
  for (int q = 0; q < l.ranks; ++q) {
    if (q == rank) continue;
    HaloLink out{q, {}};
    for (std::uint32_t g : ghosts[static_cast<std::size_t>(q)])
      if (g >= d.first && g < d.last) out.local.push_back(g - d.first + l.owned_begin);
    if (!out.local.empty()) l.sends.push_back(std::move(out));
  }
  return l;
}

std::unique_ptr<WorldState> make_local_world(const WorldState& full, LocalLayout& layout, bool to_send) {
  const Domain& d = layout.domains[static_cast<std::size_t>(layout.rank)];
  const auto& order = layout.global_of;
  const std::size_t n_full = full.particles.count(), n = order.size();
  const std::uint32_t shift = layout.owned_begin;

  auto w = std::make_unique<WorldState>();
  set_local_frame(full, layout, *w);
  w->global_index = order;

  // Per-particle arrays: every array for_each_array lists as a particle array of full length is
  // gathered through the local order (bonds.offsets, one longer, is rebuilt below). Both visits list
  // the arrays in the same order, so the k-th particle array of one is the k-th of the other.
  std::vector<const void*> sources;
  for_each_array(full, [&](ArrayKind kind, const char*, const auto& array) {
    if (kind == ArrayKind::particle) sources.push_back(&array);
  });
  // dst[l] = src[order[l]] for a full-length src; other sizes (unused arrays, bonds.offsets) are skipped.
  auto through_order = [&](const auto& src, auto& dst) {
    if (src.size() != n_full) return;
    dst.resize(n);
    for (std::size_t l = 0; l < n; ++l) dst[l] = src[order[l]];
  };
  std::size_t k = 0;
  for_each_array(*w, [&](ArrayKind kind, const char*, auto& array) {
    if (kind != ArrayKind::particle) return;
    through_order(*static_cast<const std::remove_reference_t<decltype(array)>*>(sources[k++]), array);
  });
  // The embedded mesh's per-particle held rotations (systems/mesh_rotations.cpp) are stepped here, on
  // the owned particles' families; rank 0's full world keeps the mesh itself (runtime.hpp).
  const EmbeddedMesh& fe = full.embedded;
  EmbeddedMesh& e = w->embedded;
  through_order(fe.held_deformation, e.held_deformation);
  through_order(fe.held_tracked, e.held_tracked);
  through_order(fe.held_fits, e.held_fits);
  through_order(fe.held_broken_seen, e.held_broken_seen);

  // Ghosts: integration and colliders leave them alone (the halo brings their motion).
  for (std::size_t l = 0; l < n; ++l)
    if (l < shift || l >= shift + layout.owned_count) w->particles.flags[l] |= kPrescribed;

  // Bonds: owned rows as they are (neighbours mapped to local), ghost rows empty.
  const Bonds& fb = full.bonds;
  Bonds& b = w->bonds;
  const std::uint32_t bond_first = fb.offsets[d.first], bond_last = fb.offsets[d.last];
  b.offsets = owned_row_offsets(fb.offsets, layout);
  auto slice = [&](const auto& src, auto& dst) {
    if (src.empty()) return dst.clear();
    dst.assign(src.begin() + bond_first, src.begin() + bond_last);
  };
  slice(fb.alive, b.alive);
  slice(fb.plastic_extension, b.plastic_extension);
  slice(fb.plastic_extension_mirror, b.plastic_extension_mirror);
  slice(fb.break_scale, b.break_scale);
  // Most neighbours are owned (a Morton range holds most of its families): those map by a shift, the
  // ghosts by a search in the (increasing) local order. Rank 0 makes every part, so this loop runs over
  // every bond of the world once per split: 1.9e7 binary searches per part of the full bunny at 4 ranks.
  b.neighbor.resize(bond_last - bond_first);
  const std::uint32_t owned_first = d.first, owned_last = d.last;
  for (std::size_t q = 0; q < bond_last - bond_first; ++q) {
    const std::uint32_t g = fb.neighbor[bond_first + q];
    b.neighbor[q] = g >= owned_first && g < owned_last ? g - owned_first + shift : local_of(order, g);
  }

  // FEM mode (components/fem.hpp; no bonds, the particles are the mesh vertices): the tets at the
  // owned vertices, in increasing global order, with their constants, and each owned vertex's corners
  // in the same order as in the whole world, so its force sums the same values in the same order.
  // Ghost vertices get no corners (their force is never read).
  if (full.settings.solver != scene::Solver::peridynamics) make_local_fem(full, layout, *w);

  // Boundary conditions: each list restricted to the owned particles.
  for (const auto& list : full.boundary.particles) w->boundary.particles.push_back(owned_part(list, d, shift));
  w->boundary.constrained = owned_part(full.boundary.constrained, d, shift);

  // Surface patches (CSR by particle): owned rows keep their patches, in order, so a global patch
  // index p of an owned particle is local patch p − offsets[first].
  const SurfacePatches& fs = full.surface;
  SurfacePatches& s = w->surface;
  std::uint32_t patch_first = 0;
  if (!fs.offsets.empty()) {
    patch_first = fs.offsets[d.first];
    const std::uint32_t patch_last = fs.offsets[d.last];
    s.offsets = owned_row_offsets(fs.offsets, layout);
    s.area.assign(fs.area.begin() + patch_first, fs.area.begin() + patch_last);
    s.normal.assign(fs.normal.begin() + patch_first, fs.normal.begin() + patch_last);
    s.offset.assign(fs.offset.begin() + patch_first, fs.offset.begin() + patch_last);
    s.radius.assign(fs.radius.begin() + patch_first, fs.radius.begin() + patch_last);
    s.corner.assign(fs.corner.begin() + patch_first, fs.corner.begin() + patch_last);
  }

  // Loads: particle lists restricted to the owned particles, with their patch rows.
  const LoadSet& fl = full.loads;
  LoadSet& ld = w->loads;
  for (std::size_t q = 0; q < fl.loads.size(); ++q) {
    const auto& list = fl.particles[q];
    const bool has_patches = q < fl.patch_offsets.size() && !fl.patch_offsets[q].empty();
    std::vector<std::uint32_t> particles, patch_offsets, patches;
    if (has_patches) patch_offsets.push_back(0);
    for (std::size_t m = 0; m < list.size(); ++m) {
      const std::uint32_t g = list[m];
      if (g < d.first || g >= d.last) continue;
      particles.push_back(g - d.first + shift);
      if (has_patches) {
        for (std::uint32_t pe = fl.patch_offsets[q][m]; pe < fl.patch_offsets[q][m + 1]; ++pe)
          patches.push_back(fl.patches[q][pe] - patch_first);
        patch_offsets.push_back(static_cast<std::uint32_t>(patches.size()));
      }
    }
    ld.particles.push_back(std::move(particles));
    ld.patch_offsets.push_back(std::move(patch_offsets));
    ld.patches.push_back(std::move(patches));
  }

  w->projectiles.bodies = full.projectiles.bodies;
  if (!to_send) finish_local_world(full, layout, *w);
  return w;
}

namespace {
// A local world's pieces, each a value or an array's count and then its elements (write_local_world).
template <class T>
void put_piece(const PutBytes& put, const T& value) {
  put(&value, sizeof value);
}
template <class V>
void put_array(const PutBytes& put, const V& v) {
  const std::uint64_t count = v.size();
  put_piece(put, count);
  put(v.data(), count * sizeof(v[0]));
}
template <class T>
T take_piece(const TakeBytes& take) {
  T value{};
  take(&value, sizeof value);
  return value;
}
template <class V>
void take_array(const TakeBytes& take, V& v) {
  v.resize(take_piece<std::uint64_t>(take));
  take(v.data(), v.size() * sizeof(v[0]));
}
// The pieces through one buffer: appended to `out`, or read from `message` in order (`what` names it
// in the errors; finish() checks that nothing is left over).
PutBytes appending_to(std::vector<char>& out) {
  return [&out](const void* data, std::size_t bytes) {
    const std::size_t at = out.size();
    out.resize(at + bytes);
    if (bytes) std::memcpy(out.data() + at, data, bytes);
  };
}
struct BufferReader {
  const std::vector<char>& message;
  const char* what;
  std::size_t at = 0;
  void operator()(void* data, std::size_t bytes) {
    if (message.size() - at < bytes) throw std::logic_error(std::string(what) + " ends early");
    if (bytes) std::memcpy(data, message.data() + at, bytes);
    at += bytes;
  }
  void finish() const {
    if (at != message.size()) throw std::logic_error(std::string(what) + ": bytes left over");
  }
};
}  // namespace

void write_local_world(const WorldState& local, const LocalLayout& layout, const PutBytes& put) {
  put_array(put, layout.global_of);
  put_piece(put, layout.owned_begin);
  put_piece(put, layout.owned_count);
  put_piece(put, layout.bond_begin);
  for (const auto* links : {&layout.sends, &layout.receives}) {
    put_piece(put, std::uint64_t{links->size()});
    for (const HaloLink& link : *links) {
      put_piece(put, link.rank);
      put_array(put, link.local);
    }
  }
  // The nested lists' counts first (the receiver sizes them, then for_each_array visits each).
  for (const std::size_t lists : {local.boundary.particles.size(), local.loads.particles.size(),
                                  local.loads.patch_offsets.size(), local.loads.patches.size()})
    put_piece(put, std::uint64_t{lists});
  for_each_array(local, [&](ArrayKind kind, const char* name, const auto& array) {
    if (travels(kind, name)) put_array(put, array);
  });
}

std::unique_ptr<WorldState> read_local_world(const WorldState& shell, LocalLayout& layout, const TakeBytes& take) {
  take_array(take, layout.global_of);
  layout.owned_begin = take_piece<decltype(layout.owned_begin)>(take);
  layout.owned_count = take_piece<decltype(layout.owned_count)>(take);
  layout.bond_begin = take_piece<decltype(layout.bond_begin)>(take);
  for (auto* links : {&layout.sends, &layout.receives}) {
    links->assign(take_piece<std::uint64_t>(take), HaloLink{});
    for (HaloLink& link : *links) {
      link.rank = take_piece<int>(take);
      take_array(take, link.local);
    }
  }
  auto w = std::make_unique<WorldState>();
  set_local_frame(shell, layout, *w);
  for (auto* lists : {&w->boundary.particles, &w->loads.particles, &w->loads.patch_offsets, &w->loads.patches})
    lists->resize(take_piece<std::uint64_t>(take));
  for_each_array(*w, [&](ArrayKind kind, const char* name, auto& array) {
    if (travels(kind, name)) take_array(take, array);
  });
  finish_local_world(shell, layout, *w);
  return w;
}

std::vector<char> pack_local_world(const WorldState& local, const LocalLayout& layout) {
  std::vector<char> out;
  write_local_world(local, layout, appending_to(out));
  return out;
}

std::unique_ptr<WorldState> local_world_from(const WorldState& shell, LocalLayout& layout, const std::vector<char>& message) {
  BufferReader reader{message, "local world message"};
  auto w = read_local_world(shell, layout, std::ref(reader));
  reader.finish();
  return w;
}

std::vector<char> pack_world_frame(const WorldState& whole) {
  std::vector<char> out;
  const PutBytes put = appending_to(out);
  static_assert(std::is_trivially_copyable_v<Clock>);
  put_piece(put, whole.clock);
  put_piece(put, whole.settings.max_speed);
  put_piece(put, whole.contact.largest_distance);
  put_piece(put, whole.settings.contact.time_scale);
  put_piece(put, whole.contact.pairs.skin);
  put_piece(put, std::uint64_t{whole.bodies.size()});
  for (const BodyInfo& b : whole.bodies) {
    put_piece(put, b.first_particle);
    put_piece(put, b.particle_count);
    put_piece(put, b.first_vertex);
    put_piece(put, b.vertex_count);
    put_piece(put, b.mean_edge_length);
    put_piece(put, b.horizon);
  }
  return out;
}

void take_world_frame(WorldState& shell, const std::vector<char>& message) {
  BufferReader reader{message, "world frame"};
  const TakeBytes take = std::ref(reader);
  shell.clock = take_piece<Clock>(take);
  shell.settings.max_speed = take_piece<double>(take);
  shell.contact.largest_distance = take_piece<double>(take);
  shell.settings.contact.time_scale = shell.contact.time_scale = take_piece<double>(take);
  shell.contact.pairs.skin = take_piece<double>(take);
  if (take_piece<std::uint64_t>(take) != shell.bodies.size()) throw std::logic_error("world frame: another scene's bodies");
  for (BodyInfo& b : shell.bodies) {
    b.first_particle = take_piece<std::uint32_t>(take);
    b.particle_count = take_piece<std::uint32_t>(take);
    b.first_vertex = take_piece<std::uint32_t>(take);
    b.vertex_count = take_piece<std::uint32_t>(take);
    b.mean_edge_length = take_piece<double>(take);
    b.horizon = take_piece<double>(take);
  }
  reader.finish();
}

std::vector<std::uint64_t> contact_cells(const WorldState& local, const LocalLayout& layout) {
  const double inv_cell = 1.0 / layout.contact_layer;
  std::vector<std::uint64_t> cells(layout.owned_count);
  for (std::uint32_t m = 0; m < layout.owned_count; ++m)
    cells[m] = systems::key(systems::cell_at(local.particles.position[layout.owned_begin + m], inv_cell));
  std::sort(cells.begin(), cells.end());
  cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
  return cells;
}

void find_contact_sends(const WorldState& local, LocalLayout& layout,
                        const std::vector<std::vector<std::uint64_t>>& cells_by_rank) {
  const double inv_cell = 1.0 / layout.contact_layer;
  const auto& y = local.particles.position;
  layout.contact_sends_before = std::move(layout.contact_sends);
  layout.contact_sends.clear();
  for (int q = 0; q < layout.ranks; ++q) {
    const auto& theirs = cells_by_rank[static_cast<std::size_t>(q)];
    if (q == layout.rank || theirs.empty()) continue;
    // Particles q already holds as bond ghosts have their motion sent anyway.
    std::vector<std::uint32_t> bond_ghosts;
    for (const auto& link : layout.sends)
      if (link.rank == q) bond_ghosts = link.local;
    HaloLink out{q, {}};
    for (std::uint32_t i = layout.owned_begin; i < layout.owned_begin + layout.owned_count; ++i) {
      const systems::Cell c = systems::cell_at(y[i], inv_cell);
      bool near = false;
      for (int dz = -1; dz <= 1 && !near; ++dz)
        for (int dy = -1; dy <= 1 && !near; ++dy)
          for (int dx = -1; dx <= 1 && !near; ++dx)
            near = std::binary_search(theirs.begin(), theirs.end(), systems::key({c.x + dx, c.y + dy, c.z + dz}));
      if (near && !std::binary_search(bond_ghosts.begin(), bond_ghosts.end(), i)) out.local.push_back(i);
    }
    if (!out.local.empty()) layout.contact_sends.push_back(std::move(out));
  }
  layout.refreshed_at.assign(y.begin() + layout.owned_begin, y.begin() + layout.owned_begin + layout.owned_count);
}

namespace {

// Calls f(array) for every per-particle array of the local world's current length (the ones a contact
// ghost record carries), in for_each_array's order, the same on every rank.
template <class W, class F>
void for_each_particle_array(W& local, F&& f) {
  const std::size_t n = local.particles.count();
  for_each_array(local, [&](ArrayKind kind, const char*, auto& array) {
    if (kind == ArrayKind::particle && array.size() == n) f(array);
  });
}

std::size_t record_bytes(const WorldState& local) {
  std::size_t bytes = sizeof(std::uint32_t);  // the global index
  for_each_particle_array(local, [&](const auto& array) { bytes += sizeof(array[0]); });
  return bytes;
}

}  // namespace

std::vector<char> pack_contact_ghosts(const WorldState& local, const LocalLayout& layout, const HaloLink& link) {
  // What link.rank holds already: the previous refresh's list to it (increasing local index).
  const std::vector<std::uint32_t>* held = nullptr;
  for (const auto& before : layout.contact_sends_before)
    if (before.rank == link.rank) held = &before.local;
  auto entering = [&](std::uint32_t i) { return !held || !std::binary_search(held->begin(), held->end(), i); };
  std::size_t new_count = 0;
  for (std::uint32_t i : link.local) new_count += entering(i);
  const std::size_t record = record_bytes(local) - sizeof(std::uint32_t);
  std::vector<char> out(sizeof(std::uint32_t) * (1 + link.local.size()) + new_count * record);
  char* at = out.data();
  const auto count = static_cast<std::uint32_t>(link.local.size());
  std::memcpy(at, &count, sizeof count);
  at += sizeof count;
  for (std::uint32_t i : link.local) {
    std::memcpy(at, &local.global_index[i], sizeof(std::uint32_t));
    at += sizeof(std::uint32_t);
  }
  for (std::uint32_t i : link.local) {
    if (!entering(i)) continue;
    for_each_particle_array(local, [&](const auto& array) {
      std::memcpy(at, &array[i], sizeof(array[0]));
      at += sizeof(array[0]);
    });
  }
  return out;
}

void set_contact_ghosts(WorldState& local, LocalLayout& layout,
                        const std::vector<std::pair<int, std::vector<char>>>& messages) {
  // Each sender's list as whole records (global index, then every array), in its list's order: a
  // ghost this rank holds from that sender is copied from its current record (its motion is this
  // step's, the rest is never read of a contact ghost, local_world.hpp), an entering one from the
  // message. Copied out before the arrays are cut back below.
  const std::size_t record = record_bytes(local), payload = record - sizeof(std::uint32_t);
  std::vector<std::pair<int, std::vector<char>>> received_by_rank;
  for (const auto& [rank, bytes] : messages) {
    std::uint32_t count = 0;
    if (bytes.size() < sizeof count) throw std::logic_error("contact ghost message without its count");
    std::memcpy(&count, bytes.data(), sizeof count);
    const char* globals = bytes.data() + sizeof count;
    const char* next_record = globals + std::size_t{count} * sizeof(std::uint32_t);
    const char* const end = bytes.data() + bytes.size();
    const std::vector<std::uint32_t>* held = nullptr;  // this rank's contact ghosts from `rank` (global order)
    for (const auto& link : layout.contact_receives)
      if (link.rank == rank) held = &link.local;
    std::vector<char> whole(std::size_t{count} * record);
    char* at = whole.data();
    for (std::uint32_t m = 0; m < count; ++m) {
      std::uint32_t global = 0;
      std::memcpy(&global, globals + std::size_t{m} * sizeof global, sizeof global);
      std::memcpy(at, &global, sizeof global);
      at += sizeof global;
      const std::uint32_t* kept = nullptr;  // its local index, when held
      if (held) {
        const auto it = std::lower_bound(held->begin(), held->end(), global,
                                         [&](std::uint32_t i, std::uint32_t g) { return layout.global_of[i] < g; });
        if (it != held->end() && layout.global_of[*it] == global) kept = &*it;
      }
      if (kept) {
        const std::uint32_t i = *kept;
        for_each_particle_array(local, [&](const auto& array) {
          std::memcpy(at, &array[i], sizeof(array[0]));
          at += sizeof(array[0]);
        });
      } else {
        if (end - next_record < static_cast<std::ptrdiff_t>(payload))
          throw std::logic_error("contact ghost message from rank " + std::to_string(rank) + " lacks a record");
        std::memcpy(at, next_record, payload);
        next_record += payload;
        at += payload;
      }
    }
    if (next_record != end)
      throw std::logic_error("contact ghost message from rank " + std::to_string(rank) + " has records left over");
    received_by_rank.emplace_back(rank, std::move(whole));
  }
  std::size_t total = 0;
  for (const auto& [rank, bytes] : received_by_rank) total += bytes.size() / record;
  // Drop the previous contact ghosts, then append the new ones.
  const std::size_t base = layout.base_count, n = base + total;
  for_each_particle_array(local, [&](auto& array) { array.resize(n); });
  auto& offsets = local.bonds.offsets;
  offsets.resize(base + 1);
  offsets.resize(n + 1, offsets[base]);  // contact ghosts have no bonds here
  layout.global_of.resize(base);
  layout.contact_receives.clear();
  std::size_t at_particle = base;
  for (const auto& [rank, bytes] : received_by_rank) {
    if (bytes.empty()) continue;
    HaloLink in{rank, {}};
    const char* at = bytes.data();
    for (std::size_t m = 0; m < bytes.size() / record; ++m, ++at_particle) {
      const auto i = static_cast<std::uint32_t>(at_particle);
      std::uint32_t global = 0;
      std::memcpy(&global, at, sizeof global);
      at += sizeof global;
      for_each_particle_array(local, [&](auto& array) {
        std::memcpy(static_cast<void*>(&array[i]), at, sizeof(array[0]));
        at += sizeof(array[0]);
      });
      local.particles.flags[i] |= kPrescribed;
      layout.global_of.push_back(global);
      in.local.push_back(i);
    }
    layout.contact_receives.push_back(std::move(in));
  }
  local.global_index = layout.global_of;
  EmbeddedMesh& e = local.embedded;  // held rotations: contact ghosts' are never read
  if (!e.held_deformation.empty()) {
    e.held_deformation.resize(n, Mat3::Identity());
    e.held_tracked.resize(n, 1);
    e.held_fits.resize(n, 0);
    e.held_broken_seen.resize(n, 0);
  }
  systems::replace_contact_tail(local, base);
  systems::resize_projectiles(local);
}

namespace {

// A double as a uint64 in the same order (for the MIN reduction): non-negative values get the sign
// bit set, negative ones are complemented (so a larger magnitude comes lower). NaN never reaches it.
std::uint64_t ordered_bits(double x) {
  const auto u = std::bit_cast<std::uint64_t>(x);
  constexpr std::uint64_t sign = std::uint64_t{1} << 63;
  return (u & sign) ? ~u : (u | sign);
}
double from_ordered_bits(std::uint64_t k) {
  constexpr std::uint64_t sign = std::uint64_t{1} << 63;
  return std::bit_cast<double>((k & sign) ? (k & ~sign) : ~k);
}

}  // namespace

double contact_ghost_lookahead(const WorldState& local, std::uint32_t i, bool constrained) {
  const double dt = local.clock.dt;
  const auto& p = local.particles;
  const double v = p.velocity[i].norm(), a = p.acceleration[i].norm();
  const double reach = systems::collider_lookahead(local, i, dt * (v + 0.5 * dt * a));  // D_i and the push-out
  return constrained ? std::max(reach, 2.0 * dt * (v + dt * a)) : reach;
}

ContactGhostMotion contact_ghost_motion(const WorldState& local, const LocalLayout& layout) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  ContactGhostMotion out;
  const auto unbounded = [&] {
    out.within_half_skin = false;
    out.low = Vec3::Constant(-inf);
    out.high = Vec3::Constant(inf);
    return out;
  };
  if (layout.refreshed_at.size() != layout.owned_count) return unbounded();
  const double half_skin = 0.5 * layout.contact_skin;
  const auto& y = local.particles.position;
  bool finite = true;
  const auto measure = [&](std::uint32_t i, bool constrained) {
    const Vec3 d = y[i] - layout.refreshed_at[i - layout.owned_begin];
    const double ahead = contact_ghost_lookahead(local, i, constrained);
    const double reach = d.norm() + ahead;
    finite = finite && std::isfinite(reach);
    out.within_half_skin = out.within_half_skin && reach <= half_skin;
    out.low = out.low.cwiseMin(d - Vec3::Constant(ahead));
    out.high = out.high.cwiseMax(d + Vec3::Constant(ahead));
  };
  // Boundary conditions' particles (owned, local indices; the list is sorted) take their wider
  // look-ahead: one cursor walks the list beside the owned range, so each particle is measured once.
  const auto& constrained = local.boundary.constrained;
  std::size_t next = 0;
  for (std::uint32_t m = 0; m < layout.owned_count; ++m) {
    const std::uint32_t i = layout.owned_begin + m;
    while (next < constrained.size() && constrained[next] < i) ++next;
    measure(i, next < constrained.size() && constrained[next] == i);
  }
  if (!finite) return unbounded();  // NaN: stale (the health check reports it)
  return out;
}

ContactGhostMotion combine(const ContactGhostMotion& a, const ContactGhostMotion& b) {
  return {a.within_half_skin && b.within_half_skin, a.low.cwiseMin(b.low), a.high.cwiseMax(b.high)};
}

void encode_contact_ghost_motion(const ContactGhostMotion& motion, std::uint64_t* words) {
  words[0] = motion.within_half_skin ? 1 : 0;
  for (int k = 0; k < 3; ++k) {
    words[1 + k] = ordered_bits(motion.low[k]);
    words[4 + k] = ~ordered_bits(motion.high[k]);
  }
}

ContactGhostMotion decode_contact_ghost_motion(const std::uint64_t* words) {
  ContactGhostMotion motion;
  motion.within_half_skin = words[0] != 0;
  for (int k = 0; k < 3; ++k) {
    motion.low[k] = from_ordered_bits(words[1 + k]);
    motion.high[k] = from_ordered_bits(~words[4 + k]);
  }
  return motion;
}

bool contact_ghosts_stale(const ContactGhostMotion& everyone, double contact_skin) {
  if (everyone.within_half_skin) return false;  // (A); also when no particle was measured
  return !((everyone.high - everyone.low).norm() <= contact_skin);  // (B); an infinite box fails it
}

}  // namespace perifx::distributed
