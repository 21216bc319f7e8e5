// Entry point of perifx_bench (the target links benchmark::benchmark, not benchmark_main).
#include <benchmark/benchmark.h>

BENCHMARK_MAIN();
