// Contact system: short-range repulsion between particles that are not joined by an alive bond
// (particles of different bodies, or fragments after fracture), the usual peridynamic practice
// (systems/README.md §8.4, "What the paper leaves out").
//
// Pair (i, j), r = y_j − y_i, d = |r|, n = r/d, contact distance
//   d_c = distance_factor·(s_i + s_j)/2,  s = ∛V (a particle's size; ≈ the mean particle spacing),
// and for two particles of the same body d_c ≤ |x_j − x_i| too, so a broken bond's ends at their
// reference distance are not pushed apart. With penetration g = d_c − d > 0:
//   normal   f_n = max(0, k·g − c·v_n),  v_n = (v_j − v_i)·n,  c = 2ζ√(k·m_ij),  m_ij = m_i m_j/(m_i+m_j)
//   friction f_t = min(μ·f_n, ¼·m_ij·|v_t|/dt) along v_t = (v_j − v_i) − v_n n (Coulomb, capped so it
//            cannot reverse the relative sliding within one step)
//   force on i: −f_n n + f_t v_t/|v_t|      (the law: contact_law.hpp, shared with projectiles.cpp).
// Stiffness: k = stiffness_factor·min(m_i, m_j)/τ_k², τ_k = max(τ, dt), τ the scene's contact time
// scale (ContactState::time_scale; engine/setup/world_setup.cpp: the automatic step before it is fitted
// to the frames, whatever step the scene gives). One contact spring alone then has
// ω²dt² = k/m_ij·dt² ≤ 2·stiffness_factor·(dt/τ_k)² ≤ 2·stiffness_factor, so with the default 0.05 and
// the handful of contacts a surface particle has, contact adds only a small fraction to the (ω·dt)² ≤ 4
// budget of the explicit step, whatever the material: it never forces a smaller time step. Since τ
// does not depend on the step, neither does the contact while dt ≤ τ (penetration under an impact at
// speed v is ≈ v·τ/√stiffness_factor); until 2026-12-07 τ_k was dt itself, and the jelly of
// jello_bullet.json lost 29,644 bonds to its bullet at dt = 2.5e-5 s and 2,432 at 5.5e-5 s.
//
// Neighbour search: a Verlet list with a skin (components/contact.hpp, ContactPairs). The list holds,
// per particle, the unbonded particles within reach = largest d_c + skin. Positions are measured from
// the centroid c of the owned particles (all of them in one process; a common translation changes no
// distance), z_i = y_i − c. Each
// particle remembers z_i at its own last search, and only a particle that has moved more than
// h = 0.3 skin (kMoveLimit) from there is searched again ("moved"), with its pairs re-decided on both
// sides; the whole list is rebuilt only at the start or when more than 1/16 of the particles moved
// (update_moved_pairs, rebuild_pairs; 1/8 until 2026-12-07: a rebuild searches half the cells around
// each particle, an update all of them, and at 1/16 the bunny preview spends 8 % less time in contact).
// Why that keeps every pair that can come closer than d_c: a pair
// missing from the list was last decided by the search of one end, i, at a time t*, when
// |z_i − z_j| ≥ reach = d_c,max + skin. Since then i has moved at most h and j at most 2h (h each side
// of its own search position), so the pair has closed by at most 3h = 0.9 skin and is still farther
// apart than d_c. A bond that breaks adds its pair when the ends are within reach + ¼ skin
// (kBrokenReachExtra; update_moved_pairs): a pair left out then closes by at most 4h = 1.2 skin, both
// ends at most 2h from where they are then, and 1.2 < 1 + ¼. (h was skin/4 with additions at reach
// until 2026-12-03; with 0.3 the bunny preview rebuilds its whole list 63 times instead of 111 and
// spends 8 % less time in contact.)
// So one fast fragment costs a search for itself, not a rebuild of the whole
// list (the sheet preview rebuilt it 987 times in 4000 steps when any skin/2 motion rebuilt all).
// The search uses a hashed uniform grid (spatial_grid.hpp; cell = reach, counting sort, stable:
// particles in a bucket stay in index order) and visits 9 rows of 3 cells in a fixed order. A full
// rebuild searches only the forward half of those cells (for_each_within_forward), so each pair is tested
// once, and writes it on both sides. An update's search looks up a second grid, of the search positions
// (for_each_candidate_moved), which it rebuilds only now and then, and a small third one of the particles
// searched since (the displaced grid, sorted again each update). The skin, 0.6 d_c, is what balances the cost on the fast
// fragments of the bunny preview (dt 5e-4 s, 3 m/s landing): 0.3 rebuilt the list 313 times in 1,000
// steps; a larger skin searches more candidates per search (∝ reach³). Each particle then gathers the forces on
// itself from its list (no scatter, no atomics), in increasing (global) index of the partner (sort_rows),
// so the result depends neither on the thread count nor on the list's history: a resumed run, or a rank
// of a distributed run, whose list was built differently, sums the same contacts in the same order.
// In a distributed run's local world (engine/distributed/local_world.hpp) only owned particles get
// forces; a ghost has no bond row, so a ghost's own search keeps only owned partners and reads whether
// they are bonded from their rows.
// Near and far entries: every particle i is within h of its own search position b_i (z_i − b_i, the
// moved test), so |y_i − y_j| ≥ |b_i − b_j| − 2h. A pair with |b_i − b_j| ≥ d_c,ij + 2h (d_c,ij uncapped)
// cannot touch until one end is searched again, and then the pair is re-decided anyway. Each row keeps
// its near entries first (pr.near_count of them), then the far ones, each part in increasing global
// index, and the forces read only the near part: a quarter of the fig01 preview's entries, a fifth of
// the bunny's. The classification depends on the two search positions only, so it changes only where
// an update rewrites a row (sort_rows re-partitions every row it re-sorts). The sum runs over the same
// contacts in the same order as over the whole row, so the forces have the same bits.
// Every scalar of the pair term is symmetric in (i, j) and every vector flips sign exactly with r and
// v_j − v_i, so the force j computes on itself is bit-for-bit the negative of the one i computes:
// momentum is conserved. "Bonded": per-thread stamps of i's alive partners. Bonded pairs are left out
// of the list; bonds never heal.
//
// Reads: position, velocity, bond_alive, damage (broken-bond counts, to notice breaks).
// Writes: contact_force, contact_list (its own grid and pair list).
#include <oneapi/tbb/info.h>
#include <oneapi/tbb/parallel_reduce.h>
#include <oneapi/tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <limits>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include "contact_law.hpp"
#include "huge_pages.hpp"
#include "parallel.hpp"
#include "spatial_grid.hpp"
#include "systems.hpp"

