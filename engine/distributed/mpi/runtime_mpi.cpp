// The distributed runtime on Open MPI (runtime.hpp has the contract). Compiled with PERIFX_MPI only.
// MPI is started with MPI_THREAD_SERIALIZED: the halo exchanges run inside the step's oneTBB graph on
// whichever worker runs their node, but the graph orders them (each depends on the one before), and
// the gathers and reductions run between steps on the calling thread, so no two MPI calls overlap.
#include <mpi.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>
#include <type_traits>
#include <utility>

#include "distributed/local_world.hpp"
#include "distributed/pieces.hpp"
#include "distributed/runtime.hpp"
#include "scheduler.hpp"
#include "systems/bond_rules.hpp"
#include "systems/pipeline.hpp"
#include "systems/systems.hpp"

namespace perifx::distributed {
namespace {

void check(int code, const char* what) {
  if (code == MPI_SUCCESS) return;
  char text[MPI_MAX_ERROR_STRING];
  int length = 0;
  MPI_Error_string(code, text, &length);
  throw std::runtime_error(std::string("MPI ") + what + " failed: " + std::string(text, static_cast<std::size_t>(length)));
}

// Messages are cut into pieces of at most this many bytes (MPI counts are int).
constexpr std::size_t kChunk = std::size_t{1} << 30;

void send_bytes(const void* data, std::size_t bytes, int to, int tag) {
  const char* p = static_cast<const char*>(data);
  std::size_t at = 0;
  do {  // one message even for 0 bytes, so both sides make the same calls
    const int n = static_cast<int>(std::min(kChunk, bytes - at));
    check(MPI_Send(p + at, n, MPI_BYTE, to, tag, MPI_COMM_WORLD), "send");
    at += static_cast<std::size_t>(n);
  } while (at < bytes);
}

void receive_bytes(void* data, std::size_t bytes, int from, int tag) {
  char* p = static_cast<char*>(data);
  std::size_t at = 0;
  do {
    const int n = static_cast<int>(std::min(kChunk, bytes - at));
    check(MPI_Recv(p + at, n, MPI_BYTE, from, tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE), "receive");
    at += static_cast<std::size_t>(n);
  } while (at < bytes);
}

// Rank 0 receives every rank's slice into `target`: its own `count` elements from `mine` at
// slice_of(0).first, the others' at slice_of(r) = [first, last); other ranks send their `count`.
template <class T, class SliceOf>
void gather_slices(const T* mine, std::size_t count, T* target, int rank, int ranks, int tag, SliceOf&& slice_of) {
  if (rank != 0) return send_bytes(mine, count * sizeof(T), 0, tag);
  std::memcpy(static_cast<void*>(target + slice_of(0).first), mine, count * sizeof(T));
  for (int r = 1; r < ranks; ++r) {
    const auto [first, last] = slice_of(r);
    receive_bytes(target + first, (last - first) * sizeof(T), r, tag);
  }
}

enum Tag : int { kTagMotion = 11, kTagDilatation = 12, kTagThreshold = 13, kTagPieces = 14, kTagGather = 20,
                 kTagLocalWorld = 30 };

// Per rank, one link holding a's particles then b's (both lists of links ordered by rank).
std::vector<HaloLink> merge_links(const std::vector<HaloLink>& a, const std::vector<HaloLink>& b) {
  std::vector<HaloLink> out = a;
  for (const HaloLink& link : b) {
    auto at = std::find_if(out.begin(), out.end(), [&](const HaloLink& l) { return l.rank == link.rank; });
    if (at == out.end()) at = out.insert(std::find_if(out.begin(), out.end(), [&](const HaloLink& l) { return l.rank > link.rank; }), HaloLink{link.rank, {}});
    at->local.insert(at->local.end(), link.local.begin(), link.local.end());
  }
  return out;
}

bool mpi_started() {
  int started = 0;
  MPI_Initialized(&started);
  return started != 0;
}
void require_mpi() {
  if (!mpi_started()) throw std::runtime_error("the distributed runtime needs MPI started (run under mpirun)");
}

int int_count(std::size_t count, const char* what) {
  if (count > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    throw std::runtime_error(std::string("a ") + what + " message is larger than MPI's int count (" +
                             std::to_string(count) + ")");
  return static_cast<int>(count);
}

}  // namespace

void broadcast_bytes(void* data, std::size_t bytes, Wait wait) {
  require_mpi();
  char* p = static_cast<char*>(data);
  for (std::size_t at = 0; at < bytes; at += kChunk) {
    const int count = static_cast<int>(std::min(kChunk, bytes - at));
    if (wait == Wait::spin) {
      check(MPI_Bcast(p + at, count, MPI_BYTE, 0, MPI_COMM_WORLD), "broadcast");
      continue;
    }
    MPI_Request request;
    check(MPI_Ibcast(p + at, count, MPI_BYTE, 0, MPI_COMM_WORLD, &request), "broadcast");
    for (int done = 0;;) {
      check(MPI_Test(&request, &done, MPI_STATUS_IGNORE), "broadcast test");
      if (done) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
}

int job_rank() {
  int rank = 0;
  if (mpi_started()) MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  return rank;
}

setup::RankPlacement rank_placement() {
  if (!mpi_started()) return {};
  int rank = 0, ranks = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  MPI_Comm machine;
  check(MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, rank, MPI_INFO_NULL, &machine), "comm split");
  int local = 1, lowest = rank;
  MPI_Comm_size(machine, &local);
  check(MPI_Allreduce(&rank, &lowest, 1, MPI_INT, MPI_MIN, machine), "allreduce");
  MPI_Comm_free(&machine);
  return {ranks, local, lowest == 0};
}

MpiSession::MpiSession(int& argc, char**& argv) {
  if (!launched_by_mpirun()) return;
  int provided = 0;
  check(MPI_Init_thread(&argc, &argv, MPI_THREAD_SERIALIZED, &provided), "init");
  if (provided < MPI_THREAD_SERIALIZED) {
    MPI_Finalize();
    throw std::runtime_error("this MPI library cannot be called from more than one thread (MPI_THREAD_SERIALIZED)");
  }
  active_ = true;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks_);
}

MpiSession::~MpiSession() {
  if (active_) MPI_Finalize();
}

void MpiSession::abort(int exit_code) const {
  if (active_) MPI_Abort(MPI_COMM_WORLD, exit_code);
  std::exit(exit_code);
}

struct Runtime::Impl {
  LocalLayout layout;
  std::unique_ptr<WorldState> local;
  std::unique_ptr<Scheduler> scheduler;
  systems::PipelineOptions::Halo halo;
  // The motion halo's links: the bond ghosts' and the contact ghosts' (set at each contact refresh).
  std::vector<HaloLink> motion_sends, motion_receives;
  // Per link: packed values, sized when the links are (no allocation in a step). Motion carries 6
  // doubles per particle, the other stages 1 over the bond links.
  std::vector<std::vector<double>> send_buffer, receive_buffer, motion_send_buffer, motion_receive_buffer;
  std::vector<MPI_Request> requests;
  std::vector<int> counts, displacements;  // per rank, for the collectives with a count per rank
  // Running totals (share()): halo bytes received by exchange() and the contact-ghost refreshes, steps,
  // refreshes, gathers, label rounds and their times; `contact` holds the list counters of the
  // runtimes before a re-split (this one's are in its local world's list). The counts of now are
  // filled in by share().
  RankStats totals;
  std::vector<double> projectile_mine;     // this rank's projectile contacts, while they are gathered
  std::vector<Domain> rebalanced;          // the re-split a StepReport asked for
  // The embedded mesh (rank 0's full world) is split by replaying, at each gather, every step's breaks:
  // each rank records which of its owned bonds broke at which step.
  bool track_breaks = false;
  std::vector<std::uint8_t> alive_seen;    // per owned bond: alive as of the last record
  std::vector<std::uint32_t> broken_seen;  // per owned particle: broken-bond count as of then
  std::vector<std::uint64_t> break_events; // (step, global bond index) pairs since the last gather
  std::uint64_t replayed_step = 0;         // rank 0: its full world's mesh is split up to this step

