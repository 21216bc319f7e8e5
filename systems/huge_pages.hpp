// Transparent huge pages for the large arrays (Linux). The bond passes gather y_j, x_j and the far
// end's constants for every bond; with 4 KiB pages a 3e5-particle body's arrays span far more pages
// than the TLB holds, and the page walks cost as much as the arithmetic (measured: the elastic step
// at 3e5 particles on 1 thread took 409 ms with 4 KiB pages, 282 ms with 2 MiB ones). Debian's
// kernels give huge pages only to memory that asks for them (transparent_hugepage "madvise" mode),
// so the arrays ask with madvise(MADV_HUGEPAGE) before their first touch. Values never change; a
// kernel without THP ignores the advice. Setup is faster too: one fault per 2 MiB instead of 512.
// The pages are also faulted in by all threads at once (MADV_POPULATE_WRITE on 2 MiB slices) before
// the single-threaded fill: clearing fresh pages is the kernel's work and was most of the cost of
// allocating the bond arrays (9e5 particles, 1.4e8 bonds: 3 s of one thread for neighbour + alive).
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "parallel.hpp"

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace perifx::systems {

// Arrays below this size gain nothing measurable (and small allocations are not page-aligned).
inline constexpr std::size_t kHugePageMinBytes = std::size_t{8} << 20;

// The whole 4 KiB pages inside [data, data + bytes), as [begin, end) addresses (empty: end <= begin).
struct PageRange {
  std::uintptr_t begin, end;
};
inline PageRange whole_pages(const void* data, std::size_t bytes) {
  constexpr std::uintptr_t kPage = 4096;
  return {(reinterpret_cast<std::uintptr_t>(data) + kPage - 1) & ~(kPage - 1),
          (reinterpret_cast<std::uintptr_t>(data) + bytes) & ~(kPage - 1)};
}

// Advises the whole pages inside [data, data + bytes) to be backed by huge pages.
inline void advise_huge_pages(const void* data, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  const auto [begin, end] = whole_pages(data, bytes);
  if (end > begin) ::madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#else
  (void)data, (void)bytes;
#endif
}

// Asks the kernel to fault in (and clear) the whole pages of [data, data + bytes) now, in parallel
// slices. Only the page tables change; a kernel without MADV_POPULATE_WRITE (before 5.14) refuses and
// the pages fault in on first touch as before.
inline void populate_pages(const void* data, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_POPULATE_WRITE)
  constexpr std::uintptr_t kSlice = std::uintptr_t{2} << 20;
  const auto [begin, end] = whole_pages(data, bytes);
  if (end <= begin) return;
  const auto first_slice = begin & ~(kSlice - 1);
  const std::size_t slices = (end - first_slice + kSlice - 1) / kSlice;
  parallel_for_each(slices, [&](std::size_t s) {
    const auto lo = std::max(begin, first_slice + s * kSlice), hi = std::min(end, first_slice + (s + 1) * kSlice);
    if (hi > lo) ::madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_POPULATE_WRITE);
  }, 1);
#else
  (void)data, (void)bytes;
#endif
}

// v = n copies of value, in memory advised for huge pages before it is first written (large n).
template <class T>
void assign_huge_pages(std::vector<T>& v, std::size_t n, const T& value) {
  if (n * sizeof(T) < kHugePageMinBytes) {
    v.assign(n, value);
    return;
  }
  std::vector<T> fresh;
  fresh.reserve(n);
  advise_huge_pages(fresh.data(), n * sizeof(T));
  populate_pages(fresh.data(), n * sizeof(T));
  fresh.resize(n, value);
  v.swap(fresh);
}

// Moves a large array's contents into memory advised for huge pages (same size and capacity).
template <class T>
void move_to_huge_pages(std::vector<T>& v) {
  if (v.capacity() * sizeof(T) < kHugePageMinBytes) return;
  std::vector<T> fresh;
  fresh.reserve(v.capacity());
  advise_huge_pages(fresh.data(), v.capacity() * sizeof(T));
  populate_pages(fresh.data(), v.capacity() * sizeof(T));
  fresh.insert(fresh.end(), v.begin(), v.end());
  v.swap(fresh);
}

}  // namespace perifx::systems