namespace perifx::systems {
namespace {

constexpr double kSkinFraction = 0.6;     // skin = this × the largest contact distance (see above)
constexpr std::size_t kFullRebuildShare = 16;  // rebuild the whole list when more than n/16 moved (below)
constexpr double kMoveLimit = 0.3;        // search a particle again once it moved this × skin (above)
constexpr double kBrokenReachExtra = 0.25;  // a broken bond's pair is added within reach + this × skin
static_assert(3 * kMoveLimit < 1.0 && 4 * kMoveLimit < 1.0 + kBrokenReachExtra,
              "a pair left out of the list must not close to within the largest contact distance");
// Calls visit(j) for every unbonded particle j ≠ i within the grid cell size of i, in a fixed order
// (9 rows of 3 cells; kForwardHalf: only the forward half of them, for_each_within_forward, so that a
// search of every particle visits each pair once). `stamp` is this (pass, particle)'s unique mark and
// `marks` the calling thread's row of ContactPairs::bonded_stamp.
// Marks i's alive bond partners j with marks[j] = stamp.
void mark_bonded(const WorldState& w, std::uint32_t i, std::uint64_t stamp, std::uint64_t* marks) {
  const auto& b = w.bonds;
  std::uint32_t bond = b.offsets[i];
  const std::uint32_t bonds_end = b.offsets[i + 1];
#if defined(__AVX512F__) && defined(__AVX512BW__) && defined(__AVX512VL__)
  // Eight partners per masked scatter: a row's partners are distinct, so no two lanes write one mark.
  // (A tenth of a search's time in the bunny preview, whose soft body searches ~1,400 particles a step.)
  const __m512i stamps = _mm512_set1_epi64(static_cast<long long>(stamp));
  for (; bond + 8 <= bonds_end; bond += 8) {
    const __m128i alive = _mm_loadl_epi64(reinterpret_cast<const __m128i*>(b.alive.data() + bond));
    const __mmask8 m = static_cast<__mmask8>(_mm_test_epi8_mask(alive, alive));
    const __m256i j = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(b.neighbor.data() + bond));
    _mm512_mask_i32scatter_epi64(marks, m, j, stamps, 8);
  }
#endif
  for (; bond < bonds_end; ++bond)
    if (b.alive[bond]) marks[b.neighbor[bond]] = stamp;
}

// Whether j (within reach of i) is a candidate of i: not i, not bonded to it (marks, mark_bonded). A
// ghost of a distributed run has no bond row: its pairs with other ghosts are left out (nobody reads
// their forces), and whether it is bonded to an owned particle j is read from j's row.
bool unbonded_candidate(const WorldState& w, std::uint32_t i, std::uint32_t j, std::uint64_t stamp,
                        const std::uint64_t* marks) {
  if (j == i || marks[j] == stamp) return false;
  if (w.owns(i)) return true;
  if (!w.owns(j)) return false;
  const auto& b = w.bonds;
  for (std::uint32_t k = b.offsets[j]; k < b.offsets[j + 1]; ++k)
    if (b.neighbor[k] == i) return b.alive[k] == 0;
  return true;
}

template <bool kForwardHalf = false, class Visit>
void for_each_candidate(const WorldState& w, std::uint32_t i, std::uint64_t stamp, std::uint64_t* marks,
                        Visit&& visit) {
  const auto& g = w.contact.grid;
  mark_bonded(w, i, stamp, marks);
  const Vec3 yi = w.particles.position[i];
  const double reach2 = g.cell * g.cell;
  auto test = [&](std::uint32_t q) {  // q is within reach (for_each_within's branch-free filter)
    if (const std::uint32_t j = g.sorted[q]; unbonded_candidate(w, i, j, stamp, marks)) visit(j);
  };
  if constexpr (kForwardHalf) for_each_within_forward(g, yi, i, reach2, test);
  else for_each_within(g, yi, reach2, test);
}

// The same candidates as for_each_candidate (every unbonded j ≠ i within reach of i now; another order)
// without a grid of the current positions. ContactState::search_grid holds the search positions b_j
// (relative to the centroid at each search) as of its build. A particle not displaced since then was
// not searched again, and is not moved now: |y_j − centroid − b_j| ≤ h = 0.3 skin (the moved test), so
// when it is within reach R of i, b_j is within R + h of y_i − centroid, which the grid's cells of
// (R + h)(1 + 1e-6) cover. The displaced particles (this update's moved ones among them) were searched
// since, so the same holds of their latest search positions: few of them are tested one by one, more
// are looked up in ContactState::displaced_grid (`displaced_in_grid`; prepare_search_grid). Each candidate then passes the grid's own distance test on
// the current positions (the IEEE expression of scan_range: Eigen's squared norm of y_j − y_i, NaN
// passing), so the same pairs pass. (The visit order differs from a search of the current positions;
// a searched row is sorted afterwards, so the list does not depend on it.)
template <class Visit>
void for_each_candidate_moved(const WorldState& w, std::uint32_t i, const Vec3& centroid, bool displaced_in_grid,
                              std::uint64_t stamp, std::uint64_t* marks, Visit&& visit) {
  const auto& c = w.contact;
  const auto& sg = c.search_grid;
  const auto& pr = c.pairs;
  const auto& y = w.particles.position;
  mark_bonded(w, i, stamp, marks);
  const Vec3 yi = y[i];
  const double reach2 = c.grid.cell * c.grid.cell;
  auto test = [&](std::uint32_t j) {
    if (!((y[j] - yi).squaredNorm() >= reach2) && unbonded_candidate(w, i, j, stamp, marks)) visit(j);
  };
  const Vec3 zi = yi - centroid;
  for_each_within(sg, zi, sg.cell * sg.cell, [&](std::uint32_t q) {
    if (const std::uint32_t j = sg.sorted[q]; !pr.displaced[j]) test(j);
  });
  if (!displaced_in_grid) {
    for (const std::uint32_t j : pr.displaced_list) test(j);
    return;
  }
  const auto& dg = c.displaced_grid;
  for_each_within(dg, zi, dg.cell * dg.cell, [&](std::uint32_t q) { test(dg.sorted[q]); });
}

// The search grid's cell: the list reach R plus h = 0.3 skin, widened by a relative 1e-6 so that the
// rounding of positions far from the centroid cannot leave a pair within R outside it.
double search_cell(const ContactState& c) {
  return (c.largest_distance + c.pairs.skin + kMoveLimit * c.pairs.skin) * (1.0 + 1e-6);
}

// At most this share of the particles are displaced (ContactState::displaced_grid's room) before the
// search grid is built again.
constexpr std::size_t kDisplacedShare = 8;
std::size_t displaced_room(std::size_t n) { return n / kDisplacedShare + 1; }

// Before an update's search: the moved particles' new search positions, and which grid the search reads.
// The search grid (for_each_candidate_moved) holds every particle not displaced. Each search tests the
// displaced ones (this update's moved ones among them) one by one while that costs less than sorting
// them (displaced × moved ≤ particles); beyond that they are sorted into the displaced grid, by their
// search positions, every update: a counting sort of the displaced only (in the glass-wall shot ~1,400
// moved per update among 6e5 particles, and a sort of every particle each update was most of an
// update). The search grid is built again when more than 1/8 of the particles are displaced. When more
// than 1/32 move in one update (a soft body wobbling after it landed: the bunny preview), the grid of
// the current positions is built and searched as a full rebuild does (for_each_candidate): the search
// grid would then be built every few updates, and its cells, 0.3 skin wider, hold twice the candidates.
enum class UpdateSearch { current_grid, search_grid, search_and_displaced_grids };
void forget_displaced(ContactPairs& pr) {
  for (const std::uint32_t i : pr.displaced_list) pr.displaced[i] = 0;
  pr.displaced_list.clear();
}
UpdateSearch prepare_search_grid(WorldState& w, const Vec3& centroid) {
  auto& c = w.contact;
  auto& pr = c.pairs;
  const auto& p = w.particles;
  const std::size_t n = p.count(), m = pr.moved_list.size();
  parallel_for_each(m, [&](std::size_t a) {
    const std::uint32_t i = pr.moved_list[a];
    pr.built_position[i] = p.position[i] - centroid;
  }, 256);
  if (32 * m > n) {
    forget_displaced(pr);
    pr.search_grid_valid = false;
    build_grid(c.grid, p.position);
    return UpdateSearch::current_grid;
  }
  std::size_t newly = 0;
  for (const std::uint32_t i : pr.moved_list) newly += !pr.displaced[i];
  if (pr.search_grid_valid && pr.displaced_list.size() + newly <= displaced_room(n)) {
    for (const std::uint32_t i : pr.moved_list)
      if (!pr.displaced[i]) {
        pr.displaced[i] = 1;
        pr.displaced_list.push_back(i);
      }
    if (pr.displaced_list.size() * m <= n) return UpdateSearch::search_grid;
    build_grid_of(c.displaced_grid, pr.built_position, pr.displaced_list);
    ++pr.displaced_grid_builds;
    return UpdateSearch::search_and_displaced_grids;
  }
  forget_displaced(pr);
  build_grid(c.search_grid, pr.built_position);
  pr.search_grid_valid = true;
  ++pr.search_grid_builds;
  return UpdateSearch::search_grid;
}

// The calling worker's row of the bonded-partner marks.
std::uint64_t* stamp_row(ContactPairs& pr, std::size_t n) {
  const int slot = tbb::this_task_arena::current_thread_index();
  const std::size_t row = slot >= 0 && static_cast<std::size_t>(slot) < pr.stamp_slots ? std::size_t(slot) : 0;
  return pr.bonded_stamp.data() + row * n;
}

// What the pair list needs before this step's forces: nothing; an update (update_moved_pairs: a search
// for the particles that moved more than kMoveLimit·skin since their own last search, marked in pr.moved, and
// the pairs of bonds broken since the last update); or a full rebuild (first step, or more than
// n/kFullRebuildShare moved).
// `centroid` is the mean position, a fixed-block sum: the same bits for every thread count, and so is
// every decision here (integer counts and per-particle tests).
enum class PairUpdate { none, update, rebuild };
PairUpdate pair_update_needed(WorldState& w, std::uint64_t& broken_now, Vec3& centroid) {
  auto& pr = w.contact.pairs;
  const std::size_t n = w.particles.count();
  broken_now = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, 4096), std::uint64_t{0},
      [&](const tbb::blocked_range<std::size_t>& r, std::uint64_t acc) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) acc += w.state.broken_bonds[i];
        return acc;
      },
      [](std::uint64_t a, std::uint64_t b) { return a + b; });
  const auto& y = w.particles.position;
  // parallel_deterministic_reduce splits and joins the same way for any thread count (and, unlike
  // deterministic_sum, allocates nothing).
  // Over the owned particles: in a distributed run's local world the ghosts come and go with each
  // refresh, and a centroid over them would jump and mark every particle moved (one process: all).
  const std::size_t first = std::min<std::size_t>(w.owned_first, n), last = std::min<std::size_t>(w.owned_last, n);
  centroid = tbb::parallel_deterministic_reduce(
                 tbb::blocked_range<std::size_t>(first, last, 4096), Vec3(Vec3::Zero()),
                 [&](const tbb::blocked_range<std::size_t>& r, Vec3 acc) {
                   for (std::size_t i = r.begin(); i != r.end(); ++i) acc += y[i];
                   return acc;
                 },
                 [](const Vec3& a, const Vec3& b) { return Vec3(a + b); }) /
             double(std::max<std::size_t>(last - first, 1));
  if (!pr.valid) return PairUpdate::rebuild;
  const double limit = kMoveLimit * pr.skin, limit2 = limit * limit;
  const Vec3 c = centroid;
  const std::size_t moved = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, 4096), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& r, std::size_t acc) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          const bool m = !((y[i] - c - pr.built_position[i]).squaredNorm() <= limit2);  // NaN: moved
          pr.moved[i] = m;
          acc += m;
        }
        return acc;
      },
      [](std::size_t a, std::size_t b) { return a + b; });
  if (moved > n / kFullRebuildShare) return PairUpdate::rebuild;
  return moved > 0 || broken_now != pr.broken_at_build ? PairUpdate::update : PairUpdate::none;
}

