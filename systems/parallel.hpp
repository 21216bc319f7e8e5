// Parallel loop helpers shared by systems. Every helper partitions work so that each output element
// is written by exactly one task and sums run in a fixed order: results never depend on the number
// of threads or on scheduling.
#pragma once
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <cstddef>
#include <vector>

namespace perifx {

// Calls body(i) for i in [0, n). Grain keeps tasks coarse enough to amortize scheduling.
template <class Body>
void parallel_for_each(std::size_t n, Body&& body, std::size_t grain = 512) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) body(i);
                    });
}

// Deterministic sum of term(i) over [0, n): fixed blocks of `block` items are summed in order in
// parallel, then the block sums are added in order. Same bits for any thread count.
template <class T, class Term>
T deterministic_sum(std::size_t n, T zero, Term&& term, std::size_t block = 4096) {
  const std::size_t blocks = (n + block - 1) / block;
  std::vector<T> partial(blocks, zero);
  tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
    T acc = zero;
    const std::size_t end = std::min(n, (b + 1) * block);
    for (std::size_t i = b * block; i < end; ++i) acc += term(i);
    partial[b] = acc;
  });
  T total = zero;
  for (const T& p : partial) total += p;
  return total;
}

}  // namespace perifx
