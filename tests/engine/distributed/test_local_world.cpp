// Local worlds of a distributed run (engine/distributed/local_world.hpp) without MPI: the ranks' local
// worlds are stepped in one process, in lockstep, with the halo copied between them in memory, and
// every owned particle and bond must hold the same bits as the one-process world. The MPI transport
// itself is tested by mpi_identity.sh (PERIFX_MPI builds).
#include <doctest/doctest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>
#include <string_view>

#include "distributed/local_world.hpp"
#include "distributed/pieces.hpp"
#include "perifx/world.hpp"
#include "perifx/scene.hpp"
#include "systems/bond_rules.hpp"
#include "systems/pipeline.hpp"
#include "systems/systems.hpp"

using namespace perifx;

namespace {

const std::filesystem::path kTear = std::filesystem::path(PERIFX_SOURCE_DIR) / "tests/engine/distributed/mpi_tear.json";

// How many arrays of two worlds differ in a byte (each named by a failed CHECK), in for_each_array's
// order; fails when both are empty.
std::size_t differing_arrays(const WorldState& expected, const WorldState& rebuilt) {
  std::vector<std::pair<std::string, std::string>> want, have;
  auto bytes_of = [](const auto& a) { return std::string(reinterpret_cast<const char*>(a.data()), a.size() * sizeof(a[0])); };
  for_each_array(expected, [&](ArrayKind, const char* name, const auto& a) { want.emplace_back(name, bytes_of(a)); });
  for_each_array(rebuilt, [&](ArrayKind, const char* name, const auto& a) { have.emplace_back(name, bytes_of(a)); });
  REQUIRE(want.size() == have.size());
  std::size_t differing = 0, bytes = 0;
  for (std::size_t k = 0; k < want.size(); ++k) {
    CAPTURE(want[k].first);
    CHECK(want[k].first == have[k].first);
    CHECK(want[k].second == have[k].second);
    differing += want[k].second != have[k].second;
    bytes += want[k].second.size();
  }
  CHECK(bytes > 0);
  return differing;
}
const std::filesystem::path kContactBlocks =
    std::filesystem::path(PERIFX_SOURCE_DIR) / "tests/engine/distributed/contact_blocks.json";

// The same bytes in a's owned slice [begin, begin + count) as in b's [first, first + count).
template <class V>
bool same_bits(const V& local, std::size_t begin, const V& full, std::size_t first, std::size_t count) {
  if (local.empty() || full.empty()) return local.empty() && full.empty();  // an array the scene does not use
  return std::memcmp(local.data() + begin, full.data() + first, count * sizeof(local[0])) == 0;
}

struct Rank {
  distributed::LocalLayout layout;
  std::unique_ptr<WorldState> world;
  systems::PipelineOptions::Halo halo;
  std::vector<SystemDecl> systems;
};

// Copies, for every bond ghost of rank r (and its contact ghosts, with `contact`), what
// `copy(to_world, to_index, from_world, from_index)` moves.
template <class Copy>
void exchange(std::vector<Rank>& ranks, std::size_t r, Copy&& copy, bool contact = false) {
  Rank& me = ranks[r];
  using Links = std::vector<distributed::HaloLink> distributed::LocalLayout::*;
  const std::pair<Links, Links> stages[] = {{&distributed::LocalLayout::receives, &distributed::LocalLayout::sends},
                                            {&distributed::LocalLayout::contact_receives,
                                             &distributed::LocalLayout::contact_sends}};
  for (const auto& [receives, sends] : stages) {
    if (receives == &distributed::LocalLayout::contact_receives && !contact) break;
    for (const auto& in : me.layout.*receives) {
      const Rank& owner = ranks[static_cast<std::size_t>(in.rank)];
      const distributed::HaloLink* out = nullptr;
      for (const auto& link : owner.layout.*sends)
        if (link.rank == static_cast<int>(r)) out = &link;
      REQUIRE(out != nullptr);
      REQUIRE(out->local.size() == in.local.size());
      for (std::size_t m = 0; m < in.local.size(); ++m) copy(*me.world, in.local[m], *owner.world, out->local[m]);
    }
  }
}

// A contact ghost refresh of every rank, in memory (what the MPI runtime does with two collectives).
// Returns the bytes of every message.
std::size_t refresh_contact_ghosts(std::vector<Rank>& ranks) {
  std::vector<std::vector<std::uint64_t>> cells;
  for (const auto& rank : ranks) cells.push_back(distributed::contact_cells(*rank.world, rank.layout));
  for (auto& rank : ranks) distributed::find_contact_sends(*rank.world, rank.layout, cells);
  std::vector<std::vector<std::pair<int, std::vector<char>>>> received(ranks.size());
  std::size_t bytes = 0;
  for (std::size_t q = 0; q < ranks.size(); ++q)  // in sender order, as MPI_Alltoallv delivers
    for (const auto& link : ranks[q].layout.contact_sends) {
      received[static_cast<std::size_t>(link.rank)].emplace_back(
          static_cast<int>(q), distributed::pack_contact_ghosts(*ranks[q].world, ranks[q].layout, link));
      bytes += received[static_cast<std::size_t>(link.rank)].back().second.size();
    }
  for (std::size_t r = 0; r < ranks.size(); ++r)
    distributed::set_contact_ghosts(*ranks[r].world, ranks[r].layout, received[r]);
  return bytes;
}

// The layout and local world of every rank of `full` split by work over `count` ranks (no halos set).
std::vector<Rank> split_ranks(const WorldState& full, int count) {
  const auto domains = distributed::split_by_work(full, count);
  std::vector<Rank> ranks(static_cast<std::size_t>(count));
  for (std::size_t r = 0; r < ranks.size(); ++r) {
    ranks[r].layout = distributed::make_layout(full, domains, static_cast<int>(r));
    ranks[r].world = distributed::make_local_world(full, ranks[r].layout);
  }
  return ranks;
}

// The motion halo (position, velocity) of rank r's bond and contact ghosts.
void exchange_motion(std::vector<Rank>& ranks, std::size_t r) {
  exchange(
      ranks, r,
      [](WorldState& to, std::uint32_t i, const WorldState& from, std::uint32_t j) {
        to.particles.position[i] = from.particles.position[j];
        to.particles.velocity[i] = from.particles.velocity[j];
      },
      true);
}

// The refresh test as the runtime decides it: every rank's measure encoded, the words' elementwise
// minimum over ranks (the MPI_Allreduce with MPI_MIN), decoded, then stale or not. Also checks that
// the minimum decodes to the ranks' combine.
bool contact_ghosts_stale(const std::vector<Rank>& ranks) {
  constexpr std::size_t n = distributed::kContactGhostMotionWords;
  std::uint64_t all[n];
  std::fill(all, all + n, ~std::uint64_t{0});
  distributed::ContactGhostMotion combined;
  for (const auto& rank : ranks) {
    const auto motion = distributed::contact_ghost_motion(*rank.world, rank.layout);
    combined = distributed::combine(combined, motion);
    std::uint64_t mine[n];
    distributed::encode_contact_ghost_motion(motion, mine);
    for (std::size_t k = 0; k < n; ++k) all[k] = std::min(all[k], mine[k]);
  }
  const auto decoded = distributed::decode_contact_ghost_motion(all);
  CHECK(decoded.within_half_skin == combined.within_half_skin);
  CHECK(decoded.low == combined.low);
  CHECK(decoded.high == combined.high);
  return distributed::contact_ghosts_stale(decoded, ranks[0].layout.contact_skin);
}

}  // namespace