// True when particle i has bonds that broke since the list last took in i's breaks (its broken-bond
// count changed): only those particles' bonds need scanning.
bool has_new_breaks(const WorldState& w, std::size_t i) {
  return w.state.broken_bonds[i] != w.contact.pairs.broken_seen[i];
}

// Bit t: bonds.alive[64·word + t] != 0 (0 past the last bond).
std::uint64_t alive_bits(const std::vector<std::uint8_t>& alive, std::size_t word) {
  const std::size_t first = 64 * word, count = std::min<std::size_t>(64, alive.size() - first);
#if defined(__AVX512BW__)
  const __mmask64 valid = count == 64 ? ~__mmask64{0} : (__mmask64{1} << count) - 1;  // no load past the end
  const __m512i v = _mm512_maskz_loadu_epi8(valid, alive.data() + first);
  return _mm512_test_epi8_mask(v, v);
#else
  std::uint64_t bits = 0;
  for (std::size_t t = 0; t < count; ++t) bits |= std::uint64_t{alive[first + t] != 0} << t;
  return bits;
#endif
}

// Calls visit(word, bits) for each word of ContactPairs::alive_at_build that holds bonds of particle i
// that broke since the list last took in i's breaks (bits: those bonds, bit k % 64 for bond k): alive
// then, not now (a bond never heals). Sixty-four bonds per word test instead of a branch per bond: in
// shattering glass a few percent of the particles have new breaks each step, with ~130 bonds each.
template <class Visit>
void for_each_new_break_word(const WorldState& w, std::size_t i, Visit&& visit) {
  const auto& pr = w.contact.pairs;
  const auto& b = w.bonds;
  const std::uint32_t first = b.offsets[i], end = b.offsets[i + 1];
  if (first == end) return;
  for (std::uint32_t word = first / 64, last = (end - 1) / 64; word <= last; ++word) {
    std::uint64_t row = ~std::uint64_t{0};
    if (word == first / 64) row &= ~std::uint64_t{0} << (first % 64);
    if (word == last) row &= ~std::uint64_t{0} >> (63 - (end - 1) % 64);
    // An atomic load: take_in_breaks clears other particles' bits of a shared first or last word meanwhile.
    const std::uint64_t at_build =
        std::atomic_ref<std::uint64_t>(const_cast<std::uint64_t&>(pr.alive_at_build[word])).load(std::memory_order_relaxed);
    if (const std::uint64_t bits = at_build & ~alive_bits(b.alive, word) & row) visit(word, bits);
  }
}