  // Appends this step's breaks of owned bonds (only particles whose broken-bond count changed are scanned).
  void record_breaks(std::uint64_t step) {
    const WorldState& w = *local;
    const auto& b = w.bonds;
    for (std::uint32_t m = 0; m < layout.owned_count; ++m) {
      const std::uint32_t i = layout.owned_begin + m;
      if (w.state.broken_bonds[i] == broken_seen[m]) continue;
      broken_seen[m] = w.state.broken_bonds[i];
      for (std::uint32_t k = b.offsets[i]; k < b.offsets[i + 1]; ++k)
        if (alive_seen[k] && !b.alive[k]) {
          alive_seen[k] = 0;
          break_events.push_back(step);
          break_events.push_back(layout.bond_begin + k);
        }
    }
  }

  // Rank 0: every rank's break events, then the crack faces and vertex splits of every step since the
  // last replay, on the full world's bond states as they were after each step (the systems read only
  // those and the mesh: systems/crack_faces.cpp, mesh_split.cpp). Collective.
  void replay_mesh(WorldState& full) {
    std::vector<std::uint64_t> all;
    const int count = int_count(break_events.size(), "break event");
    check(MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD), "gather");
    std::size_t total = 0;
    if (layout.rank == 0)
      for (std::size_t q = 0; q < counts.size(); ++q) {
        displacements[q] = int_count(total, "break event");
        total += static_cast<std::size_t>(counts[q]);
      }
    all.resize(total);
    check(MPI_Gatherv(break_events.data(), count, MPI_UINT64_T, all.data(), counts.data(), displacements.data(),
                      MPI_UINT64_T, 0, MPI_COMM_WORLD),
          "gatherv");
    break_events.clear();
    const std::uint64_t now = local->clock.step;
    if (layout.rank != 0) return;
    std::vector<std::pair<std::uint64_t, std::uint64_t>> events(total / 2);
    for (std::size_t q = 0; q < events.size(); ++q) events[q] = {all[2 * q], all[2 * q + 1]};
    std::sort(events.begin(), events.end());
    SystemDecl crack = systems::crack_face_system(full), split = systems::mesh_split_system(full);
    std::size_t next = 0;
    for (std::uint64_t s = replayed_step + 1; s <= now; ++s) {
      for (; next < events.size() && events[next].first == s; ++next) full.bonds.alive[events[next].second] = 0;
      crack.run();
      split.run();
    }
    replayed_step = now;
  }

