// The neighbour gathers of the bond kernels (systems/bond_gather.hpp) must hand each lane exactly the
// doubles a plain indexed load would, in every lane of a full chunk and of a family's tail, and must
// not read past the end of the position arrays (the last particle's three doubles end its array).
#include <doctest/doctest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstring>
#include <random>
#include <tuple>
#include <vector>

#include "systems/bond_gather.hpp"

using namespace perifx;
using namespace perifx::systems;

namespace {

// `count` doubles ending exactly at a page that may not be read: a load past the end faults.
struct GuardedArray {
  void* base = nullptr;
  std::size_t bytes = 0;
  double* data = nullptr;
  explicit GuardedArray(std::size_t count) {
    const std::size_t page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
    const std::size_t used = (count * sizeof(double) + page - 1) / page * page;
    bytes = used + page;
    base = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    REQUIRE(base != MAP_FAILED);
    REQUIRE(mprotect(static_cast<char*>(base) + used, page, PROT_NONE) == 0);
    data = reinterpret_cast<double*>(static_cast<char*>(base) + used) - count;
  }
  ~GuardedArray() { munmap(base, bytes); }
};

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

}  // namespace

TEST_CASE("bond gathers hand every lane the far end's own doubles, and read nothing past the arrays") {
  constexpr std::size_t n = 37;
  GuardedArray y(3 * n), x(4 * n);  // x: one ReferencePoint (x y z V) per particle
  std::vector<BondEnd> ends(n);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  for (std::size_t c = 0; c < 3 * n; ++c) y.data[c] = value(rng);
  for (std::size_t c = 0; c < 4 * n; ++c) x.data[c] = value(rng);
  const auto* const reference = reinterpret_cast<const ReferencePoint*>(x.data);  // 32-byte aligned: ends at a page
  for (auto& e : ends)
    e = BondEnd{value(rng), value(rng), value(rng), value(rng), value(rng), value(rng), value(rng), value(rng)};
  // A family: the last particle (whose doubles end the guarded arrays) in several lanes, the first,
  // repeats; 29 bonds, so the traversal takes full chunks and a tail (13 with 16 lanes, 5 with 8).
  const std::vector<std::uint32_t> nb = {36, 0, 5, 36, 12, 35, 1, 36, 36, 17, 3, 29, 36, 8, 36, 2, 36, 20, 36, 36,
                                         0,  9, 36, 4, 36, 33, 7, 36, 36};
  // Alive flags in a pattern with both values in every chunk: the traversal unpacks them itself (a
  // 64-bit word per lane; with AVX-512 widened by vector before the lane loop).
  std::vector<std::uint8_t> alive(nb.size());
  for (std::size_t b = 0; b < alive.size(); ++b) alive[b] = (b * 5) % 3 != 0;
  // Both traversals: DeadChunks::visit runs the tail as its own short chunk, DeadChunks::skip as the
  // family's last kBondLanes bonds with the ones already visited given flag 0 (bond_rules.hpp).
  for (const DeadChunks dead : {DeadChunks::visit, DeadChunks::skip}) {
    CAPTURE(static_cast<int>(dead));
    std::vector<std::pair<std::size_t, int>> chunks;  // (first bond, count) as the traversal gathers them
    auto gather = [&](std::size_t k, int lanes) {
      CAPTURE(k);
      chunks.emplace_back(k, lanes);
      ChunkPositions p;
      gather_positions(y.data, reference, nb.data() + k, lanes, p);
      ChunkEnds e;
      gather_ends<true>(ends.data(), nb.data() + k, lanes, e);
      ChunkEnds elastic;
      gather_ends<false>(ends.data(), nb.data() + k, lanes, elastic);
      for (int l = 0; l < lanes; ++l) {
        CAPTURE(l);
        const std::size_t j = nb[k + l];
        CHECK(same_bits(p.yx[l], y.data[3 * j]));
        CHECK(same_bits(p.yy[l], y.data[3 * j + 1]));
        CHECK(same_bits(p.yz[l], y.data[3 * j + 2]));
        CHECK(same_bits(p.xx[l], x.data[4 * j]));
        CHECK(same_bits(p.xy[l], x.data[4 * j + 1]));
        CHECK(same_bits(p.xz[l], x.data[4 * j + 2]));
        CHECK(same_bits(p.v[l], x.data[4 * j + 3]));
        for (const ChunkEnds* c : {&e, &elastic}) {
          CHECK(same_bits(c->coupling[l], ends[j].coupling));
          CHECK(same_bits(c->b4[l], ends[j].b4));
          CHECK(same_bits(c->volume[l], ends[j].volume));
          CHECK(same_bits(c->horizon[l], ends[j].horizon));
        }
        CHECK(same_bits(e.beta_theta[l], ends[j].beta_theta));
        CHECK(same_bits(e.yield_extension[l], ends[j].yield_extension));
        CHECK(same_bits(e.plastic_cap[l], ends[j].plastic_cap));
        CHECK(same_bits(e.break_extension[l], ends[j].break_extension));
      }
    };
    // Every lane call as (bond, lane, flag), in call order.
    std::vector<std::tuple<std::size_t, int, std::uint64_t>> calls;
    auto* const calls_p = &calls;
    for_each_gathered_bond_lane(
        0, nb.size(), alive.data(), gather,
        [calls_p](std::size_t k, int l, std::uint64_t flag) { calls_p->emplace_back(k, l, flag); },
        [](std::size_t, int) {}, dead);  // every chunk has a live bond: nothing is skipped
    // Full chunks in order, every bond on lane (its index − its chunk's first) with its own flag; then
    // the tail.
    std::vector<std::pair<std::size_t, int>> expected;
    std::vector<std::tuple<std::size_t, int, std::uint64_t>> expected_calls;
    std::size_t k = 0;
    for (; k + kBondLanes <= nb.size(); k += kBondLanes) {
      expected.emplace_back(k, kBondLanes);
      for (int l = 0; l < kBondLanes; ++l) expected_calls.emplace_back(k + l, l, alive[k + l]);
    }
    const int tail = static_cast<int>(nb.size() - k);
    REQUIRE(tail > 0);
    if (dead == DeadChunks::visit) {
      expected.emplace_back(k, tail);
      for (int l = 0; l < tail; ++l) expected_calls.emplace_back(k + l, l, alive[k + l]);
    } else {
      const std::size_t last = nb.size() - kBondLanes;
      expected.emplace_back(last, kBondLanes);
      for (int l = 0; l < kBondLanes; ++l)
        expected_calls.emplace_back(last + l, l, last + l < k ? 0 : alive[last + l]);
    }
    CHECK(chunks == expected);
    CHECK(calls == expected_calls);
  }
  // A family shorter than a chunk has nothing to overlap: its bonds run as one short chunk either way.
  for (const DeadChunks dead : {DeadChunks::visit, DeadChunks::skip}) {
    std::vector<std::pair<std::size_t, int>> chunks;
    std::vector<std::size_t> bonds;
    for_each_gathered_bond_lane(
        3, 8, alive.data(), [&](std::size_t k, int lanes) { chunks.emplace_back(k, lanes); },
        [&bonds](std::size_t k, int, std::uint64_t) { bonds.push_back(k); }, [](std::size_t, int) {}, dead);
    CHECK(chunks == std::vector<std::pair<std::size_t, int>>{{3, 5}});
    CHECK(bonds == std::vector<std::size_t>{3, 4, 5, 6, 7});
  }
}