// Steps `scene` (particle contact on) in one process and as the local worlds of each rank count in
// `counts`, and compares
// every owned particle and bond. A negative count is the control: that many ranks without the θ halo
// and without contact ghosts, which must differ. `cross_contacts`: some owned particle must touch a
// contact ghost.
static void lockstep_matches_one_process(const std::filesystem::path& scene_file, std::uint64_t steps,
                                  std::initializer_list<int> counts, bool breaks, bool cross_contacts) {
  scene::Scene sc = scene::load_scene_file(scene_file);
  sc.contact.mode = scene::Contact::Mode::on;
  World one(sc);
  const World split_source(sc);
  const WorldState& full = split_source.state();
  one.step(steps);
  if (breaks) REQUIRE(one.alive_bond_count() < one.bond_count());

  for (int count : counts) {
    const bool control = count < 0;
    count = control ? -count : count;
    CAPTURE(count);
    CAPTURE(control);
    const auto domains = distributed::split_by_work(full, count);
    std::vector<Rank> ranks(static_cast<std::size_t>(count));
    for (std::size_t r = 0; r < ranks.size(); ++r) {
      Rank& rank = ranks[r];
      rank.layout = distributed::make_layout(full, domains, static_cast<int>(r));
      rank.world = distributed::make_local_world(full, rank.layout);
      if (breaks) CHECK(rank.layout.ghost_count() > 0);  // the blocks may fall on separate ranks whole
      rank.halo.motion = [&ranks, r] { exchange_motion(ranks, r); };
      rank.halo.dilatation = [&ranks, r, control] {
        if (control) return;
        exchange(ranks, r, [](WorldState& to, std::uint32_t i, const WorldState& from, std::uint32_t j) {
          to.state.dilatation[i] = from.state.dilatation[j];
          to.state.dilatation_coupling[i] = systems::dilatation_coupling(to.model, i, from.state.dilatation[j]);
        });
      };
      rank.halo.threshold = [&ranks, r] {
        exchange(ranks, r, [](WorldState& to, std::uint32_t i, const WorldState& from, std::uint32_t j) {
          to.state.break_extension[i] = from.state.break_extension[j];
        });
      };
      systems::PipelineOptions options;
      options.halo = &rank.halo;
      options.embedded_mesh = false;
      rank.systems = systems::step_pipeline(*rank.world, options);
      REQUIRE(rank.systems.size() == ranks[0].systems.size());
    }
    // Every ghost receives from its owner's copy of the same particle.
    std::size_t mismatched = 0, ghosts = 0;
    for (std::size_t r = 0; r < ranks.size(); ++r) {
      for (const auto& in : ranks[r].layout.receives) {
        const auto& owner = ranks[static_cast<std::size_t>(in.rank)].layout;
        for (const auto& out : owner.sends)
          if (out.rank == static_cast<int>(r))
            for (std::size_t m = 0; m < in.local.size(); ++m, ++ghosts)
              mismatched += owner.global_of[out.local[m]] != ranks[r].layout.global_of[in.local[m]];
      }
    }
    CHECK(mismatched == 0);
    CHECK(ghosts == [&] {
      std::size_t total = 0;
      for (const auto& rank : ranks) total += rank.layout.ghost_count();
      return total;
    }());
    // Lockstep: system s runs on every rank before system s + 1 runs on any, so a halo stage sees
    // every owner's values of that stage. Contact ghosts are refreshed before the first step and
    // whenever some rank finds them stale, as the runtime does.
    REQUIRE(ranks[0].world->contact.enabled);
    if (!control) refresh_contact_ghosts(ranks);
    std::size_t refreshes = control ? 0 : 1, most_contact_ghosts = 0, touching_contact_ghosts = 0;
    for (std::uint64_t step = 0; step < steps; ++step) {
      for (std::size_t s = 0; s < ranks[0].systems.size(); ++s)
        for (auto& rank : ranks) rank.systems[s].run();
      for (auto& rank : ranks) {
        ++rank.world->clock.step;
        rank.world->clock.time = static_cast<double>(rank.world->clock.step) * rank.world->clock.dt;
      }
      const bool stale = !control && contact_ghosts_stale(ranks);
      for (auto& rank : ranks) {
        const auto& l = rank.layout;
        const WorldState& w = *rank.world;
        most_contact_ghosts = std::max<std::size_t>(most_contact_ghosts, w.particles.count() - l.base_count);
        // Owned particles that a contact ghost pushes this step (the case only contact ghosts cover).
        const auto& pr = w.contact.pairs;
        for (std::uint32_t i = l.owned_begin; i < l.owned_begin + l.owned_count; ++i)
          for (std::uint32_t q = pr.offsets[i]; q < pr.offsets[i] + pr.length[i]; ++q)
            if (const std::uint32_t j = pr.neighbor[q]; j >= l.base_count) {
              const double dc = w.contact.distance_factor * 0.5 * (w.contact.size[i] + w.contact.size[j]);
              const double reference = (w.particles.reference_position[j] - w.particles.reference_position[i]).norm();
              touching_contact_ghosts += (w.particles.position[j] - w.particles.position[i]).norm() < std::min(dc, reference);
            }
      }
      if (stale && !control) {
        refresh_contact_ghosts(ranks);
        ++refreshes;
      }
    }
    MESSAGE("ranks " << count << ": " << refreshes << " contact ghost refreshes, up to " << most_contact_ghosts
                     << " contact ghosts on a rank, " << touching_contact_ghosts << " owned-ghost contacts");
    if (!control) CHECK(most_contact_ghosts > 0);
    if (cross_contacts && !control) CHECK(touching_contact_ghosts > 0);
    const WorldState& ref = one.state();
    if (control) {
      bool all_same = true;
      for (const auto& rank : ranks) {
        const auto& l = rank.layout;
        all_same = all_same && same_bits(rank.world->particles.position, l.owned_begin, ref.particles.position,
                                         l.domains[static_cast<std::size_t>(l.rank)].first, l.owned_count);
      }
      CHECK_FALSE(all_same);
      continue;
    }
    for (const auto& rank : ranks) {
      const auto& l = rank.layout;
      const auto& d = l.domains[static_cast<std::size_t>(l.rank)];
      CAPTURE(l.rank);
      const WorldState& w = *rank.world;
      CHECK(same_bits(w.particles.position, l.owned_begin, ref.particles.position, d.first, l.owned_count));
      CHECK(same_bits(w.particles.velocity, l.owned_begin, ref.particles.velocity, d.first, l.owned_count));
      CHECK(same_bits(w.particles.acceleration, l.owned_begin, ref.particles.acceleration, d.first, l.owned_count));
      CHECK(same_bits(w.state.dilatation, l.owned_begin, ref.state.dilatation, d.first, l.owned_count));
      CHECK(same_bits(w.state.damage, l.owned_begin, ref.state.damage, d.first, l.owned_count));
      CHECK(same_bits(w.state.break_extension, l.owned_begin, ref.state.break_extension, d.first, l.owned_count));
      const std::size_t bonds = w.bonds.count();
      CHECK(same_bits(w.bonds.alive, 0, ref.bonds.alive, l.bond_begin, bonds));
      CHECK(same_bits(w.bonds.plastic_extension, 0, ref.bonds.plastic_extension, l.bond_begin, bonds));
      CHECK(same_bits(w.bonds.plastic_extension_mirror, 0, ref.bonds.plastic_extension_mirror, l.bond_begin, bonds));
    }
  }
}

