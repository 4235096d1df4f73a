// The CPU loop of pair.lj: particles in vector lanes (AVX2: 4 doubles or 8 floats; AVX-512: 8 or
// 16), each lane one particle i walking its own row of the Verlet list in list order, exactly as
// the scalar functor LJForce (kernel.h) does: the same operations on the same values in the same
// order, with the pairs beyond the cutoff (and the rows already finished) blended out instead of
// skipped. So every particle's force, energy and virial have the bits of the scalar functor, hence
// of the CUDA loop, for any thread count, any split of the range and any assignment of particles to
// lanes. The radial terms are kernel.h's lj_terms and lj_energy, instantiated on the lane type
// below. Why lanes across particles: the scalar loop's cutoff test is taken for about half the
// listed pairs at random, a branch no predictor learns; lanes turn it into a blend. A block of W
// lanes runs as long as its longest row, so each task puts its particles into lanes in order of row
// length. Built with flipflow_cpu_loop_flags (AVX2, no fma contraction); the loop is built a second
// time for x86-64-v4 with 512-bit lanes and taken where the CPU has AVX-512
// (core/backend/cpu_isa.h): the same operations per lane, so the same bits (test_pair_lj_lanes,
// and test_pair_lj_avx2 for the AVX2 lanes on such a CPU). Measurements: bench/README.md.
#include <immintrin.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "core/backend/cpu_isa.h"
#include "core/backend/exec_cpu.h"
#include "plugins/pair/lj/stage.h"

