// Builds a oneTBB flow graph from the components each system declares it reads and writes, the way
// EnTT's `flow` and flecs' pipeline derive their schedules. Systems are added in their logical
// (sequential) order; a system depends on
//   - the last writer of every component it reads or writes (read-after-write, write-after-write),
//   - every reader of a component it writes since that component's last writer (write-after-read).
// Systems that touch disjoint data therefore run concurrently; each node is coarse and runs a
// parallel_for inside. The graph is built once and reused every step.
#pragma once
#include <oneapi/tbb/flow_graph.h>
#include <oneapi/tbb/task_arena.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "systems/system.hpp"

namespace perifx {

class Scheduler {
 public:
  explicit Scheduler(int threads);  // threads ≤ 0: all hardware threads
  ~Scheduler();
  Scheduler(const Scheduler&) = delete;
  Scheduler& operator=(const Scheduler&) = delete;

  void add(SystemDecl system);  // before build()
  void build();
  void run_step();              // one pass over the graph; blocks until every node finished
  template <class F>
  void execute(F&& f) { arena_.execute(std::forward<F>(f)); }  // run setup work in the same arena

  int threads() const { return arena_.max_concurrency(); }
  const std::vector<SystemDecl>& systems() const { return systems_; }
  // Dependency list per system (indices into systems()), as built.
  const std::vector<std::vector<int>>& dependencies() const { return dependencies_; }
  std::string describe() const;  // one line per system: name, reads, writes, depends on

  // Per-system wall time (`perifx run --profile`). When on, the graph runs the systems one at a time
  // in their listed order (make_graph), and each node reads the steady clock before and after its
  // system and adds the difference to that system's slot. A node runs once per step and only it
  // writes its slot; wait_for_all orders one step's writes before the next step's and before profile()
  // reads them, so no atomics are needed. Off by default (two clock reads per system per step when on).
  // Between steps only (it may rebuild the graph).
  void set_profiling(bool on);
  bool profiling() const { return profiling_; }
  struct SystemTime {
    std::string name;
    double seconds = 0.0;    // summed wall time of the system's node over all profiled steps
    std::uint64_t runs = 0;  // how often it ran while profiling was on
  };
  std::vector<SystemTime> profile() const;  // in systems() order

 private:
  tbb::task_arena arena_;
  std::vector<SystemDecl> systems_;
  std::vector<std::vector<int>> dependencies_;
  std::unique_ptr<tbb::flow::graph> graph_;
  std::unique_ptr<tbb::flow::broadcast_node<tbb::flow::continue_msg>> start_;
  std::vector<std::unique_ptr<tbb::flow::continue_node<tbb::flow::continue_msg>>> nodes_;
  void make_graph();
  bool profiling_ = false;
  bool graph_chained_ = false;          // the graph is the profiling chain (make_graph)
  std::vector<double> seconds_;         // per system, see set_profiling
  std::vector<std::uint64_t> runs_;
};

}  // namespace perifx
