// The distributed runtime in a build without PERIFX_MPI: MPI is never started, and asking for a
// distributed run says how to get one (runtime.hpp has the contract).
#include <cstdlib>
#include <stdexcept>

#include "distributed/runtime.hpp"

namespace perifx::distributed {
namespace {
[[noreturn]] void not_built() {
  throw std::runtime_error("this perifx was built without MPI: configure with -DPERIFX_MPI=ON (Debian: "
                           "libopenmpi-dev openmpi-bin) to run under mpirun");
}
}  // namespace

MpiSession::MpiSession(int&, char**&) {}
MpiSession::~MpiSession() = default;
void MpiSession::abort(int exit_code) const { std::exit(exit_code); }

struct Runtime::Impl {};
Runtime::Runtime(const WorldState&, int, const std::vector<Domain>*, const RankStats*) { not_built(); }
void broadcast_bytes(void*, std::size_t, Wait) { not_built(); }
setup::RankPlacement rank_placement() { return {}; }
int job_rank() { return 0; }
Runtime::~Runtime() = default;
int Runtime::rank() const { return 0; }
int Runtime::ranks() const { return 1; }
StepReport Runtime::step(bool) { not_built(); }
void Runtime::gather(WorldState&) { not_built(); }
bool Runtime::broadcast(bool) { not_built(); }
RankStats Runtime::share() const { not_built(); }
std::vector<RankStats> Runtime::gather_shares() { not_built(); }
const std::vector<Domain>& Runtime::rebalanced_domains() const { not_built(); }
Scheduler& Runtime::scheduler() { not_built(); }
std::vector<double> Runtime::gather_values(const std::vector<double>&) { not_built(); }
}  // namespace perifx::distributed
