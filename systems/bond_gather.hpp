// Neighbour data of one chunk of bonds, moved into lane order before the chunk's SIMD arithmetic.
//
// Why: a bond kernel's lane l reads particle j = neighbor[k + l]'s position, reference position and
// per-particle constants. Written as plain indexed loads, GCC 12 emulates each gathered double with a
// scalar load and an insert (hardware gathers are slower still: with them the dilatation pass took
// 1.9× as long on the development machine), and on the 3e5 bench body those moves were about two
// thirds of the dilatation pass's instructions. Here each neighbour's three position components come in
// with one 256-bit load (masked to three doubles, so the last particle reads nothing past its array),
// its reference point (x y z V, ParticleModel::reference_point) and each half of its BondEnd line with
// one aligned load; a transpose in registers turns the rows into one vector per component (with
// AVX-512 eight neighbours' rows at once in 512-bit vectors, else four at a time). The values are the
// same doubles either way, so the kernels' results are unchanged to the bit; the scalar path (a CPU without AVX, and the tail of a
// family) fills the same arrays one by one. Eight lanes are stored at a time, as one 512-bit vector
// with AVX-512: the lane loop then reads each array as 512-bit vectors (kBondLanes is 16 there), and
// a load that spans two narrower stores cannot be forwarded from them; it waits until they reach the
// cache (with 256-bit stores the 16-lane dilatation pass took 1.3× as long, 135 against 100 ms).
//
// The kernels call these from for_each_gathered_bond_lane (bond_rules.hpp).
// Shapes: a chunk is kBondLanes bonds; every array below has one entry per lane. `y` is 3 doubles per
// particle (x y z), `reference` one ReferencePoint (x y z V, 32-byte aligned) and `ends` one BondEnd
// (64-byte aligned) per particle.
#pragma once
#include <cstddef>
#include <cstdint>

#if defined(__AVX__)
#include <immintrin.h>
#define PERIFX_BOND_GATHER_AVX 1
#endif

#include "bond_rules.hpp"
#include "components/particles.hpp"

