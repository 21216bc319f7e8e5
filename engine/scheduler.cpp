#include "scheduler.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <sstream>
#include <stdexcept>

namespace perifx {

Scheduler::Scheduler(int threads)
    : arena_(threads > 0 ? threads : tbb::task_arena::automatic) {}

Scheduler::~Scheduler() {
  // Nodes must be destroyed before the graph they belong to.
  nodes_.clear();
  start_.reset();
  graph_.reset();
}

void Scheduler::add(SystemDecl system) {
  if (graph_) throw std::logic_error("Scheduler::add after build");
  systems_.push_back(std::move(system));
}

void Scheduler::build() {
  constexpr auto kCount = static_cast<std::size_t>(Component::count_);
  std::array<int, kCount> last_writer;
  last_writer.fill(-1);
  std::array<std::vector<int>, kCount> readers_since_write;

  dependencies_.assign(systems_.size(), {});
  for (std::size_t s = 0; s < systems_.size(); ++s) {
    auto& deps = dependencies_[s];
    const auto& sys = systems_[s];
    for (Component c : sys.reads) {
      const int w = last_writer[static_cast<std::size_t>(c)];
      if (w >= 0) deps.push_back(w);
    }
    for (Component c : sys.writes) {
      const auto ci = static_cast<std::size_t>(c);
      if (last_writer[ci] >= 0) deps.push_back(last_writer[ci]);
      for (int r : readers_since_write[ci])
        if (r != static_cast<int>(s)) deps.push_back(r);
    }
    std::sort(deps.begin(), deps.end());
    deps.erase(std::unique(deps.begin(), deps.end()), deps.end());
    for (Component c : sys.reads) readers_since_write[static_cast<std::size_t>(c)].push_back(static_cast<int>(s));
    for (Component c : sys.writes) {
      last_writer[static_cast<std::size_t>(c)] = static_cast<int>(s);
      readers_since_write[static_cast<std::size_t>(c)].clear();
    }
  }

  make_graph();
}

// The flow graph for dependencies_, or, while profiling, the chain of the systems in their listed
// order (a valid order for every dependency: systems are added in their sequential order). A chain
// runs one node at a time with every thread, so a node's wall time is its own; side by side, a node's
// time would include the threads it shared with another (contact beside dilatation on two threads
// took as long as on one). Either graph gives the same results: systems write disjoint data and sum
// in fixed orders.
void Scheduler::make_graph() {
  arena_.execute([&] {
    // Nodes must be destroyed before the graph they belong to.
    nodes_.clear();
    start_.reset();
    // The graph attaches to the arena it is created in, so its tasks use this world's threads only.
    graph_ = std::make_unique<tbb::flow::graph>();
    start_ = std::make_unique<tbb::flow::broadcast_node<tbb::flow::continue_msg>>(*graph_);
    if (seconds_.size() != systems_.size()) {
      seconds_.assign(systems_.size(), 0.0);
      runs_.assign(systems_.size(), 0);
    }
    for (std::size_t s = 0; s < systems_.size(); ++s) {
      auto* run = &systems_[s].run;
      nodes_.push_back(std::make_unique<tbb::flow::continue_node<tbb::flow::continue_msg>>(
          *graph_, [this, run, s](const tbb::flow::continue_msg&) {
            if (!profiling_) {
              (*run)();
              return;
            }
            const auto begin = std::chrono::steady_clock::now();
            (*run)();
            seconds_[s] += std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
            ++runs_[s];
          }));
    }
    graph_chained_ = profiling_;
    for (std::size_t s = 0; s < systems_.size(); ++s) {
      if (graph_chained_) {
        tbb::flow::make_edge(s == 0 ? static_cast<tbb::flow::sender<tbb::flow::continue_msg>&>(*start_) : *nodes_[s - 1], *nodes_[s]);
        continue;
      }
      if (dependencies_[s].empty()) tbb::flow::make_edge(*start_, *nodes_[s]);
      for (int d : dependencies_[s]) tbb::flow::make_edge(*nodes_[static_cast<std::size_t>(d)], *nodes_[s]);
    }
  });
}

void Scheduler::set_profiling(bool on) {
  profiling_ = on;
  if (graph_ && graph_chained_ != on) make_graph();
}

void Scheduler::run_step() {
  arena_.execute([&] {
    start_->try_put(tbb::flow::continue_msg());
    graph_->wait_for_all();
  });
}

std::vector<Scheduler::SystemTime> Scheduler::profile() const {
  std::vector<SystemTime> out;
  for (std::size_t s = 0; s < systems_.size(); ++s)
    out.push_back({systems_[s].name, s < seconds_.size() ? seconds_[s] : 0.0, s < runs_.size() ? runs_[s] : 0});
  return out;
}

std::string Scheduler::describe() const {
  std::ostringstream out;
  auto list = [&](const std::vector<Component>& cs) {
    std::string s;
    for (Component c : cs) s += std::string(s.empty() ? "" : ",") + component_name(c);
    return s.empty() ? std::string("-") : s;
  };
  for (std::size_t s = 0; s < systems_.size(); ++s) {
    out << s << " " << systems_[s].name << "  reads " << list(systems_[s].reads) << "  writes "
        << list(systems_[s].writes) << "  after";
    if (s < dependencies_.size() && !dependencies_[s].empty()) {
      for (int d : dependencies_[s]) out << " " << systems_[static_cast<std::size_t>(d)].name;
    } else {
      out << " (start)";
    }
    out << "\n";
  }
  return out.str();
}

}  // namespace perifx