TEST_CASE("local worlds: stepped in lockstep with copied halos, every owned particle and bond matches one process") {
  // The tearing plate with contact on (the first bond breaks at step 44, 2.2 ms); 3 and 4 ranks, then
  // 3 ranks without the dilatation halo.
  lockstep_matches_one_process(kTear, 160, {3, 4, -3}, true, false);
}

TEST_CASE("local worlds: two blocks collide across ranks through contact ghosts, as in one process") {
  // They touch at about step 50 and separate again; 2 and 3 ranks, then 2 ranks without contact ghosts
  // (the blocks then pass through each other).
  lockstep_matches_one_process(kContactBlocks, 200, {2, 3, -2}, false, true);
}

TEST_CASE("local worlds: contact ghosts: a translation of everything keeps them, particles moving apart refresh them") {
  // The two blocks at 2 ranks, their contact ghosts refreshed, then positions set by hand (no step):
  // velocities and accelerations zero, so the look-ahead is zero (no colliders, no conditions).
  const World source(scene::load_scene_file(kContactBlocks));
  const WorldState& full = source.state();
  std::vector<Rank> ranks = split_ranks(full, 2);
  for (const auto& rank : ranks) REQUIRE(rank.world->contact.enabled);
  refresh_contact_ghosts(ranks);
  const double skin = ranks[0].layout.contact_skin, layer = ranks[0].layout.contact_layer;
  REQUIRE(skin > 0.0);
  REQUIRE(layer > skin);
  for (const auto& rank : ranks) CHECK(rank.world->particles.count() > rank.layout.base_count);  // some contact ghosts
  // The ghost set is complete: every other rank's particle within the layer of an owned one is local.
  std::size_t missing = 0, pairs_within = 0;
  for (const auto& rank : ranks) {
    const auto& l = rank.layout;
    const auto& local = l.global_of;
    std::vector<std::uint32_t> present(local.begin(), local.end());
    std::sort(present.begin(), present.end());
    const auto& domain = l.domains[static_cast<std::size_t>(l.rank)];
    for (std::uint32_t m = 0; m < l.owned_count; ++m)
      for (std::uint32_t g = 0; g < full.particles.count(); ++g) {
        if (g >= domain.first && g < domain.last) continue;
        if ((full.particles.position[g] - rank.world->particles.position[l.owned_begin + m]).norm() > layer) continue;
        ++pairs_within;
        missing += !std::binary_search(present.begin(), present.end(), g);
      }
  }
  CHECK(pairs_within > 0);
  CHECK(missing == 0);
  for (auto& rank : ranks) {
    auto& p = rank.world->particles;
    std::fill(p.velocity.begin(), p.velocity.end(), Vec3::Zero());
    std::fill(p.acceleration.begin(), p.acceleration.end(), Vec3::Zero());
  }
  CHECK_FALSE(contact_ghosts_stale(ranks));
  auto move_owned = [&](const Vec3& by) {
    for (auto& rank : ranks) {
      const auto& l = rank.layout;
      for (std::uint32_t i = l.owned_begin; i < l.owned_begin + l.owned_count; ++i) rank.world->particles.position[i] += by;
    }
  };
  // Every particle of every rank moved by 5 half skins: (A) fails, (B) holds (the box is a point).
  const Vec3 shift = 2.5 * skin * Vec3(0.6, -0.8, 0.0);
  move_owned(shift);
  {
    distributed::ContactGhostMotion all;
    for (const auto& rank : ranks) all = distributed::combine(all, distributed::contact_ghost_motion(*rank.world, rank.layout));
    CHECK_FALSE(all.within_half_skin);
    CHECK((all.high - all.low).norm() < 1e-9 * skin);
  }
  CHECK_FALSE(contact_ghosts_stale(ranks));
  // One particle of each rank, on top of it, moves 0.3 skin along +x and −x: 0.6 skin apart. Still kept.
  auto& y0 = ranks[0].world->particles.position;
  auto& y1 = ranks[1].world->particles.position;
  const std::uint32_t i0 = ranks[0].layout.owned_begin, i1 = ranks[1].layout.owned_begin;
  y0[i0].x() += 0.3 * skin;
  y1[i1].x() -= 0.3 * skin;
  CHECK_FALSE(contact_ghosts_stale(ranks));
  // 0.6 skin each way: 1.2 skin apart, more than the skin: stale.
  y0[i0].x() += 0.3 * skin;
  y1[i1].x() -= 0.3 * skin;
  CHECK(contact_ghosts_stale(ranks));
  // Back to the translation: kept again (the test looks at displacements since the refresh, not steps).
  y0[i0].x() -= 0.6 * skin;
  y1[i1].x() += 0.6 * skin;
  CHECK_FALSE(contact_ghosts_stale(ranks));
  // The look-ahead, on top of the translation: one particle's velocity would carry it 0.25 skin in
  // the next step, the others' nothing: the box of d ± L has a diagonal of 0.5 √3 = 0.87 skin, kept;
  // 0.3 skin: 0.6 √3 = 1.04 skin, stale.
  auto& v0 = ranks[0].world->particles.velocity;
  const double dt = ranks[0].world->clock.dt;
  REQUIRE(dt > 0.0);
  v0[i0] = Vec3(0.25 * skin / dt, 0.0, 0.0);
  CHECK_FALSE(contact_ghosts_stale(ranks));
  v0[i0] = Vec3(0.3 * skin / dt, 0.0, 0.0);
  CHECK(contact_ghosts_stale(ranks));
  // Without the translation (A) decides: 0.3 skin of look-ahead is within the half skin, 0.6 is not.
  move_owned(-shift);
  CHECK_FALSE(contact_ghosts_stale(ranks));
  v0[i0] = Vec3(0.6 * skin / dt, 0.0, 0.0);
  CHECK(distributed::contact_ghost_lookahead(*ranks[0].world, i0, false) == doctest::Approx(0.6 * skin));
  CHECK(contact_ghosts_stale(ranks));
  // The acceleration enters as the drift's dt²|a|/2.
  v0[i0] = Vec3::Zero();
  ranks[0].world->particles.acceleration[i0] = Vec3(0.0, 2.0 * 0.6 * skin / (dt * dt), 0.0);
  CHECK(distributed::contact_ghost_lookahead(*ranks[0].world, i0, false) == doctest::Approx(0.6 * skin));
  CHECK(contact_ghosts_stale(ranks));
  ranks[0].world->particles.acceleration[i0] = Vec3::Zero();
  CHECK_FALSE(contact_ghosts_stale(ranks));
  // A non-finite position is stale.
  y1[i1].z() = std::numeric_limits<double>::quiet_NaN();
  CHECK(contact_ghosts_stale(ranks));
}

