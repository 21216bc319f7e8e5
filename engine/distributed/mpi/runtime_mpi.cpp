// The distributed runtime on Open MPI (runtime.hpp has the contract). Compiled with PERIFX_MPI only.
// MPI is started with MPI_THREAD_SERIALIZED: the halo exchanges run inside the step's oneTBB graph on
// whichever worker runs their node, but the graph orders them (each depends on the one before), and
// the gathers and reductions run between steps on the calling thread, so no two MPI calls overlap.
#include <mpi.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>

#include "distributed/local_world.hpp"
#include "distributed/runtime.hpp"
#include "scheduler.hpp"
#include "systems/bond_rules.hpp"
#include "systems/pipeline.hpp"

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

enum Tag : int { kTagMotion = 11, kTagDilatation = 12, kTagThreshold = 13, kTagGather = 20 };

}  // namespace

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
  // Per stage and link: packed values, sized once (no allocation in a step).
  std::vector<std::vector<double>> send_buffer, receive_buffer;
  std::vector<MPI_Request> requests;

  // One halo stage: `width` doubles per particle, packed by `pack`, unpacked by `unpack`.
  template <class Pack, class Unpack>
  void exchange(int width, int tag, Pack&& pack, Unpack&& unpack) {
    const auto w = static_cast<std::size_t>(width);
    std::size_t r = 0;
    for (std::size_t q = 0; q < layout.receives.size(); ++q, ++r) {
      const auto& link = layout.receives[q];
      check(MPI_Irecv(receive_buffer[q].data(), static_cast<int>(link.local.size() * w), MPI_DOUBLE, link.rank, tag,
                      MPI_COMM_WORLD, &requests[r]),
            "receive");
    }
    for (std::size_t q = 0; q < layout.sends.size(); ++q, ++r) {
      const auto& link = layout.sends[q];
      double* out = send_buffer[q].data();
      for (std::size_t m = 0; m < link.local.size(); ++m) pack(link.local[m], out + m * w);
      check(MPI_Isend(out, static_cast<int>(link.local.size() * w), MPI_DOUBLE, link.rank, tag, MPI_COMM_WORLD,
                      &requests[r]),
            "send");
    }
    check(MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE), "wait");
    for (std::size_t q = 0; q < layout.receives.size(); ++q) {
      const auto& link = layout.receives[q];
      const double* in = receive_buffer[q].data();
      for (std::size_t m = 0; m < link.local.size(); ++m) unpack(link.local[m], in + m * w);
    }
  }
};

Runtime::Runtime(const WorldState& full, int threads) : impl_(std::make_unique<Impl>()) {
  int started = 0, rank = 0, ranks = 1;
  MPI_Initialized(&started);
  if (!started) throw std::runtime_error("the distributed runtime needs MPI started (run under mpirun)");
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  if (full.settings.solver != scene::Solver::peridynamics)
    throw std::invalid_argument("/solver: the FEM solvers are not distributed (expected \"peridynamics\"): run "
                                "this scene in one process");
  Impl& m = *impl_;
  m.layout = make_layout(full, split_by_work(full, ranks), rank);
  m.local = make_local_world(full, m.layout);
  // The widest stage carries 6 doubles per particle (motion).
  for (const auto& link : m.layout.sends) m.send_buffer.emplace_back(6 * link.local.size());
  for (const auto& link : m.layout.receives) m.receive_buffer.emplace_back(6 * link.local.size());
  m.requests.resize(m.layout.sends.size() + m.layout.receives.size());

  WorldState& w = *m.local;
  m.halo.motion = [&m, &w] {
    auto& y = w.particles.position;
    auto& v = w.particles.velocity;
    m.exchange(
        6, kTagMotion,
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
        1, kTagDilatation, [&](std::uint32_t i, double* out) { out[0] = theta[i]; },
        [&](std::uint32_t i, const double* in) {
          theta[i] = in[0];
          coupling[i] = systems::dilatation_coupling(w.model, i, in[0]);
        });
  };
  m.halo.threshold = [&m, &w] {
    auto& limit = w.state.break_extension;
    m.exchange(
        1, kTagThreshold, [&](std::uint32_t i, double* out) { out[0] = limit[i]; },
        [&](std::uint32_t i, const double* in) { limit[i] = in[0]; });
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
  auto& c = w.clock;
  ++c.step;
  c.time = static_cast<double>(c.step) * c.dt;
  // [0] lowest unstable global index, [1] 0 when some owned particle has a broken bond: both minima.
  std::uint64_t mine[2] = {ParticleState::kAllStable, 1};
  if (w.state.unstable_particle != ParticleState::kAllStable)
    mine[0] = m.layout.global_of[static_cast<std::size_t>(w.state.unstable_particle)];
  if (check_broken) {
    const auto* broken = w.state.broken_bonds.data() + m.layout.owned_begin;
    if (std::any_of(broken, broken + m.layout.owned_count, [](std::uint32_t b) { return b != 0; })) mine[1] = 0;
  }
  std::uint64_t all[2];
  check(MPI_Allreduce(mine, all, 2, MPI_UINT64_T, MPI_MIN, MPI_COMM_WORLD), "allreduce");
  return {all[0], all[1] == 0};
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
  full.clock = w.clock;
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
  gather_bonds(w.bonds.alive, full.bonds.alive);
  gather_bonds(w.bonds.plastic_extension, full.bonds.plastic_extension);
  gather_bonds(w.bonds.plastic_extension_mirror, full.bonds.plastic_extension_mirror);
}

}  // namespace perifx::distributed
