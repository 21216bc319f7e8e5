// Entry point of perifx_bench (the target links benchmark::benchmark, not benchmark_main). Like the
// perifx command line it first restarts itself with glibc's malloc asking for huge pages
// (setup/preflight.hpp), so BM_Setup measures the set-up a `perifx run` gets.
#include <benchmark/benchmark.h>

#include "setup/preflight.hpp"

int main(int argc, char** argv) {
  perifx::setup::restart_with_huge_page_malloc(argv);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