TEST_CASE("local worlds: contact ghosts: a refresh sends the records of entering particles only and sets what a whole refresh sets") {
  const World source(scene::load_scene_file(kContactBlocks));
  const WorldState& full = source.state();
  // A record: every per-particle array's element (what a contact ghost carries besides its index).
  std::size_t record = 0;
  for_each_array(full, [&](ArrayKind kind, const char*, const auto& array) {
    if (kind == ArrayKind::particle && array.size() == full.particles.count()) record += sizeof(array[0]);
  });
  // The list part of the messages: per link a count and the global indices, 4 bytes each.
  auto list_bytes = [](const std::vector<Rank>& ranks) {
    std::size_t bytes = 0;
    for (const auto& rank : ranks)
      for (const auto& link : rank.layout.contact_sends) bytes += 4 * (1 + link.local.size());
    return bytes;
  };
  auto entering = [](const std::vector<Rank>& ranks, std::size_t* leaving = nullptr) {
    std::size_t count = 0;
    for (const auto& rank : ranks)
      for (const auto& link : rank.layout.contact_sends) {
        std::vector<std::uint32_t> before;
        for (const auto& b : rank.layout.contact_sends_before)
          if (b.rank == link.rank) before = b.local;
        for (std::uint32_t i : link.local) count += !std::binary_search(before.begin(), before.end(), i);
        if (leaving)
          for (std::uint32_t i : before) *leaving += !std::binary_search(link.local.begin(), link.local.end(), i);
      }
    return count;
  };
  auto tails = [](const Rank& rank) {  // the contact ghosts: indices and every per-particle array's bytes
    std::vector<char> bytes;
    const WorldState& w = *rank.world;
    const std::size_t n = w.particles.count(), base = rank.layout.base_count;
    for_each_array(w, [&](ArrayKind kind, const char*, const auto& array) {
      if (kind != ArrayKind::particle || array.size() != n) return;
      const char* first = reinterpret_cast<const char*>(array.data() + base);
      bytes.insert(bytes.end(), first, first + (n - base) * sizeof(array[0]));
    });
    const char* g = reinterpret_cast<const char*>(w.global_index.data() + base);
    bytes.insert(bytes.end(), g, g + (n - base) * sizeof(std::uint32_t));
    return bytes;
  };

  std::vector<Rank> ranks = split_ranks(full, 2);
  // The first refresh: every particle enters, whole records.
  const std::size_t first = refresh_contact_ghosts(ranks);
  const std::size_t first_ghosts = entering(ranks);
  REQUIRE(first_ghosts > 0);
  CHECK(first == list_bytes(ranks) + first_ghosts * record);
  // Nothing moved: the same lists, no record sent, the ghosts as they were.
  const std::vector<char> tail0 = tails(ranks[0]), tail1 = tails(ranks[1]);
  CHECK(refresh_contact_ghosts(ranks) == list_bytes(ranks));
  CHECK(entering(ranks) == 0);
  CHECK(tails(ranks[0]) == tail0);
  CHECK(tails(ranks[1]) == tail1);
  // Rank 1's particles move a layer along −x and half a block along +y, with the motion
  // halo after: particles enter and leave the lists; only the entering ones' records travel.
  const double layer = ranks[0].layout.contact_layer;
  for (std::size_t r = 0; r < ranks.size(); ++r) {
    const auto& l = ranks[r].layout;
    const Vec3 by = r == 1 ? Vec3(-layer, 0.05, 0.0) : Vec3::Zero();
    for (std::uint32_t i = l.owned_begin; i < l.owned_begin + l.owned_count; ++i) ranks[r].world->particles.position[i] += by;
  }
  for (std::size_t r = 0; r < ranks.size(); ++r) exchange_motion(ranks, r);
  const std::size_t moved = refresh_contact_ghosts(ranks);
  std::size_t leaving = 0;
  const std::size_t entered = entering(ranks, &leaving);
  MESSAGE(first_ghosts << " contact ghosts at first, then " << entered << " entering and " << leaving
                       << " leaving; record " << record << " B; " << first << " B, then " << moved << " B");
  CHECK(entered > 0);
  CHECK(leaving > 0);
  CHECK(moved == list_bytes(ranks) + entered * record);
  // The same ghosts, to the byte, as ranks that receive every record (a first refresh at these
  // positions).
  std::vector<Rank> whole = split_ranks(full, 2);
  for (std::size_t r = 0; r < ranks.size(); ++r) {
    const std::size_t base = ranks[r].layout.base_count;
    REQUIRE(whole[r].layout.base_count == base);
    std::copy_n(ranks[r].world->particles.position.begin(), base, whole[r].world->particles.position.begin());
  }
  refresh_contact_ghosts(whole);
  for (std::size_t r = 0; r < ranks.size(); ++r) {
    CAPTURE(r);
    CHECK(ranks[r].layout.global_of == whole[r].layout.global_of);
    CHECK(tails(ranks[r]) == tails(whole[r]));
  }
}