// DeadChunks::skip leaves out exactly the chunks whose bonds are all broken (neither gathered nor
// computed nor finished) and visits every other chunk whole, dead lanes included; DeadChunks::visit
// visits everything. Checked on a family with a dead full chunk between live ones and a dead tail.
TEST_CASE("a chunk whose bonds are all broken is skipped only when the kernel asks, and only that chunk") {
  // Four full chunks and a tail of 3; chunk 1 and the tail all broken, chunk 2 with one live bond (its
  // last lane), chunk 3 all alive, chunk 0 with one live bond (its first lane).
  const std::size_t bonds = 4 * kBondLanes + 3;
  std::vector<std::uint8_t> alive(bonds, 0);
  alive[0] = 1;
  alive[3 * kBondLanes - 1] = 1;
  for (std::size_t b = 3 * kBondLanes; b < 4 * kBondLanes; ++b) alive[b] = 1;
  for (const DeadChunks dead : {DeadChunks::skip, DeadChunks::visit}) {
    CAPTURE(static_cast<int>(dead));
    std::vector<std::pair<std::size_t, int>> gathered, finished;
    std::vector<int> visits(bonds, 0);
    int* const v = visits.data();
    for_each_gathered_bond_lane(
        0, bonds, alive.data(), [&](std::size_t k, int n) { gathered.emplace_back(k, n); },
        [v](std::size_t k, int, std::uint64_t) { ++v[k]; }, [&](std::size_t k, int n) { finished.emplace_back(k, n); },
        dead);
    std::vector<std::pair<std::size_t, int>> expected = {{0, kBondLanes}};
    if (dead == DeadChunks::visit) expected.emplace_back(kBondLanes, kBondLanes);
    expected.emplace_back(2 * kBondLanes, kBondLanes);
    expected.emplace_back(3 * kBondLanes, kBondLanes);
    if (dead == DeadChunks::visit) expected.emplace_back(4 * kBondLanes, 3);
    CHECK(gathered == expected);
    CHECK(finished == expected);
    for (std::size_t b = 0; b < bonds; ++b) {
      CAPTURE(b);
      const bool skipped_chunk = (b >= kBondLanes && b < 2 * kBondLanes) || b >= 4 * kBondLanes;
      CHECK(visits[b] == (dead == DeadChunks::skip && skipped_chunk ? 0 : 1));
    }
  }
}