namespace perifx::systems {

static_assert(kBondLanes % 8 == 0, "chunks are gathered four neighbours at a time and stored eight lanes at a time");

// y_j − y_i and ξ = x_j − x_i need both positions of the far end; V_j comes with x_j
// (ParticleModel::reference_point).
struct ChunkPositions {
  alignas(64) double yx[kBondLanes], yy[kBondLanes], yz[kBondLanes];
  alignas(64) double xx[kBondLanes], xy[kBondLanes], xz[kBondLanes];
  alignas(64) double v[kBondLanes];
};
// The far end's BondEnd, one array per field (field order as in BondEnd).
struct ChunkEnds {
  alignas(64) double coupling[kBondLanes], b4[kBondLanes], volume[kBondLanes], horizon[kBondLanes];
  alignas(64) double beta_theta[kBondLanes], yield_extension[kBondLanes], plastic_cap[kBondLanes],
      break_extension[kBondLanes];
};
// Lane l's far-end SideConstants, as side_constants(const BondEnd&) gives them from the line itself.
// Without kInelastic the inelastic half was not gathered (gather_ends<false>); its fields are 0 then.
template <bool kInelastic>
inline SideConstants side_constants(const ChunkEnds& c, int l) {
  if constexpr (kInelastic)
    return {c.beta_theta[l], c.yield_extension[l], c.plastic_cap[l], c.horizon[l], c.break_extension[l]};
  else
    return {0.0, 0.0, 0.0, c.horizon[l], 0.0};
}

#ifdef PERIFX_BOND_GATHER_AVX
namespace detail {
// Rows r0..r3 (4 doubles each, the 4th possibly unused) to columns c0..c3.
inline void transpose4(__m256d r0, __m256d r1, __m256d r2, __m256d r3, __m256d& c0, __m256d& c1, __m256d& c2,
                       __m256d& c3) {
  const __m256d t0 = _mm256_unpacklo_pd(r0, r1), t1 = _mm256_unpackhi_pd(r0, r1);
  const __m256d t2 = _mm256_unpacklo_pd(r2, r3), t3 = _mm256_unpackhi_pd(r2, r3);
  c0 = _mm256_permute2f128_pd(t0, t2, 0x20);
  c1 = _mm256_permute2f128_pd(t1, t3, 0x20);
  c2 = _mm256_permute2f128_pd(t0, t2, 0x31);
  c3 = _mm256_permute2f128_pd(t1, t3, 0x31);
}
inline void transpose3(__m256d r0, __m256d r1, __m256d r2, __m256d r3, __m256d& c0, __m256d& c1, __m256d& c2) {
  const __m256d t0 = _mm256_unpacklo_pd(r0, r1), t1 = _mm256_unpackhi_pd(r0, r1);
  const __m256d t2 = _mm256_unpacklo_pd(r2, r3), t3 = _mm256_unpackhi_pd(r2, r3);
  c0 = _mm256_permute2f128_pd(t0, t2, 0x20);
  c1 = _mm256_permute2f128_pd(t1, t3, 0x20);
  c2 = _mm256_permute2f128_pd(t0, t2, 0x31);
}
// Three doubles at p (x y z of a particle) in lanes 0–2; lane 3 is zero and nothing past p[2] is read
// (a masked load does not touch, or fault on, the masked-off double).
inline __m256d load_xyz(const double* p) {
#if defined(__AVX512VL__)
  return _mm256_maskz_loadu_pd(0x7, p);
#else
  return _mm256_maskload_pd(p, _mm256_set_epi64x(0, -1, -1, -1));
#endif
}
// Lanes lo (0–3) and hi (4–7) to dst[0..8), dst 64-byte aligned: one store with AVX-512 (see above).
inline void store8(double* dst, __m256d lo, __m256d hi) {
#if defined(__AVX512F__)
  // The masked form with its own pass-through: the plain one's _mm512_undefined_pd trips GCC 12's
  // -Wuninitialized. Mask all ones, so it compiles to the same single vinsertf64x4.
  const __m512d wide = _mm512_castpd256_pd512(lo);
  _mm512_store_pd(dst, _mm512_mask_insertf64x4(wide, 0xff, wide, hi, 1));
#else
  _mm256_store_pd(dst, lo);
  _mm256_store_pd(dst + 4, hi);
#endif
}
#if defined(__AVX512F__)
// Eight rows of 4 doubles (rows m and m + 2 of each group of four in one 512-bit vector: z0 = r0|r2,
// z1 = r1|r3, z2 = r4|r6, z3 = r5|r7) to four 8-lane columns c0..c3, stored at dst[f] + 0..8 (64-byte
// aligned). Four in-lane unpacks and one cross-lane shuffle per column: 8 shuffles for 8 rows, against
// 16 for two 4 × 4 transposes and 4 more to join their halves (bench/README.md, "Eight rows at once").
// kColumns < 4 leaves out the last columns (x y z rows).
template <int kColumns>
inline void transpose8_store(__m512d z0, __m512d z1, __m512d z2, __m512d z3, double* const (&dst)[kColumns]) {
  const __m512d t0 = _mm512_unpacklo_pd(z0, z1), t2 = _mm512_unpacklo_pd(z2, z3);  // a and c of each row
  const __m512d t1 = _mm512_unpackhi_pd(z0, z1), t3 = _mm512_unpackhi_pd(z2, z3);  // b and d
  _mm512_store_pd(dst[0], _mm512_shuffle_f64x2(t0, t2, 0x88));
  _mm512_store_pd(dst[1], _mm512_shuffle_f64x2(t1, t3, 0x88));
  if constexpr (kColumns > 2) _mm512_store_pd(dst[2], _mm512_shuffle_f64x2(t0, t2, 0xdd));
  if constexpr (kColumns > 3) _mm512_store_pd(dst[3], _mm512_shuffle_f64x2(t1, t3, 0xdd));
}
// Two rows of 4 doubles as one 512-bit vector: lo in lanes 0–3, hi in 4–7.
inline __m512d pair(__m256d lo, __m256d hi) { return _mm512_insertf64x4(_mm512_castpd256_pd512(lo), hi, 1); }
#endif
}  // namespace detail
#endif

// Positions and volumes of the far ends of bonds k..k+n−1 (neighbor ids nb[0..n)); n ≤ kBondLanes. y is
// 3 doubles per particle, `reference` one ReferencePoint (x y z V, 32-byte aligned). A multiple of 8 is
// loaded as vectors, other counts one by one.
[[gnu::always_inline]] inline void gather_positions(const double* y, const ReferencePoint* reference,
                                                    const std::uint32_t* nb, int n, ChunkPositions& c) {
#ifdef PERIFX_BOND_GATHER_AVX
  if (n % 8 == 0) {  // kBondLanes, or a 16-lane family's tail of exactly 8
#if defined(__AVX512F__)
    for (int g = 0; g < n; g += 8) {
      const std::uint32_t* q = nb + g;
      auto row = [&](int m) { return detail::load_xyz(y + 3 * std::size_t(q[m])); };
      auto point = [&](int m) { return _mm256_load_pd(&reference[q[m]].x); };
      double* const yd[3] = {c.yx + g, c.yy + g, c.yz + g};
      detail::transpose8_store<3>(detail::pair(row(0), row(2)), detail::pair(row(1), row(3)),
                                  detail::pair(row(4), row(6)), detail::pair(row(5), row(7)), yd);
      double* const xd[4] = {c.xx + g, c.xy + g, c.xz + g, c.v + g};
      detail::transpose8_store<4>(detail::pair(point(0), point(2)), detail::pair(point(1), point(3)),
                                  detail::pair(point(4), point(6)), detail::pair(point(5), point(7)), xd);
    }
    return;
#endif
    for (int g = 0; g < n; g += 8) {
      const std::uint32_t* q = nb + g;
      // Eight neighbours' y rows (x y z) into lanes g..g+7.
      __m256d a0, b0, d0, a1, b1, d1, f0, f1;
      detail::transpose3(detail::load_xyz(y + 3 * std::size_t(q[0])), detail::load_xyz(y + 3 * std::size_t(q[1])),
                         detail::load_xyz(y + 3 * std::size_t(q[2])), detail::load_xyz(y + 3 * std::size_t(q[3])), a0, b0,
                         d0);
      detail::transpose3(detail::load_xyz(y + 3 * std::size_t(q[4])), detail::load_xyz(y + 3 * std::size_t(q[5])),
                         detail::load_xyz(y + 3 * std::size_t(q[6])), detail::load_xyz(y + 3 * std::size_t(q[7])), a1, b1,
                         d1);
      detail::store8(c.yx + g, a0, a1);
      detail::store8(c.yy + g, b0, b1);
      detail::store8(c.yz + g, d0, d1);
      // Their reference points (x y z V), one aligned load each.
      auto point = [&](int m) { return _mm256_load_pd(&reference[q[m]].x); };
      detail::transpose4(point(0), point(1), point(2), point(3), a0, b0, d0, f0);
      detail::transpose4(point(4), point(5), point(6), point(7), a1, b1, d1, f1);
      detail::store8(c.xx + g, a0, a1);
      detail::store8(c.xy + g, b0, b1);
      detail::store8(c.xz + g, d0, d1);
      detail::store8(c.v + g, f0, f1);
    }
    return;
  }
#endif
  for (int l = 0; l < n; ++l) {
    const std::size_t j = nb[l];
    c.yx[l] = y[3 * j], c.yy[l] = y[3 * j + 1], c.yz[l] = y[3 * j + 2];
    const ReferencePoint& p = reference[j];
    c.xx[l] = p.x, c.xy[l] = p.y, c.xz[l] = p.z, c.v[l] = p.volume;
  }
}

// The far ends' BondEnd lines of bonds k..k+n−1: the elastic half (coupling, b4, volume, horizon)
// always, the inelastic half (β θ, yield and break extensions, plastic cap) when kInelastic.
template <bool kInelastic>
[[gnu::always_inline]] inline void gather_ends(const BondEnd* ends, const std::uint32_t* nb, int n, ChunkEnds& c) {
  static_assert(offsetof(BondEnd, horizon) == 3 * sizeof(double) && offsetof(BondEnd, break_extension) == 7 * sizeof(double),
                "the two halves of BondEnd are loaded as four doubles each");
#ifdef PERIFX_BOND_GATHER_AVX
  if (n % 8 == 0) {  // kBondLanes, or a 16-lane family's tail of exactly 8
#if defined(__AVX512F__)
    for (int g = 0; g < n; g += 8) {
      const double* e[8];
      for (int m = 0; m < 8; ++m) e[m] = &ends[nb[g + m]].coupling;
      auto half = [&](int m, int h) { return _mm256_load_pd(e[m] + 4 * h); };
      double* const elastic[4] = {c.coupling + g, c.b4 + g, c.volume + g, c.horizon + g};
      detail::transpose8_store<4>(detail::pair(half(0, 0), half(2, 0)), detail::pair(half(1, 0), half(3, 0)),
                                  detail::pair(half(4, 0), half(6, 0)), detail::pair(half(5, 0), half(7, 0)), elastic);
      if constexpr (kInelastic) {
        double* const inelastic[4] = {c.beta_theta + g, c.yield_extension + g, c.plastic_cap + g, c.break_extension + g};
        detail::transpose8_store<4>(detail::pair(half(0, 1), half(2, 1)), detail::pair(half(1, 1), half(3, 1)),
                                    detail::pair(half(4, 1), half(6, 1)), detail::pair(half(5, 1), half(7, 1)),
                                    inelastic);
      }
    }
    return;
#endif
    for (int g = 0; g < n; g += 8) {
      const double* e[8];
      for (int m = 0; m < 8; ++m) e[m] = &ends[nb[g + m]].coupling;
      __m256d a0, b0, d0, f0, a1, b1, d1, f1;
      detail::transpose4(_mm256_load_pd(e[0]), _mm256_load_pd(e[1]), _mm256_load_pd(e[2]), _mm256_load_pd(e[3]), a0, b0,
                         d0, f0);
      detail::transpose4(_mm256_load_pd(e[4]), _mm256_load_pd(e[5]), _mm256_load_pd(e[6]), _mm256_load_pd(e[7]), a1, b1,
                         d1, f1);
      detail::store8(c.coupling + g, a0, a1);
      detail::store8(c.b4 + g, b0, b1);
      detail::store8(c.volume + g, d0, d1);
      detail::store8(c.horizon + g, f0, f1);
      if constexpr (kInelastic) {
        detail::transpose4(_mm256_load_pd(e[0] + 4), _mm256_load_pd(e[1] + 4), _mm256_load_pd(e[2] + 4),
                           _mm256_load_pd(e[3] + 4), a0, b0, d0, f0);
        detail::transpose4(_mm256_load_pd(e[4] + 4), _mm256_load_pd(e[5] + 4), _mm256_load_pd(e[6] + 4),
                           _mm256_load_pd(e[7] + 4), a1, b1, d1, f1);
        detail::store8(c.beta_theta + g, a0, a1);
        detail::store8(c.yield_extension + g, b0, b1);
        detail::store8(c.plastic_cap + g, d0, d1);
        detail::store8(c.break_extension + g, f0, f1);
      }
    }
    return;
  }
#endif
  for (int l = 0; l < n; ++l) {
    const BondEnd& e = ends[nb[l]];
    c.coupling[l] = e.coupling, c.b4[l] = e.b4, c.volume[l] = e.volume, c.horizon[l] = e.horizon;
    if constexpr (kInelastic) {
      c.beta_theta[l] = e.beta_theta, c.yield_extension[l] = e.yield_extension, c.plastic_cap[l] = e.plastic_cap;
      c.break_extension[l] = e.break_extension;
    }
  }
}

}  // namespace perifx::systems