TEST_CASE("local worlds: contact ghosts: the refresh test's words keep the order of the doubles") {
  // encode_contact_ghost_motion's map: the minimum of the words is the words of the minimum (low) and
  // of the maximum (high), for values of either sign, zeros and infinities.
  const double values[] = {-std::numeric_limits<double>::infinity(), -1e300, -2.5, -1e-310, -0.0, 0.0, 1e-310,
                           3.0, 1e300, std::numeric_limits<double>::infinity()};
  for (double a : values)
    for (double b : values) {
      distributed::ContactGhostMotion ma, mb;
      ma.low = Vec3(a, b, 0.0);
      ma.high = Vec3(a, b, 0.0);
      mb.low = Vec3(b, a, 1.0);
      mb.high = Vec3(b, a, -1.0);
      mb.within_half_skin = false;
      std::uint64_t wa[distributed::kContactGhostMotionWords], wb[distributed::kContactGhostMotionWords],
          w[distributed::kContactGhostMotionWords];
      distributed::encode_contact_ghost_motion(ma, wa);
      distributed::encode_contact_ghost_motion(mb, wb);
      for (std::size_t k = 0; k < distributed::kContactGhostMotionWords; ++k) w[k] = std::min(wa[k], wb[k]);
      const auto got = distributed::decode_contact_ghost_motion(w);
      const auto want = distributed::combine(ma, mb);
      CAPTURE(a);
      CAPTURE(b);
      CHECK_FALSE(got.within_half_skin);
      for (int k = 0; k < 3; ++k) {
        CHECK(got.low[k] == want.low[k]);
        CHECK(got.high[k] == want.high[k]);
      }
      const auto back = distributed::decode_contact_ghost_motion(wa);  // a round trip keeps the bits
      CHECK(std::memcmp(back.low.data(), ma.low.data(), sizeof(Vec3)) == 0);
      CHECK(std::memcmp(back.high.data(), ma.high.data(), sizeof(Vec3)) == 0);
    }
}

