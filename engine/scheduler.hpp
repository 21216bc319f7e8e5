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

 private:
  tbb::task_arena arena_;
  std::vector<SystemDecl> systems_;
  std::vector<std::vector<int>> dependencies_;
  std::unique_ptr<tbb::flow::graph> graph_;
  std::unique_ptr<tbb::flow::broadcast_node<tbb::flow::continue_msg>> start_;
  std::vector<std::unique_ptr<tbb::flow::continue_node<tbb::flow::continue_msg>>> nodes_;
};

}  // namespace perifx