  // This rank's owned particles' work now (decomposition.hpp current_work).
  std::vector<std::uint32_t> owned_work() const {
    return current_work(*local, layout.owned_begin, layout.owned_count);
  }

  // The re-balance check (Runtime::step). True when `rebalanced` holds a new split. Collective.
  bool check_balance() {
    const auto work = owned_work();
    std::uint64_t mine = 0;
    for (std::uint32_t x : work) mine += x;
    std::vector<std::uint64_t> per_rank;
    all_gather(std::vector<std::uint64_t>{mine}, per_rank, MPI_UINT64_T);
    std::uint64_t sum = 0, most = 0;
    for (std::uint64_t t : per_rank) {
      sum += t;
      most = std::max(most, t);
    }
    // most > (1 + drift) · mean, in doubles from integers: the same decision on every rank.
    const double mean = static_cast<double>(sum) / static_cast<double>(per_rank.size());
    if (!(static_cast<double>(most) > (1.0 + local->settings.distributed.rebalance_drift) * mean)) return false;
    std::vector<std::uint32_t> all;
    all_gather(work, all, MPI_UINT32_T);
    rebalanced = split_by_work(all, layout.ranks);
    for (std::size_t r = 0; r < rebalanced.size(); ++r)
      if (rebalanced[r].first != layout.domains[r].first || rebalanced[r].last != layout.domains[r].last) return true;
    return false;  // the equal-work split is the current one
  }

  // One halo stage over (sends, receives): `width` doubles per particle, packed by `pack`, unpacked
  // by `unpack`.
  template <class Pack, class Unpack>
  void exchange(const std::vector<HaloLink>& sends, const std::vector<HaloLink>& receives,
                std::vector<std::vector<double>>& send_buf, std::vector<std::vector<double>>& receive_buf, int width,
                int tag, Pack&& pack, Unpack&& unpack) {
    const auto w = static_cast<std::size_t>(width);
    std::size_t r = 0;
    for (std::size_t q = 0; q < receives.size(); ++q, ++r) {
      const auto& link = receives[q];
      check(MPI_Irecv(receive_buf[q].data(), static_cast<int>(link.local.size() * w), MPI_DOUBLE, link.rank, tag,
                      MPI_COMM_WORLD, &requests[r]),
            "receive");
      totals.halo_bytes += link.local.size() * w * sizeof(double);
    }
    for (std::size_t q = 0; q < sends.size(); ++q, ++r) {
      const auto& link = sends[q];
      double* out = send_buf[q].data();
      for (std::size_t m = 0; m < link.local.size(); ++m) pack(link.local[m], out + m * w);
      check(MPI_Isend(out, static_cast<int>(link.local.size() * w), MPI_DOUBLE, link.rank, tag, MPI_COMM_WORLD,
                      &requests[r]),
            "send");
    }
    check(MPI_Waitall(static_cast<int>(r), requests.data(), MPI_STATUSES_IGNORE), "wait");
    for (std::size_t q = 0; q < receives.size(); ++q) {
      const auto& link = receives[q];
      const double* in = receive_buf[q].data();
      for (std::size_t m = 0; m < link.local.size(); ++m) unpack(link.local[m], in + m * w);
    }
  }