// Calls visit(k) for every bond k of particle i that broke since the list last took in i's breaks,
// in increasing k.
template <class Visit>
void for_each_new_break(const WorldState& w, std::size_t i, Visit&& visit) {
  for_each_new_break_word(w, i, [&](std::uint32_t word, std::uint64_t bits) {
    for (; bits != 0; bits &= bits - 1) visit(64 * word + static_cast<std::uint32_t>(std::countr_zero(bits)));
  });
}

// Records that the list has taken in i's breaks: their bits of alive_at_build cleared. i's bits may
// share their first and last words with the neighbouring particles', which other tasks update at the
// same time: each word is changed with an atomic AND on i's bits only (the bits are read only in other
// passes of the update).
void take_in_breaks(WorldState& w, std::size_t i) {
  auto& pr = w.contact.pairs;
  for_each_new_break_word(w, i, [&](std::uint32_t word, std::uint64_t bits) {
    std::atomic_ref<std::uint64_t>(pr.alive_at_build[word]).fetch_and(~bits, std::memory_order_relaxed);
  });
  pr.broken_seen[i] = w.state.broken_bonds[i];
}

// alive_at_build = bonds.alive, all bonds (word by word, each word written by one task).
void take_in_all_breaks(WorldState& w) {
  auto& pr = w.contact.pairs;
  const auto& alive = w.bonds.alive;
  const std::size_t m = alive.size();
  parallel_for_each(pr.alive_at_build.size(), [&](std::size_t word) {
    std::uint64_t bits = 0;
    for (std::size_t k = 64 * word, end = std::min(m, 64 * word + 64); k < end; ++k)
      bits |= std::uint64_t{alive[k] != 0} << (k % 64);
    pr.alive_at_build[word] = bits;
  }, 1024);
  std::copy(w.state.broken_bonds.begin(), w.state.broken_bonds.end(), pr.broken_seen.begin());
}

// The far end of bond k of particle i, a bond that broke since the last update (for_each_new_break),
// when the pair is unmoved and within reach + ¼ skin now; otherwise kNone.
constexpr std::uint32_t kNone = ~std::uint32_t{0};
std::uint32_t new_pair_of_break(const WorldState& w, std::size_t i, std::uint32_t k) {
  const std::uint32_t j = w.bonds.neighbor[k];
  const auto& y = w.particles.position;
  const double add_reach = w.contact.grid.cell + kBrokenReachExtra * w.contact.pairs.skin;
  return !w.contact.pairs.moved[j] && (y[j] - y[i]).squaredNorm() < add_reach * add_reach ? j : kNone;
}

// d_c of the pair (i, j) before the same-body cap (header): distance_factor·(s_i + s_j)/2, m.
double contact_distance(const ContactState& c, std::uint32_t i, std::uint32_t j) {
  return c.distance_factor * (0.5 * (c.size[i] + c.size[j]));
}

// Writes the entries j of row i with keep(j) to out, near part first (header), and returns how many.
// The kept entries of each part stay in that part, in their order (a row that only loses pairs stays
// split and sorted), and pr.near_count[i] becomes the kept near part's length. out may be the row's own
// start: every entry is read before its place can be written.
template <class Keep>
std::uint32_t filter_row(ContactPairs& pr, std::size_t i, std::uint32_t* out, Keep keep) {
  const std::uint32_t* row = pr.neighbor.data() + pr.offsets[i];
  const std::uint32_t near = pr.near_count[i], length = pr.length[i];
  std::uint32_t q = 0;
  for (std::uint32_t r = 0; r < near; ++r)
    if (keep(row[r])) out[q++] = row[r];
  pr.near_count[i] = q;
  for (std::uint32_t r = near; r < length; ++r)
    if (keep(row[r])) out[q++] = row[r];
  return q;
}

// Room for a row of `length` candidates: a quarter more and 4, so that the rows an update lengthens
// (unmoved particles that moved ones found, new broken-bond pairs) mostly fit in place.
std::uint32_t row_capacity(std::uint32_t length) { return length + 4 + length / 4; }

