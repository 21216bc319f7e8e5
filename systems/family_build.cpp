// Family build (setup, paper §5.2 and systems/README.md §6.2).
// Reads:  particles.reference_position, particles.body_id, particles.material_id, model.horizon,
//         the embedded mesh's face adjacency (mesh rule), scene materials (G, Eq 17).
// Writes: bonds (offsets, neighbor, alive, plastic_extension(_mirror), initial_count). |ξ| and ω are
//         not stored; the kernels recompute them (bond_rules.hpp).
//
// Mesh rule (default): j is in i's family when |x_j − x_i| ≤ δ and j is reachable from i through
// face-adjacent tets whose barycenters all lie within δ of x_i, so bonds never jump a thin gap.
// Reachability is not symmetric in general (the balls around i and j differ); a bond is one physical
// link, so the union is kept: i–j is bonded when either finds the other.
// Distance rule: every particle of the same body within δ (found with spatial_grid.hpp).
#include <oneapi/tbb/enumerable_thread_specific.h>
#include <oneapi/tbb/parallel_pipeline.h>
#include <oneapi/tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <span>
#include <utility>

#include "bond_rules.hpp"
#include "huge_pages.hpp"
#include "parallel.hpp"
#include "spatial_grid.hpp"
#include "systems.hpp"

namespace perifx::systems {
namespace {

// Bonds exactly at distance δ (common on structured meshes) are kept despite round-off.
constexpr double kHorizonSlack = 1e-9;
constexpr double kGridMargin = 1e-6;

// Per-particle candidate lists (sorted), back to back in particle order in one array that becomes
// the bond array (bonds.neighbor) once the one-sided finds are merged in (build_families). Writing the
// lists there directly, rather than into lists of their own copied into a fresh bond array, touches
// one array of ~4 B per bond instead of two: on the VMs we measure on, first-touching fresh memory
// costs ~2 ns per byte in the kernel and the host (a quarter of a 1e6-particle set-up's CPU time).
struct Lists {
  std::vector<std::uint32_t> flat;   // every list, in particle order
  std::vector<std::uint32_t> begin;  // n + 1: list i is flat[begin[i], begin[i + 1])
  std::span<const std::uint32_t> operator[](std::size_t i) const { return {flat.data() + begin[i], begin[i + 1] - begin[i]}; }
};
constexpr std::size_t kListChunk = 8192;  // particles per pipeline item

// A fresh array of `capacity` elements advised for huge pages before anything touches it, holding a
// copy of `v` (the rare growth when the estimate below was short).
void regrow(std::vector<std::uint32_t>& v, std::size_t capacity) {
  std::vector<std::uint32_t> fresh;
  fresh.reserve(capacity);
  advise_huge_pages(fresh.data(), capacity * sizeof(std::uint32_t));
  fresh.insert(fresh.end(), v.begin(), v.end());
  v.swap(fresh);
}

// Builds the lists with a oneTBB pipeline: chunks of kListChunk particles are searched in parallel
// into per-token buffers (reused, so they stay in cache), and appended to `flat` in chunk order by a
// serial stage. Deterministic: a chunk's lists depend on its particles only, and they land in order.
// fill(i, out) appends particle i's list to out, sorted (increasing index). `flat` is reserved up
// front from the lists of every 61st particle (1 % headroom), so it is not regrown and copied.
template <class Fill>
Lists build_lists(std::size_t n, Fill&& fill) {
  Lists lists;
  lists.begin.assign(n + 1, 0);
  if (n == 0) return lists;
  {
    constexpr std::size_t kStride = 61;
    const std::size_t samples = (n + kStride - 1) / kStride;
    std::vector<std::uint32_t> sampled(samples);
    tbb::enumerable_thread_specific<std::vector<std::uint32_t>> scratch;
    parallel_for_each(samples, [&](std::size_t s) {
      auto& out = scratch.local();
      out.clear();
      fill(s * kStride, out);
      sampled[s] = static_cast<std::uint32_t>(out.size());
    }, 64);
    double total = 0.0;
    for (std::uint32_t c : sampled) total += c;
    const auto estimate = static_cast<std::size_t>(total / double(samples) * double(n) * 1.01) + 4096;
    regrow(lists.flat, estimate);
  }
  const std::size_t chunks = (n + kListChunk - 1) / kListChunk;
  // A token is released only after the last (serial, in-order) stage, so chunks c and c + tokens are
  // never in flight together and buffer c % tokens is chunk c's alone.
  const auto tokens = static_cast<std::size_t>(2 * tbb::this_task_arena::max_concurrency());
  std::vector<std::vector<std::uint32_t>> buffer(tokens);
  std::size_t next = 0;
  tbb::parallel_pipeline(
      tokens,
      tbb::make_filter<void, std::size_t>(tbb::filter_mode::serial_in_order,
                                          [&](tbb::flow_control& control) -> std::size_t {
                                            if (next == chunks) control.stop();
                                            return next++;
                                          }) &
          tbb::make_filter<std::size_t, std::size_t>(tbb::filter_mode::parallel,
                                                     [&](std::size_t c) {
                                                       auto& out = buffer[c % tokens];
                                                       out.clear();
                                                       const std::size_t end = std::min(n, (c + 1) * kListChunk);
                                                       for (std::size_t i = c * kListChunk; i < end; ++i) {
                                                         fill(i, out);
                                                         lists.begin[i + 1] = static_cast<std::uint32_t>(out.size());
                                                       }
                                                       return c;
                                                     }) &
          tbb::make_filter<std::size_t, void>(tbb::filter_mode::serial_in_order, [&](std::size_t c) {
            const auto& out = buffer[c % tokens];
            auto& flat = lists.flat;
            if (flat.size() + out.size() > flat.capacity()) regrow(flat, std::max(2 * flat.capacity(), flat.size() + out.size()));
            const auto base = static_cast<std::uint32_t>(flat.size());
            flat.insert(flat.end(), out.begin(), out.end());
            const std::size_t end = std::min(n, (c + 1) * kListChunk);
            for (std::size_t i = c * kListChunk; i < end; ++i) lists.begin[i + 1] += base;
          }));
  return lists;
}

// Sorts a list of distinct particle indices in place. In Morton order most of a family lies within
// kHalfWindow indices of its particle (fig07 full: 94 % of the bonds), so those are sorted by marking a
// bitmap of the window and reading it back in order; the rest, the few the curve puts far away, go
// through std::sort. Sorting each family with std::sort alone was 14 % of a 9e5-particle set-up's CPU.
class NearSorter {
 public:
  static constexpr std::uint32_t kHalfWindow = 8192;
  static constexpr std::uint32_t kWords = 2 * kHalfWindow / 64;