TEST_CASE("local worlds: owned rows are the global rows, ghosts are exactly the far ends outside the range") {
  const World source(scene::load_scene_file(kTear));
  const WorldState& full = source.state();
  const auto domains = distributed::split_by_work(full, 3);
  for (int r = 0; r < 3; ++r) {
    auto layout = distributed::make_layout(full, domains, r);
    const auto w = distributed::make_local_world(full, layout);
    const auto& d = domains[static_cast<std::size_t>(r)];
    REQUIRE(w->particles.count() == layout.global_of.size());
    CHECK(std::is_sorted(layout.global_of.begin(), layout.global_of.end()));
    std::vector<std::uint8_t> is_far_end(full.particles.count(), 0);
    std::size_t wrong_owner = 0, wrong_row = 0, wrong_neighbor = 0, stray_ghosts = 0;
    for (std::uint32_t l = 0; l < w->particles.count(); ++l) {
      const std::uint32_t g = layout.global_of[l];
      const bool owned = g >= d.first && g < d.last;
      wrong_owner += owned != (l >= layout.owned_begin && l < layout.owned_begin + layout.owned_count);
      const std::uint32_t row = w->bonds.offsets[l + 1] - w->bonds.offsets[l];
      wrong_row += row != (owned ? full.bonds.offsets[g + 1] - full.bonds.offsets[g] : 0u);
      for (std::uint32_t k = w->bonds.offsets[l]; k < w->bonds.offsets[l + 1]; ++k) {
        const std::uint32_t far = layout.global_of[w->bonds.neighbor[k]];
        wrong_neighbor += far != full.bonds.neighbor[full.bonds.offsets[g] + (k - w->bonds.offsets[l])];
        is_far_end[far] = 1;
      }
    }
    // Every ghost is the far end of some owned bond (no contact in this scene).
    for (std::uint32_t l = 0; l < w->particles.count(); ++l)
      if (l < layout.owned_begin || l >= layout.owned_begin + layout.owned_count) stray_ghosts += !is_far_end[layout.global_of[l]];
    CHECK(wrong_owner == 0);
    CHECK(wrong_row == 0);
    CHECK(wrong_neighbor == 0);
    CHECK(stray_ghosts == 0);
    CHECK(layout.ghost_count() > 0);
    // Boundary lists hold owned particles only.
    for (std::uint32_t i : w->boundary.constrained)
      CHECK((i >= layout.owned_begin && i < layout.owned_begin + layout.owned_count));
  }
}