// Lays the rows out again with room for pr.count[i] candidates each (row_capacity), keeping their
// content; neighbor_next and offsets_next are the scratch. Once per update whose rows outgrew their room.
void lay_out_rows(ContactPairs& pr, std::size_t n) {
  pr.offsets_next[0] = 0;
  for (std::size_t i = 0; i < n; ++i)
    pr.offsets_next[i + 1] = pr.offsets_next[i] + row_capacity(std::max(pr.count[i], pr.length[i]));
  pr.neighbor_next.resize(pr.offsets_next[n]);
  parallel_for_each(n, [&](std::size_t i) {
    std::copy_n(pr.neighbor.begin() + pr.offsets[i], pr.length[i], pr.neighbor_next.begin() + pr.offsets_next[i]);
  }, 1024);
  std::swap(pr.offsets, pr.offsets_next);
  std::swap(pr.neighbor, pr.neighbor_next);
  ++pr.layouts;
}

// Sets partner_moved[j] = value for every j in a moved particle's (old) row: by the list's symmetry,
// the rows that hold a moved partner.
void mark_partners_of_moved(ContactPairs& pr, std::uint8_t value) {
  for (const std::uint32_t i : pr.moved_list)
    for (std::uint32_t q = pr.offsets[i], end = q + pr.length[i]; q < end; ++q) pr.partner_moved[pr.neighbor[q]] = value;
}

// Whether j is near i (header): its search position is within d_c,ij + 2h of i's, widened by a relative
// 1e-6 so that the rounding of positions far from the centroid cannot make a touching pair far.
bool is_near(const WorldState& w, std::uint32_t i, std::uint32_t j) {
  const auto& c = w.contact;
  const double reach = (contact_distance(c, i, j) + 2.0 * kMoveLimit * c.pairs.skin) * (1.0 + 1e-6);
  return !((c.pairs.built_position[j] - c.pairs.built_position[i]).squaredNorm() >= reach * reach);  // NaN: near
}

// Puts every particle's candidates in increasing global index (WorldState::global_index; the local
// index in one process). The force on a particle is summed over its list in this order, so it does not
// depend on how the list was built or updated, on which rank the particle lives, or on whether the run
// was resumed from a checkpoint (which rebuilds the list). Rows are short and mostly sorted already
// (an update keeps the order of what it keeps): insertion sort, one row per task. After an update
// (only_marked) only the rows it marked in pr.resort are sorted: the others kept a subset of a sorted
// row. Passing over every row took a sixth of contact's time in the shattered glass preview, which
// updates its list nearly every step.
// A row it sorts it first splits into its near and far part (is_near; pr.near_count), each then sorted.
void sort_rows(WorldState& w, bool only_marked) {
  auto& pr = w.contact.pairs;
  const auto& global = w.global_index;
  auto key = [&](std::uint32_t j) { return global.empty() ? j : global[j]; };
  auto sort = [&](std::uint32_t* row, std::uint32_t length) {
    for (std::uint32_t a = 1; a < length; ++a) {
      const std::uint32_t j = row[a], kj = key(j);
      std::uint32_t at = a;
      for (; at > 0 && key(row[at - 1]) > kj; --at) row[at] = row[at - 1];
      row[at] = j;
    }
  };
  parallel_for_each(w.particles.count(), [&](std::size_t i) {
    if (only_marked && !pr.resort[i]) return;
    pr.resort[i] = 0;
    std::uint32_t* row = pr.neighbor.data() + pr.offsets[i];
    const std::uint32_t length = pr.length[i];
    const auto ii = static_cast<std::uint32_t>(i);
    const std::uint32_t near = static_cast<std::uint32_t>(
        std::partition(row, row + length, [&](std::uint32_t j) { return is_near(w, ii, j); }) - row);
    pr.near_count[i] = near;
    sort(row, near);
    sort(row + near, length - near);
  }, 1024);
}

