// engine/scheduler.cpp: the step graph from declared reads and writes, and its profiling chain.
#include <doctest/doctest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <string>
#include <vector>

#include "scheduler.hpp"

using namespace perifx;

namespace {

// Four systems: "a" and "b" touch disjoint data (the graph may run them side by side), "c" reads what
// both write, "d" is independent of all. Each records when it starts and ends; "a" and "b" each wait
// (at most 50 ms) for another system to be running, so two nodes that may overlap do.
struct Recorder {
  std::atomic<int> running{0};
  std::atomic<int> most_running{0};
  std::mutex mutex;
  std::vector<std::string> events;  // "+name" at start, "-name" at end, in the order they happened

  SystemDecl system(std::string name, std::vector<Component> reads, std::vector<Component> writes, bool wait) {
    return {name, std::move(reads), std::move(writes), [this, name, wait] {
              note("+" + name);
              const int now = ++running;
              for (int seen = most_running.load(); now > seen && !most_running.compare_exchange_weak(seen, now);) {
              }
              const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(50);
              while (wait && running.load() < 2 && std::chrono::steady_clock::now() < until) {
              }
              if (running.load() > most_running.load()) most_running = running.load();
              --running;
              note("-" + name);
            }};
  }
  void note(std::string e) {
    std::lock_guard<std::mutex> lock(mutex);
    events.push_back(std::move(e));
  }
  std::size_t at(const std::string& e) const {
    for (std::size_t k = 0; k < events.size(); ++k)
      if (events[k] == e) return k;
    return events.size();
  }
};

void add_systems(Scheduler& s, Recorder& r) {
  s.add(r.system("a", {Component::position}, {Component::velocity}, true));
  s.add(r.system("b", {Component::position}, {Component::dilatation}, true));
  s.add(r.system("c", {Component::velocity, Component::dilatation}, {Component::flags}, false));
  s.add(r.system("d", {Component::time}, {Component::damage}, false));
}

}  // namespace

TEST_CASE("scheduler: the graph orders every declared dependency; profiling runs one system at a time in listed order") {
  Scheduler scheduler(2);
  Recorder r;
  add_systems(scheduler, r);
  scheduler.build();
  REQUIRE(scheduler.dependencies().size() == 4);
  CHECK(scheduler.dependencies()[0].empty());
  CHECK(scheduler.dependencies()[1].empty());
  CHECK(scheduler.dependencies()[2] == std::vector<int>{0, 1});
  CHECK(scheduler.dependencies()[3].empty());

  // Unprofiled: c starts only after a and b ended (whatever else overlaps).
  scheduler.run_step();
  CHECK(r.events.size() == 8);
  CHECK(r.at("+c") > r.at("-a"));
  CHECK(r.at("+c") > r.at("-b"));
  MESSAGE("systems running at once without profiling: " << r.most_running.load());

  // Profiled: a chain a, b, c, d; never two at once (a and b wait 50 ms for a partner that must not
  // come), each timed once per step.
  scheduler.set_profiling(true);
  for (int step = 0; step < 3; ++step) {
    r.events.clear();
    r.most_running = 0;
    scheduler.run_step();
    CHECK(r.most_running.load() == 1);
    CHECK(r.events == std::vector<std::string>{"+a", "-a", "+b", "-b", "+c", "-c", "+d", "-d"});
  }
  const auto times = scheduler.profile();
  REQUIRE(times.size() == 4);
  for (const auto& t : times) CHECK(t.runs == 3);
  CHECK(times[0].seconds >= 3 * 0.05);  // a waited its full 50 ms each step: b never ran beside it

  // Profiling off again: the dependency graph, with the times kept.
  scheduler.set_profiling(false);
  r.events.clear();
  scheduler.run_step();
  CHECK(r.at("+c") > r.at("-a"));
  CHECK(r.at("+c") > r.at("-b"));
  CHECK(scheduler.profile()[0].runs == 3);
}