TEST_CASE("local worlds: the pieces the ranks find together are the one-process components") {
  // The tearing plate cut into 5 × 5 blocks across its bounding box: a bond between two blocks is
  // kept only when a hash of the block pair says so (1 pair in 4), and inside a block a hash of
  // the particle pair kills 1 bond in 3. Both directions of a bond alike, as in a run. That leaves
  // pieces of several blocks, some spread over several ranks. The ranks' labels are copied in memory
  // as the runtime sends them (owners to the ranks holding the particle as a ghost), round after round;
  // a second direction is not needed (engine/distributed/pieces.hpp says why) and is not sent.
  World source(scene::load_scene_file(kTear));
  WorldState full = source.state();
  const auto& x = full.particles.reference_position;
  Vec3 lo = x[0], hi = x[0];
  for (const Vec3& p : x) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  auto block = [&](std::uint32_t i) {
    const Vec3 c = ((x[i] - lo).array() / (hi - lo).array().max(1e-12) * 4.999).floor();
    return static_cast<std::uint64_t>(c.x() + 5 * c.y());
  };
  auto hash = [](std::uint64_t a, std::uint64_t b) {
    std::uint64_t h = (std::min(a, b) << 32 | std::max(a, b)) * 0x9E3779B97F4A7C15ull;
    return h ^ (h >> 29);
  };
  for (std::uint32_t i = 0; i < full.particles.count(); ++i)
    for (std::uint32_t k = full.bonds.offsets[i]; k < full.bonds.offsets[i + 1]; ++k) {
      const std::uint32_t j = full.bonds.neighbor[k];
      const std::uint64_t bi = block(i), bj = block(j);
      full.bonds.alive[k] = bi == bj ? hash(i, j) % 3 != 0 : hash(bi, bj) % 4 == 0;
    }
  std::vector<std::uint32_t> expected;
  const std::size_t pieces = systems::compute_fragments(full, expected);
  MESSAGE(pieces << " pieces among " << full.particles.count() << " particles");
  REQUIRE(pieces >= 4);
  for (int count : {2, 3, 4}) {
    CAPTURE(count);
    const auto domains = distributed::split_by_work(full, count);
    std::vector<distributed::LocalLayout> layouts(static_cast<std::size_t>(count));
    std::vector<std::unique_ptr<WorldState>> worlds;
    std::vector<distributed::PieceLabels> labels(layouts.size());
    for (std::size_t r = 0; r < layouts.size(); ++r) {
      layouts[r] = distributed::make_layout(full, domains, static_cast<int>(r));
      worlds.push_back(distributed::make_local_world(full, layouts[r]));
      distributed::label_local_pieces(*worlds[r], layouts[r], labels[r]);
    }
    // One direction of a round: every link's values from `from_links` land on `to_links` of the peer.
    auto send = [&](auto from_links, auto to_links) {
      bool lowered = false;
      std::vector<std::vector<std::uint32_t>> packed(layouts.size());
      for (std::size_t r = 0; r < layouts.size(); ++r)  // pack first, as the runtime does before it receives
        for (const auto& link : layouts[r].*from_links)
          for (std::uint32_t i : link.local) packed[r].push_back(distributed::piece_label(labels[r], i));
      for (std::size_t r = 0; r < layouts.size(); ++r) {
        std::size_t at = 0;
        for (const auto& link : layouts[r].*from_links) {
          const auto& peer = layouts[static_cast<std::size_t>(link.rank)];
          for (const auto& back : peer.*to_links)
            if (back.rank == static_cast<int>(r)) {
              REQUIRE(back.local.size() == link.local.size());
              for (std::size_t m = 0; m < link.local.size(); ++m)
                lowered = distributed::lower_piece_label(labels[static_cast<std::size_t>(link.rank)], back.local[m],
                                                         packed[r][at + m]) || lowered;
            }
          at += link.local.size();
        }
      }
      return lowered;
    };
    int rounds = 1;
    while (send(&distributed::LocalLayout::sends, &distributed::LocalLayout::receives)) ++rounds;
    MESSAGE(count << " ranks: " << rounds << " rounds");
    CHECK(rounds >= 2);  // some piece lies on two ranks
    std::size_t wrong = 0, spread = 0;
    for (std::size_t r = 0; r < layouts.size(); ++r) {
      const auto& l = layouts[r];
      std::vector<std::uint32_t> roots(l.owned_count);
      distributed::owned_piece_roots(labels[r], l, roots.data());
      const std::uint32_t first = domains[r].first;
      for (std::uint32_t m = 0; m < l.owned_count; ++m) {
        wrong += roots[m] != expected[first + m];
        spread += roots[m] < first;  // its piece reaches into a lower rank's range
      }
    }
    CHECK(wrong == 0);
    CHECK(spread > 0);
  }
}

TEST_CASE("local worlds: a local world sent as bytes and rebuilt on a rank that holds no arrays is the same to the byte") {
  // A re-split sends each rank only its part (pack_local_world); the rank rebuilds it with the
  // non-array parts of its own copy of the world, whose arrays World::split released. The tearing plate
  // with contact, stepped until bonds have broken and plastic extensions are stored, at 3 ranks.
  scene::Scene sc = scene::load_scene_file(kTear);
  sc.contact.mode = scene::Contact::Mode::on;
  World world(sc);
  world.step(60);
  REQUIRE(world.alive_bond_count() < world.bond_count());
  const WorldState& full = world.state();
  World released(sc);  // the same scene's world, stepped as far, then its arrays released
  released.step(60);
  WorldState& shell = released.state_mutable();
  for_each_array(shell, [](ArrayKind, const char*, auto& array) { std::remove_reference_t<decltype(array)>().swap(array); });
  const auto domains = distributed::split_by_work(full, 3);
  std::size_t sent = 0;
  for (int r = 0; r < 3; ++r) {
    CAPTURE(r);
    distributed::LocalLayout made = distributed::make_layout(full, domains, r);
    const auto expected = distributed::make_local_world(full, made);
    const std::vector<char> message = distributed::pack_local_world(*expected, made);
    {  // what rank 0 sends: the same bytes from a local world made only to be sent
      distributed::LocalLayout to_send = distributed::make_layout(full, domains, r);
      CHECK(distributed::pack_local_world(*distributed::make_local_world(full, to_send, true), to_send) == message);
    }
    sent += message.size();
    distributed::LocalLayout got;
    got.rank = r;
    got.ranks = 3;
    got.domains = domains;
    const auto rebuilt = distributed::local_world_from(shell, got, message);
    CHECK(got.global_of == made.global_of);
    CHECK(got.owned_begin == made.owned_begin);
    CHECK(got.owned_count == made.owned_count);
    CHECK(got.bond_begin == made.bond_begin);
    CHECK(got.base_count == made.base_count);
    CHECK(got.contact_layer == made.contact_layer);
    auto same_links = [](const std::vector<distributed::HaloLink>& a, const std::vector<distributed::HaloLink>& b) {
      if (a.size() != b.size()) return false;
      for (std::size_t k = 0; k < a.size(); ++k)
        if (a[k].rank != b[k].rank || a[k].local != b[k].local) return false;
      return true;
    };
    CHECK(same_links(got.sends, made.sends));
    CHECK(same_links(got.receives, made.receives));
    // Every array, contact buffers included (rebuilt from the same inputs).
    CHECK(differing_arrays(*expected, *rebuilt) == 0);
    // And the parts that are not arrays.
    CHECK(rebuilt->clock.step == expected->clock.step);
    CHECK(rebuilt->owned_first == expected->owned_first);
    CHECK(rebuilt->owned_last == expected->owned_last);
    CHECK(rebuilt->any_plastic == expected->any_plastic);
    CHECK(rebuilt->any_fracture == expected->any_fracture);
    CHECK(rebuilt->boundary.conditions.size() == expected->boundary.conditions.size());
    CHECK(rebuilt->loads.loads.size() == expected->loads.loads.size());
    CHECK(rebuilt->contact.enabled == expected->contact.enabled);
    CHECK(rebuilt->contact.largest_distance == expected->contact.largest_distance);
    CHECK(rebuilt->embedded.motion == expected->embedded.motion);
  }
  // Against the whole world (its arrays but the mesh's and contact's), which every rank received before.
  std::size_t whole = 0;
  for_each_array(full, [&](ArrayKind kind, const char*, const auto& a) {
    if (kind != ArrayKind::mesh && kind != ArrayKind::contact) whole += a.size() * sizeof(a[0]);
  });
  MESSAGE("3 ranks: the three local worlds are " << sent << " bytes in all; the whole world " << whole << " bytes");
  CHECK(sent < 2 * whole);  // each rank's part and its ghosts: about 1/3 of the world each, not 3 worlds
}