  // The pieces (pieces.hpp): local components, then rounds of labels over the bond links, owners to
  // ghosts, until no rank lowers a label. Collective. Labels travel as doubles (exact below
  // 2^53) in the θ halo's buffers; the traffic is not counted in halo_bytes, which is the step's.
  PieceLabels pieces;
  std::vector<std::uint32_t> owned_roots;
  void find_pieces() {
    label_local_pieces(*local, layout, pieces);
    const std::uint64_t step_bytes = totals.halo_bytes;
    auto pack = [&](std::uint32_t i, double* out) { out[0] = piece_label(pieces, i); };
    int lowered = 0;
    auto unpack = [&](std::uint32_t i, const double* in) {
      lowered |= lower_piece_label(pieces, i, static_cast<std::uint32_t>(in[0])) ? 1 : 0;
    };
    for (;;) {
      lowered = 0;
      ++totals.piece_rounds;
      exchange(layout.sends, layout.receives, send_buffer, receive_buffer, 1, kTagPieces, pack, unpack);
      int any = 0;
      check(MPI_Allreduce(&lowered, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD), "allreduce");
      if (any == 0) break;
    }
    totals.halo_bytes = step_bytes;
    owned_roots.resize(layout.owned_count);
    owned_piece_roots(pieces, layout, owned_roots.data());
  }

  // The motion links and their buffers, from the bond links and the current contact ghosts.
  void set_motion_links() {
    motion_sends = merge_links(layout.sends, layout.contact_sends);
    motion_receives = merge_links(layout.receives, layout.contact_receives);
    motion_send_buffer.clear();
    motion_receive_buffer.clear();
    for (const auto& link : motion_sends) motion_send_buffer.emplace_back(6 * link.local.size());
    for (const auto& link : motion_receives) motion_receive_buffer.emplace_back(6 * link.local.size());
    requests.resize(std::max(requests.size(), motion_sends.size() + motion_receives.size()));
  }

  // Every rank's `mine` (count elements of `type` each), concatenated in rank order into `all`.
  template <class T>
  void all_gather(const std::vector<T>& mine, std::vector<T>& all, MPI_Datatype type) {
    const int count = int_count(mine.size(), "gather");
    check(MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD), "allgather");
    std::size_t total = 0;
    for (std::size_t q = 0; q < counts.size(); ++q) {
      displacements[q] = int_count(total, "gather");
      total += static_cast<std::size_t>(counts[q]);
    }
    all.resize(total);
    check(MPI_Allgatherv(mine.data(), count, type, all.data(), counts.data(), displacements.data(), type,
                         MPI_COMM_WORLD),
          "allgatherv");
  }