// Searches the moved particles (pr.moved) again and re-decides every pair with a moved end; keeps
// the other pairs and adds those of bonds broken since the last update that are within reach now (see
// the header for why that is enough; both ends of a bond see the same bit-symmetric test). With no
// moved particle it is only that addition (no search). New list of
//   a moved particle i:  its search (unbonded particles within reach now), in grid-visit order;
//   any other particle j: its old pairs with unmoved partners, in their order; then the bonds broken
//                         since the last update whose unmoved partner is within reach, in bond order;
//                         then the moved particles whose search found j, in index order.
// A pair of two moved particles is found by both searches (the same distance and bond test), a pair of
// a moved and an unmoved particle is written on both sides from the moved one's search: the list stays
// symmetric. Deterministic: the searches run in parallel into per-particle rows, the one scatter of
// found pairs onto unmoved partners is serial in index order.
// Rows are rewritten in place, within their room (ContactPairs::offsets; row_capacity): only the rows
// that change are written, where updates used to copy the whole list into a new one (a 77k-particle
// glass-wall run: contact 15.7 → 14.2 s on 2 threads). When some row outgrows its room, lay_out_rows
// gives every row room again first (counted in pr.layouts).
void update_moved_pairs(WorldState& w, std::uint64_t broken_now, const Vec3& centroid) {
  auto& c = w.contact;
  auto& pr = c.pairs;
  const auto& p = w.particles;
  const std::size_t n = p.count();
  pr.moved_list.clear();  // reserved to n at setup: no allocation
  for (std::size_t i = 0; i < n; ++i)
    if (pr.moved[i]) pr.moved_list.push_back(static_cast<std::uint32_t>(i));
  const std::size_t m = pr.moved_list.size();
  // 1. Search from every moved particle: count, keeping the first `cap` finds in its scratch row (row a
  // of the moved list; two particle rows each, which fit: an update has at most n/kFullRebuildShare).
  const std::uint32_t cap = static_cast<std::uint32_t>(
      std::min<std::size_t>(2 * ContactPairs::kScratchPerParticle, pr.scratch.size() / std::max<std::size_t>(m, 1)));
  const std::uint64_t search_base = pr.stamp_base, fill_base = search_base + n + 1;
  UpdateSearch search = UpdateSearch::current_grid;
  if (m > 0) {
    search = prepare_search_grid(w, centroid);
    pr.stamp_base = fill_base + n + 1;
  }
  auto for_each_found = [&](std::uint32_t i, std::uint64_t stamp, auto&& visit) {
    if (search != UpdateSearch::current_grid)
      for_each_candidate_moved(w, i, centroid, search == UpdateSearch::search_and_displaced_grids, stamp,
                               stamp_row(pr, n), visit);
    else for_each_candidate(w, i, stamp, stamp_row(pr, n), visit);
  };
  parallel_for_each(m, [&](std::size_t a) {
    const std::uint32_t i = pr.moved_list[a];
    std::uint32_t count = 0;
    std::uint32_t* row = pr.scratch.data() + a * cap;
    for_each_found(i, search_base + i + 1, [&](std::uint32_t j) {
      if (count < cap) row[count] = j;
      ++count;
    });
    pr.count[i] = count;
  }, 64);
  pr.moved_offsets[0] = 0;
  for (std::size_t a = 0; a < m; ++a) pr.moved_offsets[a + 1] = pr.moved_offsets[a] + pr.count[pr.moved_list[a]];
  pr.moved_neighbor.resize(pr.moved_offsets[m]);
  parallel_for_each(m, [&](std::size_t a) {
    const std::uint32_t i = pr.moved_list[a];
    std::uint32_t q = pr.moved_offsets[a];
    if (pr.count[i] <= cap) {
      std::copy_n(pr.scratch.data() + a * cap, pr.count[i], pr.moved_neighbor.data() + q);
      return;
    }
    for_each_found(i, fill_base + i + 1, [&](std::uint32_t j) { pr.moved_neighbor[q++] = j; });
  }, 64);
  // 2. How many moved particles found each unmoved one (serial: a particle can be found by several),
  // and which rows hold a moved partner: the list is symmetric, so they are the moved particles' old
  // rows. Only the rows these name, the moved particles' and those with new breaks change; the others
  // are not touched.
  for (std::size_t q = 0; q < pr.moved_neighbor.size(); ++q)
    if (const std::uint32_t j = pr.moved_neighbor[q]; !pr.moved[j]) ++pr.found_by[j];
  mark_partners_of_moved(pr, 1);
  auto changes = [&](std::size_t j) { return pr.partner_moved[j] || pr.found_by[j] != 0 || has_new_breaks(w, j); };
  // 3. New lengths of the rows that change (count; a moved particle's is its search's), and whether
  // each still fits in its room.
  auto kept = [&](std::size_t j) {
    std::uint32_t count = pr.length[j];
    if (pr.partner_moved[j]) {
      count = 0;
      for (std::uint32_t q = pr.offsets[j], end = q + pr.length[j]; q < end; ++q) count += !pr.moved[pr.neighbor[q]];
    }
    if (has_new_breaks(w, j)) for_each_new_break(w, j, [&](std::uint32_t k) { count += new_pair_of_break(w, j, k) != kNone; });
    return count;
  };
  const bool outgrown = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, 1024), false,
      [&](const tbb::blocked_range<std::size_t>& r, bool acc) {
        for (std::size_t j = r.begin(); j != r.end(); ++j) {
          if (pr.moved[j]) {
            acc |= pr.count[j] > pr.offsets[j + 1] - pr.offsets[j];
          } else if (changes(j)) {
            pr.count[j] = kept(j) + pr.found_by[j];
            acc |= pr.count[j] > pr.offsets[j + 1] - pr.offsets[j];
          } else {
            pr.count[j] = pr.length[j];
          }
        }
        return acc;
      },
      [](bool x, bool y) { return x || y; });
  if (outgrown) lay_out_rows(pr, n);
  // 4. Rewrite in place: an unmoved row keeps its pairs with unmoved partners (filter_row), then takes
  // the pairs of its new breaks, then leaves found_by[j] places for the moved particles that found it
  // (found_by becomes its write cursor). resort marks the rows sort_rows must split and sort: a row
  // that only lost pairs keeps each part sorted; one with anything appended does not.
  parallel_for_each(n, [&](std::size_t j) {
    if (pr.moved[j] || !changes(j)) return;
    std::uint32_t* row = pr.neighbor.data() + pr.offsets[j];
    std::uint32_t q = pr.partner_moved[j] ? filter_row(pr, j, row, [&](std::uint32_t r) { return !pr.moved[r]; })
                                          : pr.length[j];
    const std::uint32_t kept_end = q;
    if (has_new_breaks(w, j))
      for_each_new_break(w, j, [&](std::uint32_t k) {
        if (const std::uint32_t partner = new_pair_of_break(w, j, k); partner != kNone) row[q++] = partner;
      });
    pr.resort[j] = q != kept_end || pr.found_by[j] != 0;
    if (pr.found_by[j] != 0) pr.found_by[j] = pr.offsets[j] + q;
    pr.length[j] = pr.count[j];
  }, 1024);
  mark_partners_of_moved(pr, 0);  // from the moved rows' old content: all 0 again for the next update
  parallel_for_each(m, [&](std::size_t a) {
    const std::uint32_t i = pr.moved_list[a];
    pr.resort[i] = 1;  // its search, in grid-visit order
    std::copy(pr.moved_neighbor.begin() + pr.moved_offsets[a], pr.moved_neighbor.begin() + pr.moved_offsets[a + 1],
              pr.neighbor.begin() + pr.offsets[i]);
    pr.length[i] = pr.count[i];
  }, 64);
  for (std::size_t a = 0; a < m; ++a)
    for (std::uint32_t q = pr.moved_offsets[a]; q < pr.moved_offsets[a + 1]; ++q)
      if (const std::uint32_t j = pr.moved_neighbor[q]; !pr.moved[j]) pr.neighbor[pr.found_by[j]++] = pr.moved_list[a];
  for (const std::uint32_t j : pr.moved_neighbor) pr.found_by[j] = 0;  // all 0 again for the next update
  parallel_for_each(n, [&](std::size_t i) {
    if (has_new_breaks(w, i)) take_in_breaks(w, i);
  }, 1024);
  pr.broken_at_build = broken_now;
  if (m == 0) {
    ++pr.additions;
    return;
  }
  ++pr.partial_updates;
  pr.searched += m;
}