TEST_CASE("local worlds: a rank's shell (WorldBuild::shell) holds no arrays and makes the local world the whole world makes") {
  // Under mpirun the ranks other than 0 build a shell and receive their part from rank 0 (World::split):
  // its non-array parts must be the whole world's. Three scenes: the tearing plate with contact; two
  // bodies, one anisotropic, with an initial crack, loads, a projectile and colliders; the FEM beam.
  const std::filesystem::path dir = std::filesystem::path(PERIFX_SOURCE_DIR) / "tests/engine/distributed";
  for (const char* name : {"mpi_tear.json", "mpi_impact.json", "mpi_fem.json"}) {
    CAPTURE(name);
    const scene::Scene sc = scene::load_scene_file(dir / name);
    World whole(sc);
    whole.step(3);  // a clock that is not the one a shell starts with
    World shell_world(sc, WorldBuild::shell);
    CHECK(shell_world.shell());
    CHECK_FALSE(whole.shell());
    const WorldState& full = whole.state();
    WorldState& shell = shell_world.state_mutable();
    std::size_t held = 0;
    for_each_array(shell, [&](ArrayKind, const char*, const auto& a) { held += a.capacity(); });
    CHECK(held == 0);  // nothing was meshed or allocated
    // What needs the meshes comes from rank 0 before the split (World::split broadcasts it).
    CHECK(shell.settings.max_speed != full.settings.max_speed);
    distributed::take_world_frame(shell, distributed::pack_world_frame(full));
    CHECK(shell.clock.step == 3);
    CHECK(shell.clock.time == full.clock.time);
    CHECK(shell.contact.pairs.skin == full.contact.pairs.skin);
    // What set_local_frame and finish_local_world read (local_world.cpp), field by field.
    CHECK(shell.settings.max_speed == full.settings.max_speed);
    CHECK(shell.settings.gravity == full.settings.gravity);
    CHECK(shell.settings.materials.size() == full.settings.materials.size());
    CHECK(shell.settings.colliders.size() == full.settings.colliders.size());
    CHECK(shell.settings.projectiles.size() == full.settings.projectiles.size());
    CHECK(shell.clock.dt == full.clock.dt);
    CHECK(shell.any_plastic == full.any_plastic);
    CHECK(shell.any_anisotropic == full.any_anisotropic);
    CHECK(shell.any_fracture == full.any_fracture);
    REQUIRE(shell.bodies.size() == full.bodies.size());
    for (std::size_t b = 0; b < full.bodies.size(); ++b) {
      CHECK(shell.bodies[b].name == full.bodies[b].name);
      CHECK(shell.bodies[b].first_particle == full.bodies[b].first_particle);
      CHECK(shell.bodies[b].particle_count == full.bodies[b].particle_count);
      CHECK(shell.bodies[b].mean_edge_length == full.bodies[b].mean_edge_length);
      CHECK(shell.bodies[b].horizon == full.bodies[b].horizon);
    }
    CHECK(shell.boundary.conditions.size() == full.boundary.conditions.size());
    CHECK(shell.loads.loads.size() == full.loads.loads.size());
    CHECK(shell.fem.corotated == full.fem.corotated);
    CHECK(shell.embedded.motion == full.embedded.motion);
    CHECK(shell.contact.enabled == full.contact.enabled);
    CHECK(shell.contact.largest_distance == full.contact.largest_distance);
    // And the local worlds made from it, against those made from the whole world, at 3 ranks.
    const auto domains = distributed::split_by_work(full, 3);
    for (int r = 0; r < 3; ++r) {
      CAPTURE(r);
      distributed::LocalLayout made = distributed::make_layout(full, domains, r);
      const auto expected = distributed::make_local_world(full, made);
      distributed::LocalLayout got;
      got.rank = r;
      got.ranks = 3;
      got.domains = domains;
      const auto rebuilt = distributed::local_world_from(shell, got, distributed::pack_local_world(*expected, made));
      CHECK(differing_arrays(*expected, *rebuilt) == 0);
      CHECK(got.contact_layer == made.contact_layer);
      CHECK(got.contact_skin == made.contact_skin);
      CHECK(rebuilt->settings.max_speed == expected->settings.max_speed);
      CHECK(rebuilt->contact.enabled == expected->contact.enabled);
      CHECK(rebuilt->contact.pairs.skin == expected->contact.pairs.skin);
    }
  }
}

TEST_CASE("local worlds: a shell steps only once distributed") {
  World shell(scene::load_scene_file(kTear), WorldBuild::shell);
  CHECK_THROWS_AS(shell.step(), std::logic_error);
}
