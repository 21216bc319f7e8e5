// The distributed runtime (issue 17): a world split over the ranks of an MPI job, each rank stepping
// its local world (local_world.hpp) and exchanging halos with its neighbours. Built with PERIFX_MPI
// (engine/distributed/mpi/runtime_mpi.cpp, Open MPI); without it (nompi/runtime_none.cpp) MpiSession
// never starts MPI and make_runtime throws.
//
// Bit-identical to one process: owned particles compute from the same values in the same order
// (local_world.hpp), the halo copies values bit for bit, the per-step reduction (health, first break,
// contact ghosts stale) is three minima, whose result does not depend on the order, and the projectiles'
// contacts are concatenated in rank order, which is particle order.
//
// Output: gather() copies every rank's owned particle and bond data into rank 0's full world, in
// particle order, so rank 0 writes the same files as one process. The embedded mesh lives there too:
// every rank records at which step each of its bonds broke, and gather() first replays, on rank 0, the
// crack faces and vertex splits of every step since the last gather (systems/crack_faces.cpp and
// mesh_split.cpp read only the bond states and the mesh), then gathers the held rotations the local
// worlds stepped. The surfaces are then those of one process, bit for bit. The pieces are found by all
// ranks together, each from its own bonds (pieces.hpp), and rank 0 receives every particle's piece root
// (derived.fragment_root) and gives the stable ids from it (systems/fragments.cpp).
#pragma once
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <memory>

#include "components/world_state.hpp"
#include "distributed/decomposition.hpp"
#include "perifx/world.hpp"
#include "scheduler.hpp"
#include "setup/preflight.hpp"

namespace perifx::distributed {

// MPI for the life of a program: started only when the process was launched by mpirun/mpiexec
// (launched_by_mpirun below) and perifx was built
// with PERIFX_MPI; otherwise a single process (rank 0 of 1).
class MpiSession {
 public:
  MpiSession(int& argc, char**& argv);
  ~MpiSession();  // MPI_Finalize when started
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
  bool active() const { return active_; }
  int rank() const { return rank_; }
  int ranks() const { return ranks_; }
  [[noreturn]] void abort(int exit_code) const;  // MPI_Abort (stops every rank)

 private:
  bool active_ = false;
  int rank_ = 0, ranks_ = 1;
};

// The rank count mpirun/mpiexec put in the environment (Open MPI's OMPI_COMM_WORLD_SIZE, or
// PMI_SIZE), or null when no launcher started this process.
inline const char* launcher_size() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"})
    if (const char* v = std::getenv(name)) return v;
  return nullptr;
}
inline bool launched_by_mpirun() { return launcher_size() != nullptr; }
// The rank count this process was launched among, 1 without a launcher.
inline int launcher_ranks() {
  const char* v = launcher_size();
  return v ? std::max(1, std::atoi(v)) : 1;
}

// How a rank waits in a collective: in MPI (spinning, the fastest answer), or asleep, polling every
// millisecond, for a wait as long as rank 0's set-up, which leaves the waiting ranks' cores to rank 0
// (setup::setup_threads).
enum class Wait { spin, asleep };
// Rank 0's `bytes` bytes at `data`, on every rank. Collective; throws std::runtime_error without MPI.
void broadcast_bytes(void* data, std::size_t bytes, Wait wait = Wait::spin);
// The job's ranks, those sharing this rank's machine (MPI_COMM_TYPE_SHARED) and whether rank 0 is one
// of them: the memory preflight's placement (setup/preflight.hpp). Collective; {1, 1, true} without MPI
// or outside mpirun.
setup::RankPlacement rank_placement();
// This process's rank in the MPI job (MPI_COMM_WORLD), 0 without MPI or outside mpirun.
int job_rank();

struct StepReport {
  std::uint64_t unstable_particle = ParticleState::kAllStable;  // lowest global index over all ranks
  bool any_broken = false;  // some owned particle on some rank has a broken bond (when asked)
  bool rebalance = false;   // the work per rank drifted: re-split with Runtime::rebalanced_domains()
};

class Runtime {
 public:
  // Splits `full` over the ranks of MPI_COMM_WORLD (by `domains`, the same on every rank, or by rank
  // 0's split_by_work) and builds this rank's local world and its step graph on `threads` threads.
  // Only rank 0's `full` needs its arrays (the whole world as built, loaded or gathered): rank 0 makes
  // every rank's local world and sends each its own (local_world.hpp, write_local_world); the other
  // ranks take the rest from their `full`'s non-array parts (a shell, setup/world_setup.hpp, or a
  // world whose arrays were released), which must equal rank 0's. Collective. Throws
  // std::invalid_argument for a world the runtime cannot split (an embedded mesh whose vertex motion
  // is a test option) and std::runtime_error without MPI. `before`: the share() of the runtime this
  // one replaces at a re-split, whose running totals (traffic, steps, refreshes, contact list
  // counters, gathers and their times) this one continues.
  Runtime(const WorldState& full, int threads, const std::vector<Domain>* domains = nullptr,
          const RankStats* before = nullptr);
  ~Runtime();
  Runtime(const Runtime&) = delete;
  Runtime& operator=(const Runtime&) = delete;

  int rank() const;
  int ranks() const;
  // One step of the local world with its halos, then the clock. Collective. Every
  // settings.distributed.rebalance_interval steps it measures each rank's work (current_work: alive
  // bonds, contact candidates, kParticleWork and held rotations per owned particle); when the busiest
  // exceeds the mean by more than rebalance_drift and the equal-work split of the current work differs
  // from the current one, the report asks for a re-split (World::step makes it: gather, then a new
  // Runtime whose local worlds rank 0 makes and sends).
  StepReport step(bool check_broken);
  const std::vector<Domain>& rebalanced_domains() const;
  // This rank's step graph (its local world's systems and the halo exchanges): `perifx run --profile`.
  Scheduler& scheduler();
  // Every rank's `values` (the same count on each), rank after rank, on rank 0; empty elsewhere.
  // Collective.
  std::vector<double> gather_values(const std::vector<double>& values);
  // Every rank's share(), by rank, on rank 0; its own elsewhere. Collective.
  std::vector<RankStats> gather_shares();
  // Rank 0's `full` receives every rank's owned particle and bond state (other ranks pass theirs,
  // which is left as it is). Collective.
  void gather(WorldState& full);
  // Rank 0's value of `flag` on every rank. Collective.
  bool broadcast(bool flag);
  // This rank's share: its particles and ghosts now, and its traffic and counters since the run was
  // first split (through every re-split: `before` above). Not collective.
  RankStats share() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace perifx::distributed