  // A contact ghost refresh (local_world.hpp): occupied cells to every rank, then each rank's records
  // to the ranks near them. Collective.
  void refresh_contact_ghosts() {
    WorldState& w = *local;
    const auto ranks = static_cast<std::size_t>(layout.ranks);
    std::vector<std::uint64_t> all_cells;
    all_gather(contact_cells(w, layout), all_cells, MPI_UINT64_T);
    std::vector<std::vector<std::uint64_t>> cells_by_rank(ranks);
    for (std::size_t q = 0; q < ranks; ++q)
      cells_by_rank[q].assign(all_cells.begin() + displacements[q], all_cells.begin() + displacements[q] + counts[q]);
    find_contact_sends(w, layout, cells_by_rank);
    std::vector<int> send_counts(ranks, 0), send_displacements(ranks, 0), receive_counts(ranks, 0),
        receive_displacements(ranks, 0);
    std::vector<char> out;
    for (const auto& link : layout.contact_sends) {
      const auto q = static_cast<std::size_t>(link.rank);
      std::vector<char> packed = pack_contact_ghosts(w, layout, link);
      send_displacements[q] = int_count(out.size(), "contact ghost");
      send_counts[q] = int_count(packed.size(), "contact ghost");
      out.insert(out.end(), packed.begin(), packed.end());
    }
    check(MPI_Alltoall(send_counts.data(), 1, MPI_INT, receive_counts.data(), 1, MPI_INT, MPI_COMM_WORLD), "alltoall");
    std::size_t total = 0;
    for (std::size_t q = 0; q < ranks; ++q) {
      receive_displacements[q] = int_count(total, "contact ghost");
      total += static_cast<std::size_t>(receive_counts[q]);
    }
    std::vector<char> in(total);
    check(MPI_Alltoallv(out.data(), send_counts.data(), send_displacements.data(), MPI_BYTE, in.data(),
                        receive_counts.data(), receive_displacements.data(), MPI_BYTE, MPI_COMM_WORLD),
          "alltoallv");
    std::vector<std::pair<int, std::vector<char>>> received;
    for (std::size_t q = 0; q < ranks; ++q)
      if (receive_counts[q] > 0)
        received.emplace_back(static_cast<int>(q), std::vector<char>(in.begin() + receive_displacements[q],
                                                                     in.begin() + receive_displacements[q] + receive_counts[q]));
    set_contact_ghosts(w, layout, received);
    set_motion_links();
    ++totals.contact_ghost_refreshes;
    totals.halo_bytes += total;
  }
};