namespace ff::pair {

namespace lanes {

// B: the bytes of a vector, 32 (AVX2) or 64 (AVX-512; only inside functions built for
// x86-64-v4, see lj_cpu_loop). index: W int32 list entries or element offsets.
template <class R, int B>
struct Raw;
template <>
struct Raw<double, 32> {
  typedef double type __attribute__((vector_size(32)));
  typedef long long mask __attribute__((vector_size(32)));
  typedef __m128i index;  // 4 x int32
};
template <>
struct Raw<float, 32> {
  typedef float type __attribute__((vector_size(32)));
  typedef int mask __attribute__((vector_size(32)));
  typedef __m256i index;  // 8 x int32
};
template <>
struct Raw<double, 64> {
  typedef double type __attribute__((vector_size(64)));
  typedef long long mask __attribute__((vector_size(64)));
  typedef __m256i index;  // 8 x int32
};
template <>
struct Raw<float, 64> {
  typedef float type __attribute__((vector_size(64)));
  typedef int mask __attribute__((vector_size(64)));
  typedef __m512i index;  // 16 x int32
};

// W reals, one per particle; a class, so that kernel.h's unqualified mul_rn and sqrt find the
// overloads below by argument-dependent lookup.
template <class R, int B>
struct V {
  using raw = typename Raw<R, B>::type;
  using mask = typename Raw<R, B>::mask;
  using index = typename Raw<R, B>::index;
  static constexpr int W = int(B / sizeof(R));
  raw v;
  V() = default;
  V(raw x) : v(x) {}
  V(R x) : v(raw{} + x) {}  // every lane x
};
template <class R, int B>
V<R, B> operator+(V<R, B> a, V<R, B> b) { return a.v + b.v; }
template <class R, int B>
V<R, B> operator-(V<R, B> a, V<R, B> b) { return a.v - b.v; }
template <class R, int B>
V<R, B> operator*(V<R, B> a, V<R, B> b) { return a.v * b.v; }
template <class R, int B>
V<R, B> operator/(V<R, B> a, V<R, B> b) { return a.v / b.v; }
template <class R, int B>
V<R, B> mul_rn(V<R, B> a, V<R, B> b) { return a.v * b.v; }  // never contracted: flipflow_cpu_loop_flags
template <class R, int B>
V<R, B> select(typename V<R, B>::mask m, V<R, B> a, V<R, B> b) { return m ? a.v : b.v; }

// AVX2: 4 doubles or 8 floats.
using D4 = V<double, 32>;
using F8 = V<float, 32>;
inline D4 sqrt(D4 a) { return (D4::raw)_mm256_sqrt_pd((__m256d)a.v); }
inline F8 sqrt(F8 a) { return (F8::raw)_mm256_sqrt_ps((__m256)a.v); }
// std::rint in the default rounding mode (to nearest, ties to even), as PeriodicBox::min_image.
inline D4 rint(D4 a) { return (D4::raw)_mm256_round_pd((__m256d)a.v, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC); }
inline F8 rint(F8 a) { return (F8::raw)_mm256_round_ps((__m256)a.v, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC); }
inline bool any(D4::mask m) { return !_mm256_testz_si256((__m256i)m, (__m256i)m); }
inline bool any(F8::mask m) { return !_mm256_testz_si256((__m256i)m, (__m256i)m); }

// Lane indices (int32) and gathers. The lane type L picks the index width (a null L* as tag).
inline __m128i splat_index(D4*, int x) { return _mm_set1_epi32(x); }
inline __m256i splat_index(F8*, int x) { return _mm256_set1_epi32(x); }
inline __m128i load_index(D4*, const std::uint32_t* p) { return _mm_loadu_si128((const __m128i*)p); }  // W of them
inline __m256i load_index(F8*, const std::uint32_t* p) { return _mm256_loadu_si256((const __m256i*)p); }
inline __m128i add(__m128i a, __m128i b) { return _mm_add_epi32(a, b); }
inline __m256i add(__m256i a, __m256i b) { return _mm256_add_epi32(a, b); }
inline __m128i mul(__m128i a, __m128i b) { return _mm_mullo_epi32(a, b); }
inline __m256i mul(__m256i a, __m256i b) { return _mm256_mullo_epi32(a, b); }
inline __m128i greater(__m128i a, __m128i b) { return _mm_cmpgt_epi32(a, b); }
inline __m256i greater(__m256i a, __m256i b) { return _mm256_cmpgt_epi32(a, b); }
inline void store_index(std::int32_t* p, __m128i x) { _mm_store_si128((__m128i*)p, x); }
inline void store_index(std::int32_t* p, __m256i x) { _mm256_store_si256((__m256i*)p, x); }
// base[idx] where m is set, src elsewhere (32-bit elements).
inline __m128i gather_masked(__m128i src, const std::uint32_t* base, __m128i idx, __m128i m) {
  return _mm_mask_i32gather_epi32(src, (const int*)base, idx, m, 4);
}
inline __m256i gather_masked(__m256i src, const std::uint32_t* base, __m256i idx, __m256i m) {
  return _mm256_mask_i32gather_epi32(src, (const int*)base, idx, m, 4);
}
inline __m128i gather_int(const std::int32_t* base, __m128i idx) { return _mm_i32gather_epi32(base, idx, 4); }
inline __m256i gather_int(const std::int32_t* base, __m256i idx) { return _mm256_i32gather_epi32(base, idx, 4); }
inline D4 gather(const double* base, __m128i idx) { return (D4::raw)_mm256_i32gather_pd(base, idx, 8); }
inline F8 gather(const float* base, __m256i idx) { return (F8::raw)_mm256_i32gather_ps(base, idx, 4); }
// An int32 lane mask (all ones or zero) as the reals' lane mask.
inline D4::mask widen(D4*, __m128i m) { return (D4::mask)_mm256_cvtepi32_epi64(m); }
inline F8::mask widen(F8*, __m256i m) { return (F8::mask)m; }
// Records (double): each particle's position (D reals, zeros up to 3) and diameter, 32 bytes
// (lj_cpu_forces packs them every step). load_records turns the records of particles j[0 .. W − 1]
// into x, y, z, d of W lanes: W loads and a transpose instead of four gathers.
inline void load_records(const double* rec, const std::int32_t* j, D4 out[4]) {
  const __m256d r0 = _mm256_loadu_pd(rec + 4 * std::size_t(j[0])), r1 = _mm256_loadu_pd(rec + 4 * std::size_t(j[1]));
  const __m256d r2 = _mm256_loadu_pd(rec + 4 * std::size_t(j[2])), r3 = _mm256_loadu_pd(rec + 4 * std::size_t(j[3]));
  const __m256d t0 = _mm256_unpacklo_pd(r0, r1);  // x0 x1 | z0 z1
  const __m256d t1 = _mm256_unpackhi_pd(r0, r1);  // y0 y1 | d0 d1
  const __m256d t2 = _mm256_unpacklo_pd(r2, r3);  // x2 x3 | z2 z3
  const __m256d t3 = _mm256_unpackhi_pd(r2, r3);  // y2 y3 | d2 d3
  out[0] = (D4::raw)_mm256_permute2f128_pd(t0, t2, 0x20);
  out[1] = (D4::raw)_mm256_permute2f128_pd(t1, t3, 0x20);
  out[2] = (D4::raw)_mm256_permute2f128_pd(t0, t2, 0x31);
  out[3] = (D4::raw)_mm256_permute2f128_pd(t1, t3, 0x31);
}

#if FF_CPU_V4_DISPATCH
// GCC warns that 512-bit vectors passed by value change the ABI of a function built without
// AVX-512 (the generic templates): they never are, every one is inlined into range_avx512.
#pragma GCC diagnostic ignored "-Wpsabi"
// AVX-512: 8 doubles or 16 floats. Built for x86-64-v4 and not always_inline: only the x86-64-v4
// entry point (flatten) inlines them (GCC refuses an always_inline function of a wider target
// inside the generic block template). Each must be inlined there: a 512-bit vector passed
// between functions of different targets does not keep its bits (test_pair_lj_lanes catches
// that; `objdump -d` of range_avx512 shows no call).
using D8 = V<double, 64>;
using F16 = V<float, 64>;
// sqrt lane by lane in plain C++ (GCC 12 leaves it scalar: slower, only for odd n and geometric
// mixing): kernel.h's lj_terms, a template of no target, calls it, and GCC kept an x86-64-v4
// sqrt called from there out of line.
template <class R>
inline V<R, 64> sqrt(V<R, 64> a) {
  for (int l = 0; l < V<R, 64>::W; ++l) a.v[l] = std::sqrt(a.v[l]);
  return a;
}
FF_TARGET_X86_64_V4 inline D8 rint(D8 a) {
  return (D8::raw)_mm512_roundscale_pd((__m512d)a.v, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
}
FF_TARGET_X86_64_V4 inline F16 rint(F16 a) {
  return (F16::raw)_mm512_roundscale_ps((__m512)a.v, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
}
FF_TARGET_X86_64_V4 inline bool any(D8::mask m) { return _mm512_test_epi64_mask((__m512i)m, (__m512i)m) != 0; }
FF_TARGET_X86_64_V4 inline bool any(F16::mask m) { return _mm512_test_epi32_mask((__m512i)m, (__m512i)m) != 0; }
inline __m256i splat_index(D8*, int x) { return _mm256_set1_epi32(x); }
FF_TARGET_X86_64_V4 inline __m512i splat_index(F16*, int x) { return _mm512_set1_epi32(x); }
inline __m256i load_index(D8*, const std::uint32_t* p) { return _mm256_loadu_si256((const __m256i*)p); }
FF_TARGET_X86_64_V4 inline __m512i load_index(F16*, const std::uint32_t* p) { return _mm512_loadu_si512(p); }
FF_TARGET_X86_64_V4 inline __m512i add(__m512i a, __m512i b) { return _mm512_add_epi32(a, b); }
FF_TARGET_X86_64_V4 inline __m512i mul(__m512i a, __m512i b) { return _mm512_mullo_epi32(a, b); }
FF_TARGET_X86_64_V4 inline __m512i greater(__m512i a, __m512i b) {
  return _mm512_movm_epi32(_mm512_cmpgt_epi32_mask(a, b));
}
FF_TARGET_X86_64_V4 inline void store_index(std::int32_t* p, __m512i x) { _mm512_store_si512(p, x); }
FF_TARGET_X86_64_V4 inline __m512i gather_masked(__m512i src, const std::uint32_t* base, __m512i idx, __m512i m) {
  return _mm512_mask_i32gather_epi32(src, _mm512_movepi32_mask(m), idx, base, 4);
}
FF_TARGET_X86_64_V4 inline __m512i gather_int(const std::int32_t* base, __m512i idx) {
  return _mm512_i32gather_epi32(idx, base, 4);
}
FF_TARGET_X86_64_V4 inline D8 gather(const double* base, __m256i idx) {
  return (D8::raw)_mm512_i32gather_pd(idx, base, 8);
}
FF_TARGET_X86_64_V4 inline F16 gather(const float* base, __m512i idx) {
  return (F16::raw)_mm512_i32gather_ps(idx, base, 4);
}
FF_TARGET_X86_64_V4 inline D8::mask widen(D8*, __m256i m) { return (D8::mask)_mm512_cvtepi32_epi64(m); }
inline F16::mask widen(F16*, __m512i m) { return (F16::mask)m; }
// Records j[l] and j[l + 4] in the two halves of one vector. (Helpers, not lambdas: a lambda
// would not take the x86-64-v4 target.)
FF_TARGET_X86_64_V4 inline __m512d record_pair(const double* rec, std::int32_t a, std::int32_t b) {
  return _mm512_insertf64x4(_mm512_castpd256_pd512(_mm256_loadu_pd(rec + 4 * std::size_t(a))),
                            _mm256_loadu_pd(rec + 4 * std::size_t(b)), 1);
}
FF_TARGET_X86_64_V4 inline void load_records(const double* rec, const std::int32_t* j, D8 out[4]) {
  const __m512d A = record_pair(rec, j[0], j[4]), B = record_pair(rec, j[1], j[5]);
  const __m512d C = record_pair(rec, j[2], j[6]), E = record_pair(rec, j[3], j[7]);
  const __m512d t0 = _mm512_unpacklo_pd(A, B);  // x0 x1 | z0 z1 | x4 x5 | z4 z5
  const __m512d t1 = _mm512_unpackhi_pd(A, B);  // y0 y1 | d0 d1 | y4 y5 | d4 d5
  const __m512d t2 = _mm512_unpacklo_pd(C, E);  // x2 x3 | z2 z3 | x6 x7 | z6 z7
  const __m512d t3 = _mm512_unpackhi_pd(C, E);  // y2 y3 | d2 d3 | y6 y7 | d6 d7
  const __m512i lo = _mm512_setr_epi64(0, 1, 8, 9, 4, 5, 12, 13), hi = _mm512_setr_epi64(2, 3, 10, 11, 6, 7, 14, 15);
  out[0] = (D8::raw)_mm512_permutex2var_pd(t0, lo, t2);
  out[1] = (D8::raw)_mm512_permutex2var_pd(t1, lo, t3);
  out[2] = (D8::raw)_mm512_permutex2var_pd(t0, hi, t2);
  out[3] = (D8::raw)_mm512_permutex2var_pd(t1, hi, t3);
}
#endif
// Float lanes read positions and diameters by gathers (no records).
template <class L>
inline void load_records(const void*, const std::int32_t*, L*) {}

// Entry a of the rows starting at row (lanes i, count entries each) into to[0 .. W − 1]; the
// lanes whose row has ended take their own particle i.
template <class L, class I>
inline void entries(L* tag, const std::uint32_t* list, I i, I row, I count, std::uint32_t a, std::int32_t* to) {
  const auto a_lanes = splat_index(tag, int(a));
  store_index(to, gather_masked(i, list, add(row, a_lanes), greater(count, a_lanes)));
}

// Particles who[0 .. W − 1] (each < n): LJForce::operator() for each, one per lane of L. kEnergy
// is f.energy != nullptr; kN is f.n, or 0 for an n known only at run time (a constant n unrolls
// power()'s loop). record: the records of load_records (double), or null (float).
template <class L, class R, int D, bool kEnergy, int kN>
inline __attribute__((always_inline)) void block(const LJForce<R, D>& f, const R* record, const std::uint32_t* who) {
  constexpr bool kRecords = std::is_same_v<R, double>;
  using M = typename L::mask;
  constexpr int W = L::W;
  L* const tag = nullptr;  // picks the index width of L
  const auto i = load_index(tag, who);
  const auto iD = mul(i, splat_index(tag, D));
  L own[4];  // the lanes' own records (double)
  if (kRecords) load_records(record, reinterpret_cast<const std::int32_t*>(who), own);
  L xi[D];
  for (int c = 0; c < D; ++c) xi[c] = kRecords ? own[c] : gather(f.position, add(iD, splat_index(tag, c)));
  const auto count = gather_int(reinterpret_cast<const std::int32_t*>(f.count), i);
  std::uint32_t longest = 0;
  for (int l = 0; l < W; ++l) longest = std::max(longest, f.count[who[l]]);
  const auto row = mul(i, splat_index(tag, int(f.capacity)));  // where each lane's row starts
  const std::uint32_t* const list = f.list;
  const L di = !f.diameter ? L(R(0)) : kRecords ? own[3] : gather(f.diameter, i);
  const auto ti = f.type ? mul(gather_int(f.type, i), splat_index(tag, kMaxTypes)) : splat_index(tag, 0);
  const L r_cut2(f.r_cut2), shift(f.shift);
  L force[D], u(R(0)), w(R(0));
  for (int c = 0; c < D; ++c) force[c] = L(R(0));
  // Each lane's list entry a (finished rows: their own particle, then masked out, never an unset
  // entry), gathered two entries ahead into a ring of three: its neighbours' records (or
  // positions) are fetched then, since at N = 2^16 they miss the core's cache.
  alignas(64) std::int32_t ring[3][W];
  entries(tag, list, i, row, count, 0, ring[0]);
  entries(tag, list, i, row, count, 1, ring[1]);
  for (std::uint32_t a = 0; a < longest; ++a) {
    {
      std::int32_t* const next = ring[(a + 2) % 3];
      entries(tag, list, i, row, count, a + 2, next);
      for (int l = 0; l < W; ++l) {
        const std::size_t j = std::size_t(next[l]);
        _mm_prefetch(reinterpret_cast<const char*>(kRecords ? record + 4 * j : f.position + j * D), _MM_HINT_T0);
      }
    }
    const std::int32_t* const here = ring[a % 3];
    const auto active = greater(count, splat_index(tag, int(a)));
    const auto j = load_index(tag, reinterpret_cast<const std::uint32_t*>(here));
    L rec[4];
    if (kRecords) load_records(record, here, rec);
    const auto jD = mul(j, splat_index(tag, D));
    L d[D], r2(R(0));
    for (int c = 0; c < D; ++c) {
      const L dc = xi[c] - (kRecords ? rec[c] : gather(f.position, add(jD, splat_index(tag, c))));
      d[c] = dc - L(f.box.L[c]) * rint(dc * L(f.box.inv_L[c]));
      r2 = r2 + mul_rn(d[c], d[c]);
    }
    auto ab = ti;
    if (f.type) ab = add(ti, gather_int(f.type, j));
    L sig2;
    if (f.diameter) {
      const L dj = kRecords ? rec[3] : gather(f.diameter, j);
      const L s = f.geometric ? sqrt(mul_rn(di, dj)) : L(R(0.5)) * (di + dj);
      sig2 = mul_rn(s, s);
    } else {
      sig2 = f.type ? gather(f.table.sigma2, ab) : L(f.table.sigma2[0]);
    }
    // Kept: in an unfinished row, not beyond the cutoff, not coincident (the scalar `continue`).
    const M keep = widen(tag, active) & ~M(r2.v >= mul_rn(r_cut2, sig2).v) & M(r2.v != R(0));
    if (!any(keep)) continue;
    L inv_r2 = L(R(1)) / r2;
    L s = mul_rn(sig2, inv_r2);
    const M capped = keep & M(s.v > R(kMaxS));
    if (any(capped)) {
      s = select<R>(capped, L(R(kMaxS)), s);
      inv_r2 = select<R>(capped, s / sig2, inv_r2);
    }
    const L eps = f.type ? gather(f.table.epsilon, ab) : L(f.table.epsilon[0]);
    const LJTerms<L> t = lj_terms(s, inv_r2, eps, kN ? kN : f.n);
    for (int c = 0; c < D; ++c) force[c] = select<R>(keep, force[c] + mul_rn(t.magnitude, d[c]), force[c]);
    if (kEnergy) {
      u = select<R>(keep, u + lj_energy(t, eps, shift), u);
      w = select<R>(keep, w + mul_rn(t.magnitude, r2), w);
    }
  }
  for (int l = 0; l < W; ++l)
    for (int c = 0; c < D; ++c) f.force[std::size_t(who[l]) * D + c] = force[c].v[l];
  if (kEnergy) {
    const L half(R(0.5));
    const L eu = half * u, ew = half * w;
    for (int l = 0; l < W; ++l) {
      f.energy[who[l]] = eu.v[l];
      f.virial[who[l]] = ew.v[l];
    }
  }
}

constexpr std::size_t kGrain = 2048;  // particles per task at most

// Particles [p0, p1) (at most kGrain) in lanes of L. They go into lanes in order of their row
// length (a stable counting sort), so the W rows of a block end together: lanes wait little on
// the longest row of their block. Which lane a particle takes does not change its bits.
template <class L, bool kEnergy, int kN, class R, int D>
inline void particles(const LJForce<R, D>& f, const R* record, std::size_t p0, std::size_t p1) {
  constexpr std::size_t W = L::W;
  const LJForce<R, D> local = f;  // members in registers (see cpu_for_each)
  std::uint32_t who[kGrain], start[65];
  constexpr std::uint32_t kLongest = 63;  // rows longer than this share the last bucket
  std::fill(start, start + 65, 0u);
  for (std::size_t i = p0; i < p1; ++i) ++start[std::min(local.count[i], kLongest) + 1];
  for (std::uint32_t b = 1; b < 65; ++b) start[b] += start[b - 1];
  for (std::size_t i = p0; i < p1; ++i) who[start[std::min(local.count[i], kLongest)]++] = std::uint32_t(i);
  const std::size_t m = p1 - p0, full = m / W * W;
  for (std::size_t b = 0; b < full; b += W) {
    // The next block's rows (their first two lines), fetched while this block runs: in the order
    // of row length the rows are scattered over the task's part of the list (~150 kB at 2^16), so
    // the hardware prefetcher cannot follow, and each block's first list gather would wait on its
    // rows (half of pair.lj's samples without this; bench/README.md).
    if (b + W < full)
      for (std::size_t l = 0; l < W; ++l) {
        const char* const r = reinterpret_cast<const char*>(local.list + std::size_t(who[b + W + l]) * local.capacity);
        _mm_prefetch(r, _MM_HINT_T0);
        _mm_prefetch(r + 64, _MM_HINT_T0);
        if (record) _mm_prefetch(reinterpret_cast<const char*>(record + 4 * std::size_t(who[b + W + l])), _MM_HINT_T0);
      }
    block<L, R, D, kEnergy, kN>(local, record, who + b);
  }
  for (std::size_t b = full; b < m; ++b) local(who[b]);  // the last m mod W, one by one
}

// Particles [r0, r1) in tasks of at most kGrain (oneTBB's ranges may exceed the grain), in lanes
// of B bytes. No lambdas here: a lambda would not take the x86-64-v4 entry point's target.
template <int B, class R, int D>
inline void range(const LJForce<R, D>& f, const R* record, std::size_t r0, std::size_t r1) {
  using L = V<R, B>;
  constexpr int kTran = 18;  // Tran et al.'s 36–18
  for (std::size_t p0 = r0; p0 < r1; p0 += kGrain) {
    const std::size_t p1 = std::min(r1, p0 + kGrain);
    if (f.energy) {
      if (f.n == kTran) particles<L, true, kTran>(f, record, p0, p1);
      else particles<L, true, 0>(f, record, p0, p1);
    } else {
      if (f.n == kTran) particles<L, false, kTran>(f, record, p0, p1);
      else particles<L, false, 0>(f, record, p0, p1);
    }
  }
}

template <class R, int D>
__attribute__((flatten)) void range_avx2(const LJForce<R, D>& f, const R* record, std::size_t r0, std::size_t r1) {
  range<32>(f, record, r0, r1);
}
#if FF_CPU_V4_DISPATCH
template <class R, int D>
FF_TARGET_X86_64_V4 __attribute__((flatten)) void range_avx512(const LJForce<R, D>& f, const R* record, std::size_t r0,
                                                                std::size_t r1) {
  range<64>(f, record, r0, r1);
}
#endif

}  // namespace lanes

// Rows [0, n), reading any of the `held` particles (loops.h). Double: each step first packs every
// held particle's record (position, zeros, diameter; 32-byte aligned, so one cache line) into
// scratch, which the lanes read instead of gathering from the position and diameter arrays.
template <class R, int D>
void lj_cpu_forces(std::size_t n, std::size_t held, const LJForce<R, D>& f, LJScratch<R>& scratch,
                   CUstream_st* stream) {
  // The lanes' gathers take int32 element offsets.
  if (held * std::max<std::size_t>(4, f.capacity) >= std::size_t(std::numeric_limits<std::int32_t>::max())) {
    cpu_for_each(n, f, stream);
    return;
  }
  const R* record = nullptr;
  if constexpr (std::is_same_v<R, double>) {
    R* const base = scratch.record.get(4 * held + 4);
    R* const rec = base + (-reinterpret_cast<std::uintptr_t>(base) / sizeof(R) & 3);  // 32-byte aligned
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, held, 8192), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t p = r.begin(); p < r.end(); ++p) {
        for (int c = 0; c < D; ++c) rec[4 * p + c] = f.position[p * D + c];
        rec[4 * p + 3] = f.diameter ? f.diameter[p] : R(0);
      }
    });
    record = rec;
  }
  const bool avx512 = cpu_has_x86_64_v4();
  auto run = [&](std::size_t r0, std::size_t r1) {
#if FF_CPU_V4_DISPATCH
    if (avx512) return lanes::range_avx512(f, record, r0, r1);
#else
    (void)avx512;
#endif
    lanes::range_avx2(f, record, r0, r1);
  };
  if (n <= lanes::kGrain) run(0, n);
  else
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, lanes::kGrain),
                      [&](const tbb::blocked_range<std::size_t>& r) { run(r.begin(), r.end()); });
}

template <class R>
LJLoops<R> lj_loops(CpuExec) {
  return {&lj_cpu_forces<R, 2>, &lj_cpu_forces<R, 3>};
}
template LJLoops<float> lj_loops<float>(CpuExec);
template LJLoops<double> lj_loops<double>(CpuExec);

}  // namespace ff::pair