void rebuild_pairs(WorldState& w, std::uint64_t broken_now, const Vec3& centroid) {
  auto& c = w.contact;
  auto& g = c.grid;
  auto& pr = c.pairs;
  const auto& p = w.particles;
  const std::size_t n = p.count();
  build_grid(g, p.position);  // 1. cells and buckets, 2. counting sort (spatial_grid.cpp)
  // 3. Half search (parallel): each pair is found once, by the end whose forward half-neighbourhood
  // holds the other (for_each_within_forward), which halves the candidate tests, the build's inner loop.
  // The search keeps each particle's first kScratchPerParticle finds; a forward CSR (offsets_next,
  // neighbor_next, free between updates) then takes them, searching again only for the rare particle
  // with more. Stamps are fresh for every pass and particle, so a mark left by an earlier pass or
  // build (a bond since broken) never matches.
  constexpr std::uint32_t cap = ContactPairs::kScratchPerParticle;
  const std::uint64_t search_base = pr.stamp_base, fill_base = search_base + n + 1;
  pr.stamp_base = fill_base + n + 1;
  parallel_for_each(n, [&](std::size_t i) {
    std::uint32_t count = 0;
    std::uint32_t* row = pr.scratch.data() + i * cap;
    for_each_candidate<true>(w, static_cast<std::uint32_t>(i), search_base + i + 1, stamp_row(pr, n),
                               [&](std::uint32_t j) {
                                 if (count < cap) row[count] = j;
                                 ++count;
                               });
    pr.count[i] = count;
  }, 256);
  auto& forward_offsets = pr.offsets_next;
  auto& forward = pr.neighbor_next;
  forward_offsets[0] = 0;
  for (std::size_t i = 0; i < n; ++i) forward_offsets[i + 1] = forward_offsets[i] + pr.count[i];
  forward.resize(forward_offsets[n]);  // grows only when it outgrows every earlier list
  parallel_for_each(n, [&](std::size_t i) {
    std::uint32_t q = forward_offsets[i];
    if (pr.count[i] <= cap) {
      std::copy_n(pr.scratch.data() + i * cap, pr.count[i], forward.data() + q);
      return;
    }
    for_each_candidate<true>(w, static_cast<std::uint32_t>(i), fill_base + i + 1, stamp_row(pr, n),
                               [&](std::uint32_t j) { forward[q++] = j; });
  }, 1024);
  // 4. Both sides (serial over the pairs, in index order): particle j's list is the particles that
  // found j, in increasing index, then j's own finds in visit order. found_by[j] counts, then writes.
  std::fill(pr.found_by.begin(), pr.found_by.end(), 0u);
  for (std::uint32_t q = 0; q < forward_offsets[n]; ++q) ++pr.found_by[forward[q]];
  // Each row with room to grow (row_capacity), so that updates rewrite rows in place.
  pr.offsets[0] = 0;
  for (std::size_t i = 0; i < n; ++i) {
    pr.length[i] = pr.found_by[i] + pr.count[i];
    pr.offsets[i + 1] = pr.offsets[i] + row_capacity(pr.length[i]);
  }
  pr.neighbor.resize(pr.offsets[n]);  // grows only when the list outgrows every earlier one
  for (std::size_t i = 0; i < n; ++i) pr.found_by[i] = pr.offsets[i];
  for (std::uint32_t i = 0; i < n; ++i)
    for (std::uint32_t q = forward_offsets[i]; q < forward_offsets[i + 1]; ++q) pr.neighbor[pr.found_by[forward[q]]++] = i;
  parallel_for_each(n, [&](std::size_t i) {
    std::copy(forward.begin() + forward_offsets[i], forward.begin() + forward_offsets[i + 1],
              pr.neighbor.begin() + pr.found_by[i]);
  }, 4096);
  parallel_for_each(n, [&](std::size_t i) {
    pr.built_position[i] = p.position[i] - centroid;
    pr.found_by[i] = 0;  // all 0 between updates
  }, 4096);
  take_in_all_breaks(w);
  pr.search_grid_valid = false;  // every search position changed: the next update builds it
  pr.broken_at_build = broken_now;
  pr.valid = true;
  ++pr.builds;
}

// contact.size: s_i = ∛V_i per particle.
void size_particles(WorldState& w) {
  auto& c = w.contact;
  const std::size_t n = w.particles.count();
  c.size.resize(n);
  for (std::size_t i = 0; i < n; ++i) c.size[i] = std::cbrt(w.particles.volume[i]);
}

// The three grids for n particles, nothing displaced; the search grid is built by the next update that
// needs it.
void allocate_grids(ContactState& c, std::size_t n) {
  auto& pr = c.pairs;
  allocate_grid(c.grid, n, c.largest_distance + pr.skin);
  pr.displaced.assign(n, 0);
  pr.displaced_list.clear();
  pr.displaced_list.reserve(displaced_room(n));
  pr.search_grid_valid = false;
  allocate_grid(c.search_grid, n, search_cell(c));
  allocate_grid(c.displaced_grid, displaced_room(n), search_cell(c));
}

// Every buffer of the pair list and grid, for the current particle count (the list is built on the
// next step).
void allocate_pairs(WorldState& w) {
  auto& c = w.contact;
  const std::size_t n = w.particles.count();
  auto& pr = c.pairs;
  pr.offsets.assign(n + 1, 0);
  pr.length.assign(n, 0);
  pr.count.assign(n, 0);
  // The large buffers are cleared by all threads (assign_huge_pages): at 9e5 particles they are about
  // 100 MB, and the kernel's page clearing of them on one thread was most of a second. The bonds' bits
  // (alive_at_build, 17 MB at 1.4e8 bonds) are small enough for one.
  assign_huge_pages(pr.scratch, n * ContactPairs::kScratchPerParticle, 0u);
  assign_huge_pages(pr.built_position, n, Vec3(Vec3::Zero()));
  pr.neighbor.reserve(2 * n);
  pr.neighbor_next.reserve(2 * n);
  pr.offsets_next.assign(n + 1, 0);
  pr.alive_at_build.assign((w.bonds.alive.size() + 63) / 64, ~std::uint64_t{0});
  pr.moved.assign(n, 0);
  pr.moved_list.reserve(n);
  pr.moved_offsets.assign(n + 1, 0);
  pr.found_by.assign(n, 0);
  pr.partner_moved.assign(n, 0);
  pr.resort.assign(n, 0);
  pr.near_count.assign(n, 0);
  pr.broken_seen.assign(n, 0);
  // One row per worker slot of the arena the step runs in (scene threads, or the machine's).
  pr.stamp_slots = static_cast<std::size_t>(
      std::max(w.settings.threads > 0 ? w.settings.threads : 0, tbb::info::default_concurrency()));
  assign_huge_pages(pr.bonded_stamp, pr.stamp_slots * n, std::uint64_t{0});
  pr.stamp_base = 0;
  pr.valid = false;
  allocate_grids(c, n);
}

}  // namespace

bool contact_runs(const WorldState& w) {
  const auto mode = w.settings.contact.mode;
  return mode == scene::Contact::Mode::on ||
         (mode == scene::Contact::Mode::automatic && (w.bodies.size() >= 2 || w.any_fracture));
}