Runtime::Runtime(const WorldState& full, int threads, const std::vector<Domain>* domains, const RankStats* before)
    : impl_(std::make_unique<Impl>()) {
  if (before) impl_->totals = *before;  // its counts of now are replaced in share()
  require_mpi();
  int rank = 0, ranks = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  Impl& m = *impl_;
  if (domains && domains->size() != static_cast<std::size_t>(ranks))
    throw std::logic_error("Runtime: a split for " + std::to_string(domains->size()) + " ranks, the job has " +
                           std::to_string(ranks));
  // The first split is rank 0's plan (the other ranks may hold a shell: WorldBuild::shell); its
  // ranges and work go to every rank, which is all a layout reads of the other ranks' domains.
  std::vector<Domain> planned;
  if (!domains) {
    if (rank == 0) planned = split_by_work(full, ranks);
    planned.resize(static_cast<std::size_t>(ranks));
    std::vector<std::uint64_t> ranges(4 * planned.size());
    for (std::size_t q = 0; q < planned.size(); ++q) {
      const Domain& d = planned[q];
      std::copy_n(std::array<std::uint64_t, 4>{d.first, d.last, d.bonds, d.work}.begin(), 4, ranges.begin() + 4 * q);
    }
    broadcast_bytes(ranges.data(), ranges.size() * sizeof(std::uint64_t));
    for (std::size_t q = 0; q < planned.size(); ++q) {
      planned[q].first = static_cast<std::uint32_t>(ranges[4 * q]);
      planned[q].last = static_cast<std::uint32_t>(ranges[4 * q + 1]);
      planned[q].bonds = ranges[4 * q + 2];
      planned[q].work = ranges[4 * q + 3];
    }
    domains = &planned;
  }
  if (rank != 0) {
    // This rank's part, made by rank 0 from the whole world (local_world.hpp, write_local_world).
    m.layout.rank = rank;
    m.layout.ranks = ranks;
    m.layout.domains = *domains;
    m.local = read_local_world(full, m.layout, [](void* data, std::size_t bytes) {
      receive_bytes(data, bytes, 0, kTagLocalWorld);  // piece by piece, straight into the arrays
    });
  } else {
    // Every rank's ghost lists, computed once for all the layouts; one part at a time, so rank 0
    // holds one more local world at most.
    const std::vector<std::vector<std::uint32_t>> ghosts = bond_ghosts(full, *domains);
    for (int q = 1; q < ranks; ++q) {
      LocalLayout theirs = make_layout(full, *domains, q, &ghosts);
      write_local_world(*make_local_world(full, theirs, true), theirs, [q](const void* data, std::size_t bytes) {
        send_bytes(data, bytes, q, kTagLocalWorld);
      });
    }
    m.layout = make_layout(full, *domains, rank, &ghosts);
    m.local = make_local_world(full, m.layout);
  }
  for (const auto& link : m.layout.sends) m.send_buffer.emplace_back(link.local.size());
  for (const auto& link : m.layout.receives) m.receive_buffer.emplace_back(link.local.size());
  m.requests.resize(m.layout.sends.size() + m.layout.receives.size());
  m.counts.resize(static_cast<std::size_t>(ranks));
  m.displacements.resize(static_cast<std::size_t>(ranks));
  m.set_motion_links();

  WorldState& w = *m.local;
  if (w.contact.enabled) m.refresh_contact_ghosts();
  // Rank 0's word: other ranks may have released their copy of the mesh.
  m.track_breaks = full.any_fracture && !full.embedded.tets.empty();
  {
    int track = m.track_breaks ? 1 : 0;
    check(MPI_Bcast(&track, 1, MPI_INT, 0, MPI_COMM_WORLD), "broadcast");
    m.track_breaks = track != 0;
  }
  if (m.track_breaks) {
    if (full.embedded.motion != VertexMotion::deformation)
      throw std::invalid_argument("the embedded mesh's vertex motion is not 'deformation' (a test option): "
                                  "a distributed run cannot step it; run this scene in one process");
    m.alive_seen = w.bonds.alive;
    m.broken_seen.assign(w.state.broken_bonds.begin() + m.layout.owned_begin,
                         w.state.broken_bonds.begin() + m.layout.owned_begin + m.layout.owned_count);
    m.replayed_step = full.clock.step;
  }
  m.halo.motion = [&m, &w] {
    auto& y = w.particles.position;
    auto& v = w.particles.velocity;
    m.exchange(
        m.motion_sends, m.motion_receives, m.motion_send_buffer, m.motion_receive_buffer, 6, kTagMotion,
        [&](std::uint32_t i, double* out) {
          std::memcpy(out, y[i].data(), 3 * sizeof(double));
          std::memcpy(out + 3, v[i].data(), 3 * sizeof(double));
        },
        [&](std::uint32_t i, const double* in) {
          std::memcpy(y[i].data(), in, 3 * sizeof(double));
          std::memcpy(v[i].data(), in + 3, 3 * sizeof(double));
        });
  };
  m.halo.dilatation = [&m, &w] {
    auto& theta = w.state.dilatation;
    auto& coupling = w.state.dilatation_coupling;
    // θ travels; P follows from it and constants the ghost already has, with the same expression.
    m.exchange(
        m.layout.sends, m.layout.receives, m.send_buffer, m.receive_buffer, 1, kTagDilatation, [&](std::uint32_t i, double* out) { out[0] = theta[i]; },
        [&](std::uint32_t i, const double* in) {
          theta[i] = in[0];
          coupling[i] = systems::dilatation_coupling(w.model, i, in[0]);
        });
  };
  m.halo.threshold = [&m, &w] {
    auto& limit = w.state.break_extension;
    m.exchange(
        m.layout.sends, m.layout.receives, m.send_buffer, m.receive_buffer, 1, kTagThreshold, [&](std::uint32_t i, double* out) { out[0] = limit[i]; },
        [&](std::uint32_t i, const double* in) { limit[i] = in[0]; });
  };
  m.halo.projectile_contacts = [&m](std::vector<double>& contacts) {
    m.projectile_mine.assign(contacts.begin(), contacts.end());  // allocates only when it outgrows itself
    m.all_gather(m.projectile_mine, contacts, MPI_DOUBLE);
  };
  m.scheduler = std::make_unique<Scheduler>(threads);
  systems::PipelineOptions options;
  options.halo = &m.halo;
  options.embedded_mesh = false;
  for (auto& system : systems::step_pipeline(w, options)) m.scheduler->add(std::move(system));
  m.scheduler->build();
}

Runtime::~Runtime() {
  if (impl_) impl_->scheduler.reset();  // the graph's nodes reference the local world
}

int Runtime::rank() const { return impl_->layout.rank; }
int Runtime::ranks() const { return impl_->layout.ranks; }