  void sort(std::uint32_t* list, std::size_t count, std::uint32_t centre) {
    const std::uint32_t base = centre > kHalfWindow ? centre - kHalfWindow : 0;
    far_.clear();
    for (std::size_t k = 0; k < count; ++k) {
      const std::uint32_t offset = list[k] - base;  // wraps (large) below the window
      if (offset < 64 * kWords) bits_[offset / 64] |= std::uint64_t{1} << (offset % 64);
      else far_.push_back(list[k]);
    }
    std::sort(far_.begin(), far_.end());
    const auto below = std::lower_bound(far_.begin(), far_.end(), base);
    std::uint32_t* outp = std::copy(far_.begin(), below, list);
    for (std::uint32_t word = 0; word < kWords; ++word) {
      for (std::uint64_t w = bits_[word]; w != 0; w &= w - 1)
        *outp++ = base + 64 * word + static_cast<std::uint32_t>(std::countr_zero(w));
      bits_[word] = 0;
    }
    std::copy(below, far_.end(), outp);
  }

 private:
  std::array<std::uint64_t, kWords> bits_{};
  std::vector<std::uint32_t> far_;
};

// Breadth-first search from each particle's tet over face-adjacent tets whose barycenters lie within
// reach. The queue holds exactly the tets accepted so far, so it is the particle's list: it is sorted
// in place at the end and appended to the pipeline's buffer. It lives in the thread's scratch (a few
// hundred entries, in L1) rather than in that buffer. "Seen" is a byte per tet and thread, stamped
// with a generation number that wraps every 255 searches (then the bytes are cleared): 0.9 MB at 9e5
// particles stays in the L2 cache where a 4-byte stamp per tet (3.6 MB) did not. A tet's four
// neighbours are tested without branches (each is written to the queue's end, and the end advances only
// when it is new and within reach; a missing neighbour reads as the tet itself, already seen): the
// tests' outcomes are close to random, and as branches they were mostly mispredictions.
Lists families_by_mesh(const WorldState& w, const std::vector<std::array<std::int32_t, 4>>& adjacency) {
  const auto& x = w.particles.reference_position;
  const std::size_t n = x.size();
  struct Scratch {
    std::vector<std::uint8_t> seen;  // seen[t] == generation: tet t already met in this search
    std::uint8_t generation = 0;
    std::vector<std::uint32_t> queue;
    NearSorter sorter;
  };
  tbb::enumerable_thread_specific<Scratch> scratch(
      [n] { return Scratch{std::vector<std::uint8_t>(n, 0), 0, std::vector<std::uint32_t>(1024), {}}; });
  return build_lists(n, [&](std::size_t i, std::vector<std::uint32_t>& out) {
    Scratch& s = scratch.local();
    if (++s.generation == 0) {
      std::fill(s.seen.begin(), s.seen.end(), std::uint8_t{0});
      s.generation = 1;
    }
    const std::uint8_t mark = s.generation;
    const Vec3 xi = x[i];
    const double reach = w.model.horizon[i] * (1.0 + kHorizonSlack);
    const double reach2 = reach * reach;
    std::uint8_t* seen = s.seen.data();
    seen[i] = mark;
    std::size_t length = 0;
    auto expand = [&](std::uint32_t q) {
      if (length + 4 > s.queue.size()) s.queue.resize(2 * s.queue.size());
      std::uint32_t* queue = s.queue.data();
      for (std::int32_t nb : adjacency[q]) {
        const std::uint32_t t = nb < 0 ? q : static_cast<std::uint32_t>(nb);
        const bool fresh = seen[t] != mark;
        seen[t] = mark;
        queue[length] = t;
        length += static_cast<std::size_t>(fresh & ((x[t] - xi).squaredNorm() <= reach2));
      }
    };
    expand(static_cast<std::uint32_t>(i));
    for (std::size_t head = 0; head < length; ++head) expand(s.queue[head]);
    s.sorter.sort(s.queue.data(), length, static_cast<std::uint32_t>(i));
    out.insert(out.end(), s.queue.begin(), s.queue.begin() + static_cast<std::ptrdiff_t>(length));
  });
}

Lists families_by_distance(const WorldState& w) {
  const auto& x = w.particles.reference_position;
  const std::size_t n = x.size();
  if (n == 0) return {};
  double cell = 0.0;
  for (std::size_t i = 0; i < n; ++i) cell = std::max(cell, w.model.horizon[i] * (1.0 + kHorizonSlack));
  // Every pair within reach is in neighbouring cells; the margin keeps that true through the
  // rounding of the cell coordinates (the exact test below decides, so the margin changes nothing).
  SpatialGrid grid;
  allocate_grid(grid, n, cell * (1.0 + kGridMargin));
  build_grid(grid, x);
  return build_lists(n, [&](std::size_t i, std::vector<std::uint32_t>& out) {
    const std::size_t first = out.size();
    const double reach = w.model.horizon[i] * (1.0 + kHorizonSlack);
    for_each_near(grid, x[i], [&](std::uint32_t q) {
      const std::uint32_t j = grid.sorted[q];
      if (j == i || w.particles.body_id[j] != w.particles.body_id[i]) return;
      if ((x[j] - x[i]).squaredNorm() <= reach * reach) out.push_back(j);
    });
    std::sort(out.begin() + std::ptrdiff_t(first), out.end());
  });
}

}  // namespace

void build_families(WorldState& w, const std::vector<std::array<std::int32_t, 4>>& tet_face_neighbors) {
  const auto& x = w.particles.reference_position;
  const std::size_t n = x.size();
  Lists lists = w.settings.family == scene::FamilyRule::mesh ? families_by_mesh(w, tet_face_neighbors)
                                                                : families_by_distance(w);
  // A bond is one physical link: i–j is bonded when either found the other. Bonds of i = L_i ∪ E_i,
  // where the extras E_i = {k : i ∈ L_k, k ∉ L_i} are the one-sided finds (rare: where two balls see
  // different paths through the mesh). They are found without building the transpose (as large as the
  // bond array, and at 9e5 particles about a second of page faults here): the particles are cut into
  // chunks of consecutive k; within a chunk the queries "k ∈ L_i?" reach each list L_i with increasing
  // k, so a cursor per list advances monotonically (the thread's dense arrays, reset by a chunk stamp)
  // and the whole test is one pass over the lists. Each chunk keeps its (i, k) extras in order; they
  // are then joined in chunk order and sorted: deterministic for any thread count.
  struct Cursors {
    std::vector<std::uint32_t> position, chunk;  // per particle: cursor into L_i, chunk + 1 that set it
  };
  tbb::enumerable_thread_specific<Cursors> cursors(
      [n] { return Cursors{std::vector<std::uint32_t>(n, 0), std::vector<std::uint32_t>(n, 0)}; });
  const std::size_t chunks = (n + kListChunk - 1) / kListChunk;
  std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> chunk_extras(chunks);
  parallel_for_each(chunks, [&](std::size_t c) {
    Cursors& cur = cursors.local();
    const auto stamp = static_cast<std::uint32_t>(c + 1);
    for (std::size_t k = c * kListChunk, end = std::min(n, (c + 1) * kListChunk); k < end; ++k) {
      const auto k32 = static_cast<std::uint32_t>(k);
      for (std::uint32_t i : lists[k]) {
        const auto row = lists[i];
        std::uint32_t& at = cur.position[i];
        if (cur.chunk[i] != stamp) {
          cur.chunk[i] = stamp;
          at = static_cast<std::uint32_t>(std::lower_bound(row.begin(), row.end(), k32) - row.begin());
        }
        while (at < row.size() && row[at] < k32) ++at;
        if (at == row.size() || row[at] != k32) chunk_extras[c].emplace_back(i, k32);
      }
    }
  }, 1);
  cursors.clear();
  std::vector<std::pair<std::uint32_t, std::uint32_t>> extras;  // (i, k): i also bonds k
  for (const auto& e : chunk_extras) extras.insert(extras.end(), e.begin(), e.end());
  chunk_extras = {};
  std::sort(extras.begin(), extras.end());
  std::vector<std::uint32_t> extra_offsets(n + 1, 0);  // extras of rows < i
  for (const auto& e : extras) ++extra_offsets[e.first + 1];
  for (std::size_t i = 0; i < n; ++i) extra_offsets[i + 1] += extra_offsets[i];

  Bonds& b = w.bonds;
  b.offsets.assign(n + 1, 0);
  b.initial_count.resize(n);
  parallel_for_each(n, [&](std::size_t i) {
    b.offsets[i] = lists.begin[i] + extra_offsets[i];
    b.initial_count[i] = lists.begin[i + 1] - lists.begin[i] + extra_offsets[i + 1] - extra_offsets[i];
  }, 4096);
  b.offsets[n] = lists.begin[n] + extra_offsets[n];
  const std::size_t m = b.offsets[n];

  // Bonds of i = L_i ∪ E_i, in place: row i moves right by the extras of the rows before it. From the
  // last row back: the rows after a row with extras move as one block (memmove), then that row is
  // merged from its end (the write position stays at or right of the read position, so nothing unread
  // is overwritten). 579 extras in fig07 full: a few hundred block moves.
  std::vector<std::uint32_t> flat = std::move(lists.flat);
  const std::size_t listed = flat.size();
  if (m > flat.capacity()) regrow(flat, m);
  flat.resize(m);
  std::size_t old_end = listed;  // [.., old_end): what is still at its listed place
  for (std::size_t r = n; r-- > 0 && extra_offsets[r + 1] > 0;) {
    if (extra_offsets[r + 1] == extra_offsets[r]) continue;
    const std::size_t after = lists.begin[r + 1], shift = extra_offsets[r + 1];
    std::memmove(flat.data() + after + shift, flat.data() + after, (old_end - after) * sizeof(std::uint32_t));
    std::size_t write = after + shift, read = after, t = extra_offsets[r + 1];
    const std::size_t read_first = lists.begin[r], t_first = extra_offsets[r];
    while (t > t_first) {
      if (read > read_first && flat[read - 1] > extras[t - 1].second) flat[--write] = flat[--read];
      else flat[--write] = extras[--t].second;
    }
    old_end = read;  // the rest of row r moves with the rows before it, by extra_offsets[r]
  }
  // A small world's array is made exact (World::memory reports capacities); a large one keeps the
  // estimate's headroom (about 1 %), which was reserved but never touched.
  if (flat.capacity() != flat.size() && flat.size() * sizeof(std::uint32_t) < kHugePageMinBytes) flat.shrink_to_fit();
  b.neighbor = std::move(flat);
  // The bond arrays are the largest the world holds: backed by huge pages (huge_pages.hpp).
  assign_huge_pages(b.alive, m, std::uint8_t{1});
  // e^p only where something can yield (components/bonds.hpp); the step's kernels skip it otherwise.
  assign_huge_pages(b.plastic_extension, w.any_plastic ? m : 0, 0.0f);
  assign_huge_pages(b.plastic_extension_mirror, w.any_plastic ? m : 0, 0.0f);
}

std::vector<std::uint32_t> mirror_bonds(const Bonds& b) {
  std::vector<std::uint32_t> mirror(b.count());
  parallel_for_each(b.particle_count(), [&](std::size_t i) {
    for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k) mirror[k] = mirror_bond(b, i, k);
  }, 256);
  return mirror;
}

}  // namespace perifx::systems