void resolve_contact(WorldState& w, double largest_distance) {
  const auto& sc = w.settings.contact;
  auto& c = w.contact;
  c.enabled = contact_runs(w);
  c.distance_factor = sc.distance_factor;
  c.stiffness_factor = sc.stiffness_factor;
  c.time_scale = sc.time_scale;  // resolved by set-up (0 only in worlds built without it: the step's)
  c.damping_ratio = sc.damping_ratio;
  c.friction = sc.friction;
  size_particles(w);
  if (!c.enabled) return;
  if (largest_distance > 0.0) {
    c.largest_distance = largest_distance;
  } else {
    double largest = 0.0;
    for (const double size : c.size) largest = std::max(largest, size);
    c.largest_distance = c.distance_factor * largest;
  }
  c.pairs.skin = kSkinFraction * c.largest_distance;
}

void setup_contact(WorldState& w, double largest_distance) {
  resolve_contact(w, largest_distance);
  if (w.contact.enabled) allocate_pairs(w);
}

void replace_contact_tail(WorldState& w, std::size_t kept) {
  size_particles(w);
  auto& c = w.contact;
  auto& pr = c.pairs;
  if (!c.enabled) return;
  if (!pr.valid) {  // nothing built yet: plain buffers for the new count
    allocate_pairs(w);
    return;
  }
  const std::size_t n_old = pr.offsets.size() - 1, n = w.particles.count();
  // The rows of the kept particles without their pairs beyond `kept` (in place, keeping each row's
  // room); empty rows, with room, for the new ones.
  pr.near_count.resize(n, 0);
  pr.length.resize(n, 0);
  for (std::size_t i = 0; i < std::min(kept, n_old); ++i)
    pr.length[i] = filter_row(pr, i, pr.neighbor.data() + pr.offsets[i], [&](std::uint32_t j) { return j < kept; });
  const std::size_t first_new = std::min(kept, n_old);
  pr.offsets.resize(n + 1);
  for (std::size_t i = first_new; i < n; ++i) {
    pr.near_count[i] = 0;
    pr.length[i] = 0;
    pr.offsets[i + 1] = pr.offsets[i] + row_capacity(0);
  }
  pr.neighbor.resize(pr.offsets[n]);
  pr.offsets_next.assign(n + 1, 0);
  // Per-particle buffers for n; a new particle's search position is NaN, which counts as moved, so the
  // next step searches it (update_moved_pairs) and writes its pairs on both sides.
  pr.count.assign(n, 0);
  pr.moved.assign(n, 0);
  pr.found_by.assign(n, 0);
  pr.partner_moved.assign(n, 0);
  pr.resort.assign(n, 0);
  pr.moved_offsets.assign(n + 1, 0);
  pr.moved_list.reserve(n);
  pr.built_position.resize(n, Vec3::Constant(std::numeric_limits<double>::quiet_NaN()));
  for (std::size_t i = kept; i < n; ++i) pr.built_position[i] = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  pr.broken_seen.resize(n);
  for (std::size_t i = kept; i < n; ++i) pr.broken_seen[i] = w.state.broken_bonds[i];
  pr.scratch.resize(n * ContactPairs::kScratchPerParticle);
  pr.bonded_stamp.assign(pr.stamp_slots * n, 0);  // every mark below stamp_base: none matches a later pass
  allocate_grids(c, n);
}


SystemDecl contact_system(WorldState& w) {
  return {"contact",
          {Component::position, Component::velocity, Component::bond_alive, Component::damage},
          {Component::contact_force, Component::contact_list},
          [&w] {
            std::uint64_t broken_now = 0;
            Vec3 centroid;
            switch (pair_update_needed(w, broken_now, centroid)) {
              case PairUpdate::rebuild: rebuild_pairs(w, broken_now, centroid); sort_rows(w, false); break;
              case PairUpdate::update: update_moved_pairs(w, broken_now, centroid); sort_rows(w, true); break;
              case PairUpdate::none: break;
            }
            auto& c = w.contact;
            const auto& pr = c.pairs;
            const auto& p = w.particles;
            const double per_mass = contact_stiffness_per_mass(c.time_scale, w.clock.dt);  // 1/max(τ, dt)²
            const double inv_dt = 1.0 / w.clock.dt;
            parallel_for_each(p.count(), [&](std::size_t ii) {
              const auto i = static_cast<std::uint32_t>(ii);
              Vec3 f = Vec3::Zero();
              const std::uint32_t first = pr.offsets[i], last = first + pr.near_count[i];  // near part (header)
              if (first == last || !w.owns(i)) {
                w.state.contact_force[i] = f;
                return;
              }
              const Vec3 yi = p.position[i], vi = p.velocity[i];
              for (std::uint32_t q = first; q < last; ++q) {
                const std::uint32_t j = pr.neighbor[q];
                const Vec3 r = p.position[j] - yi;
                const double d2 = r.squaredNorm();
                double dc = contact_distance(c, i, j);
                if (d2 >= dc * dc) continue;  // most of the list: out of contact whatever the cap below
                if (p.body_id[i] == p.body_id[j]) {
                  // Most near same-body pairs are the ends of broken bonds still about their reference
                  // distance apart: out of contact. Tested on squares first (d² ≥ |ξ|²(1 + 1e-12) implies
                  // d² ≥ min(d_c, |ξ|)² as rounded below), which skips the square root for them.
                  const double xi2 = (p.reference_position[j] - p.reference_position[i]).squaredNorm();
                  if (d2 >= xi2 * (1.0 + 1e-12)) continue;
                  dc = std::min(dc, std::sqrt(xi2));
                }
                if (d2 >= dc * dc) continue;
                const double d = std::sqrt(d2);
                if (!(d > 0.0)) continue;  // coincident: no direction (never happens in practice)
                const Vec3 nrm = r / d;
                const double mi = p.mass[i], mj = p.mass[j];
                const double m_pair = (mi * mj) / (mi + mj);
                const double k = c.stiffness_factor * std::min(mi, mj) * per_mass;
                const ContactForce cf = contact_force(dc - d, nrm, Vec3(p.velocity[j] - vi), k, m_pair,
                                                      c.damping_ratio, c.friction, inv_dt);
                f -= cf.normal * nrm;
                if (cf.sliding) f += cf.friction;
              }
              w.state.contact_force[i] = f;
            }, 256);
          }};
}

}  // namespace perifx::systems