StepReport Runtime::step(bool check_broken) {
  Impl& m = *impl_;
  WorldState& w = *m.local;
  m.scheduler->run_step();
  ++m.totals.steps;
  auto& c = w.clock;
  ++c.step;
  c.time = static_cast<double>(c.step) * c.dt;
  if (m.track_breaks) m.record_breaks(c.step);
  // [0] lowest unstable global index, [1] 0 when some owned particle has a broken bond, [2, 9) the
  // contact ghosts' motion since their last refresh (local_world.hpp, encode_contact_ghost_motion):
  // all minima, in one reduction.
  constexpr std::size_t kWords = 2 + kContactGhostMotionWords;
  std::uint64_t mine[kWords] = {ParticleState::kAllStable, 1};
  if (w.state.unstable_particle != ParticleState::kAllStable)
    mine[0] = m.layout.global_of[static_cast<std::size_t>(w.state.unstable_particle)];
  if (check_broken) {
    const auto* broken = w.state.broken_bonds.data() + m.layout.owned_begin;
    if (std::any_of(broken, broken + m.layout.owned_count, [](std::uint32_t b) { return b != 0; })) mine[1] = 0;
  }
  encode_contact_ghost_motion(w.contact.enabled ? contact_ghost_motion(w, m.layout) : ContactGhostMotion{}, mine + 2);
  std::uint64_t all[kWords];
  check(MPI_Allreduce(mine, all, static_cast<int>(kWords), MPI_UINT64_T, MPI_MIN, MPI_COMM_WORLD), "allreduce");
  StepReport report{all[0], all[1] == 0, false};
  if (all[0] != ParticleState::kAllStable) return report;  // the run stops; positions may not be finite
  const std::uint64_t interval = w.settings.distributed.rebalance_interval;
  if (m.layout.ranks > 1 && interval > 0 && c.step % interval == 0 && m.check_balance()) {
    report.rebalance = true;  // World::step re-splits; contact ghosts come with the new local worlds
    return report;
  }
  // The same words on every rank, so the same decision.
  if (w.contact.enabled && contact_ghosts_stale(decode_contact_ghost_motion(all + 2), m.layout.contact_skin))
    m.refresh_contact_ghosts();
  return report;
}

const std::vector<Domain>& Runtime::rebalanced_domains() const { return impl_->rebalanced; }

RankStats Runtime::share() const {
  const Impl& m = *impl_;
  RankStats s = m.totals;
  s.owned_particles = m.layout.owned_count;
  s.bond_ghosts = m.layout.base_count - m.layout.owned_count;
  s.contact_ghosts = static_cast<std::uint32_t>(m.layout.global_of.size()) - m.layout.base_count;
  const auto& pairs = m.local->contact.pairs;
  s.contact.list_builds += pairs.builds;
  s.contact.list_additions += pairs.additions;
  s.contact.list_partial_updates += pairs.partial_updates;
  s.contact.list_searched += pairs.searched;
  return s;
}

std::vector<RankStats> Runtime::gather_shares() {
  static_assert(std::is_trivially_copyable_v<RankStats>, "RankStats travels as bytes");
  const RankStats mine = share();
  std::vector<RankStats> all(impl_->layout.rank == 0 ? static_cast<std::size_t>(impl_->layout.ranks) : 0);
  check(MPI_Gather(&mine, int(sizeof mine), MPI_BYTE, all.data(), int(sizeof mine), MPI_BYTE, 0, MPI_COMM_WORLD),
        "gather");
  if (all.empty()) all.push_back(mine);
  return all;
}
Scheduler& Runtime::scheduler() { return *impl_->scheduler; }

std::vector<double> Runtime::gather_values(const std::vector<double>& values) {
  const int count = int_count(values.size(), "gather");
  std::vector<double> all(impl_->layout.rank == 0 ? values.size() * static_cast<std::size_t>(impl_->layout.ranks) : 0);
  check(MPI_Gather(values.data(), count, MPI_DOUBLE, all.data(), count, MPI_DOUBLE, 0, MPI_COMM_WORLD), "gather");
  return all;
}

bool Runtime::broadcast(bool flag) {
  int value = flag ? 1 : 0;
  check(MPI_Bcast(&value, 1, MPI_INT, 0, MPI_COMM_WORLD), "broadcast");
  return value != 0;
}

void Runtime::gather(WorldState& full) {
  Impl& m = *impl_;
  const WorldState& w = *m.local;
  const auto& layout = m.layout;
  using Clock = std::chrono::steady_clock;
  auto seconds_since = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
  const auto replay_start = Clock::now();
  if (m.track_breaks) m.replay_mesh(full);  // before the bond states below overwrite the replayed ones
  m.totals.replay_seconds += seconds_since(replay_start);
  const auto gather_start = Clock::now();
  ++m.totals.state_gathers;
  full.clock = w.clock;
  full.projectiles.bodies = w.projectiles.bodies;  // the same on every rank
  // summary.json's contact list counters: this rank's (rank 0's, where they are written).
  const ContactPairs& pairs = w.contact.pairs;
  ContactPairs& full_pairs = full.contact.pairs;
  full_pairs.builds = pairs.builds;
  full_pairs.additions = pairs.additions;
  full_pairs.partial_updates = pairs.partial_updates;
  full_pairs.searched = pairs.searched;
  // The full world's own pair list is not stepped: a one-process resume of a checkpoint written from
  // it builds a new one (the same forces: contact sums each particle's pairs in index order).
  full_pairs.valid = false;
  // Particle arrays: the owned slice of every full-length array, into [first, last) of rank 0's.
  std::vector<void*> targets;
  for_each_array(full, [&](ArrayKind kind, const char*, auto& array) {
    if (kind == ArrayKind::particle) targets.push_back(&array);
  });
  // Which arrays travel is decided from the local world, the same on every rank (other ranks' full
  // worlds are emptied by World::distribute): the per-particle ones, not the empty ones or
  // bonds.offsets (constant, one longer).
  auto particles_of = [&](int r) {
    const Domain& d = layout.domains[static_cast<std::size_t>(r)];
    return std::pair<std::size_t, std::size_t>(d.first, d.last);
  };
  std::size_t k = 0;
  const std::size_t n_local = w.particles.count();
  for_each_array(w, [&](ArrayKind kind, const char*, const auto& array) {
    if (kind != ArrayKind::particle) return;
    auto& target = *static_cast<std::remove_cvref_t<decltype(array)>*>(targets[k++]);
    if (array.size() != n_local) return;
    gather_slices(array.data() + layout.owned_begin, layout.owned_count, target.data(), layout.rank, layout.ranks,
                  kTagGather, particles_of);
  });
  // Bond state: a rank's bonds are the global range of its owned rows.
  auto bonds_of = [&](int r) {
    const auto [first, last] = particles_of(r);
    return std::pair<std::size_t, std::size_t>(full.bonds.offsets[first], full.bonds.offsets[last]);
  };
  auto gather_bonds = [&](const auto& mine, auto& target) {
    if (!mine.empty())
      gather_slices(mine.data(), mine.size(), target.data(), layout.rank, layout.ranks, kTagGather, bonds_of);
  };
  // The held rotations of the embedded mesh (per particle, stepped by the local worlds).
  const EmbeddedMesh& e = w.embedded;
  EmbeddedMesh& fe = full.embedded;
  auto gather_held = [&](const auto& mine, auto& target) {
    if (!mine.empty())
      gather_slices(mine.data() + layout.owned_begin, layout.owned_count, target.data(), layout.rank, layout.ranks,
                    kTagGather, particles_of);
  };
  gather_held(e.held_deformation, fe.held_deformation);
  gather_held(e.held_tracked, fe.held_tracked);
  gather_held(e.held_fits, fe.held_fits);
  gather_held(e.held_broken_seen, fe.held_broken_seen);
  gather_bonds(w.bonds.alive, full.bonds.alive);
  gather_bonds(w.bonds.plastic_extension, full.bonds.plastic_extension);
  gather_bonds(w.bonds.plastic_extension_mirror, full.bonds.plastic_extension_mirror);
  m.totals.gather_seconds += seconds_since(gather_start);
  // The pieces, found by every rank from its own bonds; rank 0 gives the stable ids from these roots.
  const auto piece_start = Clock::now();
  m.find_pieces();
  m.totals.piece_seconds += seconds_since(piece_start);
  if (layout.rank == 0) full.derived.fragment_root.resize(full.particles.count());
  gather_slices(m.owned_roots.data(), m.owned_roots.size(), full.derived.fragment_root.data(), layout.rank,
                layout.ranks, kTagGather, particles_of);
  full.derived.fragment_root_step = w.clock.step;
}

}  // namespace perifx::distributed
