// Counter-based random numbers (Philox4x32-10, Random123), identical on host and device.
//
// Key: (seed, stage) — the stage part is a hash of the stage's id in the pipeline, so adding or
// reordering other stages does not change a stage's noise. Counter: (particle, step, attempt,
// draw). A rolled-back step is retried with attempt + 1 and so gets fresh numbers; the numbers
// never depend on thread count or launch order.
//
// Gaussians are drawn by Box–Muller in pairs, truncated at ±3 standard deviations (a pair with
// a member outside is redrawn with the next draw index) and rescaled by 1/sqrt(var_3), where
// var_3 = 1 − 6φ(3)/(2Φ(3) − 1) = 0.97333692 is the variance of a unit normal truncated to
// [−3, 3], so the numbers have exactly unit variance. Truncation bounds the largest
// displacement in a step, which keeps the triangulation repairable.
//
// Box–Muller's log and sincos are written here (musl's fdlibm polynomials, < 1 ulp), not taken
// from the platform's libm: branch-free code that a CPU loop vectorizes over particles, the
// same on both backends, and sincos(2πu) needs no general range reduction because u ∈ (0, 1]
// reduces exactly to a quadrant. gaussian_pair_lanes (host loops) gives bit-identical numbers
// to gaussian_pair as long as its translation unit does not contract a·b + c into fma (the
// CPU loops are built with -ffp-contract=off); on CUDA nvcc may fuse, a difference of ulps.
#pragma once
#include <Random123/philox.h>

#include <cmath>
#include <cstdint>
#include <cstring>

#include "core/hd.h"

// The host's AVX2 Philox lanes (below); never in code nvcc sees.
#if defined(__AVX2__) && !defined(__CUDACC__) && !defined(FF_RNG_NO_AVX2)
#define FF_RNG_AVX2 1
#include <immintrin.h>
#else
#define FF_RNG_AVX2 0
#endif

namespace ff {

struct RngKey {
  std::uint32_t seed_lo = 0;
  std::uint32_t seed_hi_stage = 0;  // seed high word XOR stage hash
};

// FNV-1a of a stage id, folded to 32 bits (host only).
inline std::uint32_t stage_hash(const char* s) {
  std::uint32_t h = 2166136261u;
  for (; *s; ++s) h = (h ^ std::uint8_t(*s)) * 16777619u;
  return h;
}

inline RngKey make_rng_key(std::uint64_t seed, const char* stage_id) {
  return RngKey{std::uint32_t(seed), std::uint32_t(seed >> 32) ^ stage_hash(stage_id)};
}

namespace rng_detail {
// Draw indices at or above this are reserved for redraws after a truncation reject.
constexpr std::uint32_t kRedrawBase = 0x8000u;
constexpr double kTruncation = 3.0;
constexpr double kTruncatedVarianceScale = 1.013604197642207;  // 1/sqrt(var_3)

FF_HD r123::Philox4x32::ctr_type raw(RngKey key, std::uint32_t particle, std::uint64_t step,
                                     std::uint32_t attempt, std::uint32_t draw) {
  r123::Philox4x32 philox;
  r123::Philox4x32::key_type k = {{key.seed_lo, key.seed_hi_stage}};
  r123::Philox4x32::ctr_type c = {
      {particle, std::uint32_t(step), std::uint32_t(step >> 32), (attempt << 16) | draw}};
  return philox(c, k);
}

// Uniform in (0, 1]: never 0, so log() in Box–Muller is finite. The 53 bits hi·2^21 + lo/2^11
// are summed in double (exact), with hi converted as a signed int + 2^31 (exact): both
// vectorize where 64-bit and unsigned conversions do not (AVX2).
FF_HD double u01_open0(std::uint32_t hi, std::uint32_t lo) {
  const double h = double(std::int32_t(hi ^ 0x80000000u)) + 2147483648.0;
  return (h * 2097152.0 + double(std::int32_t(lo >> 11)) + 1.0) * (1.0 / 9007199254740992.0);
}

FF_HD std::uint64_t bits_of(double x) {
#if defined(__CUDA_ARCH__)
  return std::uint64_t(__double_as_longlong(x));
#else
  std::uint64_t u;
  std::memcpy(&u, &x, sizeof u);
  return u;
#endif
}

FF_HD double from_bits(std::uint64_t u) {
#if defined(__CUDA_ARCH__)
  return __longlong_as_double(static_cast<long long>(u));
#else
  double x;
  std::memcpy(&x, &u, sizeof x);
  return x;
#endif
}

// log(u) for a normal positive u (musl's fdlibm e_log.c main path, < 1 ulp): u = 2^k (1 + f)
// with 1 + f in [√2/2, √2), log(1 + f) = f − f²/2 + s (f²/2 + R(s²)), s = f / (2 + f).
FF_HD double log_positive(double u) {
  constexpr double ln2_hi = 0x1.62e42fee00000p-1, ln2_lo = 0x1.a39ef35793c76p-33;
  constexpr double Lg1 = 0x1.5555555555593p-1, Lg2 = 0x1.999999997fa04p-2, Lg3 = 0x1.2492494229359p-2,
                   Lg4 = 0x1.c71c51d8e78afp-3, Lg5 = 0x1.7466496cb03dep-3, Lg6 = 0x1.39a09d078c69fp-3,
                   Lg7 = 0x1.2f112df3e5244p-3;
  const std::uint64_t ix = bits_of(u) + (0x3ff0000000000000ull - 0x3fe6a09e00000000ull);
  // k + 1023 is ix's exponent field; 2^52 + (k + 1023) − (2^52 + 1023) is k, exactly.
  const double k = from_bits(0x4330000000000000ull | (ix >> 52)) - 4503599627371519.0;
  const double f = from_bits((ix & 0x000fffffffffffffull) + 0x3fe6a09e00000000ull) - 1.0;
  const double hfsq = 0.5 * f * f;
  const double s = f / (2.0 + f);
  const double z = s * s;
  const double w = z * z;
  const double t1 = w * (Lg2 + w * (Lg4 + w * Lg6));
  const double t2 = z * (Lg1 + w * (Lg3 + w * (Lg5 + w * Lg7)));
  const double R = t2 + t1;
  return s * (hfsq + R) + k * ln2_lo - hfsq + f + k * ln2_hi;
}

// cos(2πu) and sin(2πu) for u in [0, 1]: 4u = q + r exactly (q = rint(4u), |r| ≤ 1/2), then
// musl's __cos/__sin kernels (< 1 ulp on [−π/4, π/4]) at x = r·π/2 and the quadrant q.
FF_HD void sincos_2pi(double u, double& s_out, double& c_out) {
  constexpr double C1 = 0x1.555555555554cp-5, C2 = -0x1.6c16c16c15177p-10, C3 = 0x1.a01a019cb1590p-16,
                   C4 = -0x1.27e4f809c52adp-22, C5 = 0x1.1ee9ebdb4b1c4p-29, C6 = -0x1.8fae9be8838d4p-37;
  constexpr double S1 = -0x1.5555555555549p-3, S2 = 0x1.111111110f8a6p-7, S3 = -0x1.a01a019c161d5p-13,
                   S4 = 0x1.71de357b1fe7dp-19, S5 = -0x1.ae5e68a2b9cebp-26, S6 = 0x1.5d93a5acfd57cp-33;
  constexpr double kHalfPi = 1.5707963267948966;
  const double t = 4.0 * u;
  const double q = std::rint(t);
  const double x = (t - q) * kHalfPi;
  const double z = x * x;
  const double w = z * z;
  const double rs = S2 + z * (S3 + z * S4) + z * w * (S5 + z * S6);
  const double sn = x + z * x * (S1 + z * rs);
  const double rc = z * (C1 + z * (C2 + z * C3)) + w * w * (C4 + z * (C5 + z * C6));
  const double hz = 0.5 * z;
  const double one_minus_hz = 1.0 - hz;
  const double cs = one_minus_hz + (((1.0 - one_minus_hz) - hz) + z * rc);
  // Quadrant q mod 4: odd ones swap sin and cos; sin is negative in 2 and 3, cos in 1 and 2.
  // (Arithmetic instead of branches keeps the loops over lanes vectorizable; ×±1 is exact.)
  const int quadrant = int(q) & 3;
  const double odd = double(quadrant & 1);
  const double s_abs = odd * cs + (1.0 - odd) * sn, c_abs = odd * sn + (1.0 - odd) * cs;
  s_out = s_abs * double(1 - (quadrant & 2));
  c_out = c_abs * double(1 - ((quadrant + 1) & 2));
}

// Box–Muller on one Philox output (before truncation and rescaling).
FF_HD void box_muller(std::uint32_t r0, std::uint32_t r1, std::uint32_t r2, std::uint32_t r3, double& z0,
                      double& z1) {
  const double rad = std::sqrt(-2.0 * log_positive(u01_open0(r0, r1)));
  double s, c;
  sincos_2pi(u01_open0(r2, r3), s, c);
  z0 = rad * c;
  z1 = rad * s;
}

FF_HD bool inside_truncation(double z0, double z1) {
  return (std::fabs(z0) <= kTruncation) & (std::fabs(z1) <= kTruncation);
}

// The redraws of a pair whose first draw (z0, z1) fell outside ±3: draw index
// kRedrawBase + pair·64 + t for t = 0, 1, ... (a region no first draw uses), at most 64.
FF_HD void redraw_pair(RngKey key, std::uint32_t particle, std::uint64_t step, std::uint32_t attempt,
                       std::uint32_t pair, double& z0, double& z1) {
  for (std::uint32_t t = 0; t < 64 && !inside_truncation(z0, z1); ++t) {
    const auto r = raw(key, particle, step, attempt, kRedrawBase + ((pair * 64u + t) & 0x7fffu));
    box_muller(r[0], r[1], r[2], r[3], z0, z1);
  }
}
}  // namespace rng_detail

// Uniform in (0, 1] (double), draw index `draw` (0 .. 0x7fff), two per Philox call.
FF_HD double uniform01(RngKey key, std::uint32_t particle, std::uint64_t step,
                       std::uint32_t attempt, std::uint32_t draw) {
  const auto r = rng_detail::raw(key, particle, step, attempt, draw >> 1);
  return (draw & 1) ? rng_detail::u01_open0(r[2], r[3]) : rng_detail::u01_open0(r[0], r[1]);
}

// Pair number `pair` (0 .. 0x3fff) of truncated, variance-corrected unit Gaussians.
FF_HD void gaussian_pair(RngKey key, std::uint32_t particle, std::uint64_t step,
                         std::uint32_t attempt, std::uint32_t pair, double& z0, double& z1) {
  using namespace rng_detail;
  const auto r = raw(key, particle, step, attempt, pair);
  box_muller(r[0], r[1], r[2], r[3], z0, z1);
  if (!inside_truncation(z0, z1)) redraw_pair(key, particle, step, attempt, pair, z0, z1);
  z0 *= kTruncatedVarianceScale;
  z1 *= kTruncatedVarianceScale;
}

namespace rng_detail {
// Philox4x32-10 (Random123's round and key schedule) of the counters (first + l, step, attempt
// << 16 | draw) for the lanes l < W, as plain loops over the lanes; c[word][lane].
template <int W>
inline void philox_lanes(RngKey key, std::uint32_t first, std::uint64_t step, std::uint32_t attempt,
                         std::uint32_t draw, std::uint32_t (&c)[4][W]) {
  for (int l = 0; l < W; ++l) {
    c[0][l] = first + std::uint32_t(l);
    c[1][l] = std::uint32_t(step);
    c[2][l] = std::uint32_t(step >> 32);
    c[3][l] = (attempt << 16) | draw;
  }
  std::uint32_t k0 = key.seed_lo, k1 = key.seed_hi_stage;
#if defined(__GNUC__) && !defined(__CUDACC__) && !defined(__clang__)
#pragma GCC unroll 10
#endif
  for (int round = 0; round < 10; ++round) {
    for (int l = 0; l < W; ++l) {
      const std::uint64_t p0 = std::uint64_t(0xD2511F53u) * c[0][l];
      const std::uint64_t p1 = std::uint64_t(0xCD9E8D57u) * c[2][l];
      const std::uint32_t n0 = std::uint32_t(p1 >> 32) ^ c[1][l] ^ k0;
      const std::uint32_t n2 = std::uint32_t(p0 >> 32) ^ c[3][l] ^ k1;
      c[0][l] = n0;
      c[1][l] = std::uint32_t(p1);
      c[2][l] = n2;
      c[3][l] = std::uint32_t(p0);
    }
    k0 += 0x9E3779B9u;
    k1 += 0xBB67AE85u;
  }
}

#if FF_RNG_AVX2
// The same for 16 lanes with AVX2 (GCC's generic lowering of the 32×32→64 products is mostly
// shuffles): even and odd lanes multiplied by vpmuludq, high and low halves put back by blends.
template <>
inline void philox_lanes<16>(RngKey key, std::uint32_t first, std::uint64_t step, std::uint32_t attempt,
                             std::uint32_t draw, std::uint32_t (&c)[4][16]) {
  const __m256i m0 = _mm256_set1_epi32(int(0xD2511F53u)), m1 = _mm256_set1_epi32(int(0xCD9E8D57u));
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  __m256i a[2], b[2], d[2], e[2];  // counter words 0..3, lanes 0-7 and 8-15
  for (int h = 0; h < 2; ++h) {
    a[h] = _mm256_add_epi32(_mm256_set1_epi32(int(first + 8u * h)), lane);
    b[h] = _mm256_set1_epi32(int(std::uint32_t(step)));
    d[h] = _mm256_set1_epi32(int(std::uint32_t(step >> 32)));
    e[h] = _mm256_set1_epi32(int((attempt << 16) | draw));
  }
  std::uint32_t k0 = key.seed_lo, k1 = key.seed_hi_stage;
  for (int round = 0; round < 10; ++round) {
    const __m256i kk0 = _mm256_set1_epi32(int(k0)), kk1 = _mm256_set1_epi32(int(k1));
    for (int h = 0; h < 2; ++h) {
      const __m256i p0e = _mm256_mul_epu32(a[h], m0), p0o = _mm256_mul_epu32(_mm256_srli_epi64(a[h], 32), m0);
      const __m256i p1e = _mm256_mul_epu32(d[h], m1), p1o = _mm256_mul_epu32(_mm256_srli_epi64(d[h], 32), m1);
      const __m256i lo0 = _mm256_blend_epi32(p0e, _mm256_slli_epi64(p0o, 32), 0xAA);
      const __m256i hi0 = _mm256_blend_epi32(_mm256_srli_epi64(p0e, 32), p0o, 0xAA);
      const __m256i lo1 = _mm256_blend_epi32(p1e, _mm256_slli_epi64(p1o, 32), 0xAA);
      const __m256i hi1 = _mm256_blend_epi32(_mm256_srli_epi64(p1e, 32), p1o, 0xAA);
      a[h] = _mm256_xor_si256(_mm256_xor_si256(hi1, b[h]), kk0);
      b[h] = lo1;
      d[h] = _mm256_xor_si256(_mm256_xor_si256(hi0, e[h]), kk1);
      e[h] = lo0;
    }
    k0 += 0x9E3779B9u;
    k1 += 0xBB67AE85u;
  }
  for (int h = 0; h < 2; ++h) {
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(&c[0][8 * h]), a[h]);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(&c[1][8 * h]), b[h]);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(&c[2][8 * h]), d[h]);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(&c[3][8 * h]), e[h]);
  }
}
#endif
}  // namespace rng_detail

// gaussian_pair for the W particles first .. first + W − 1, for CPU loops: Philox4x32-10 and
// Box–Muller as loops over the lanes with no branches (the compiler vectorizes them), then the
// rare lane that needs a truncation redraw (≈ 0.5 %) finished one at a time. Same numbers as
// gaussian_pair (checked in tests/test_rng.cpp).
template <int W>
inline void gaussian_pair_lanes(RngKey key, std::uint32_t first, std::uint64_t step, std::uint32_t attempt,
                                std::uint32_t pair, double* z0, double* z1) {
  using namespace rng_detail;
  std::uint32_t c[4][W];
  philox_lanes<W>(key, first, step, attempt, pair, c);
  double a0[W], a1[W];
  for (int l = 0; l < W; ++l) box_muller(c[0][l], c[1][l], c[2][l], c[3][l], a0[l], a1[l]);
  int outside = 0;
  for (int l = 0; l < W; ++l) outside |= int(!inside_truncation(a0[l], a1[l]));
  if (outside)
    for (int l = 0; l < W; ++l)
      if (!inside_truncation(a0[l], a1[l])) redraw_pair(key, first + std::uint32_t(l), step, attempt, pair, a0[l], a1[l]);
  for (int l = 0; l < W; ++l) {
    z0[l] = a0[l] * kTruncatedVarianceScale;
    z1[l] = a1[l] * kTruncatedVarianceScale;
  }
}

// `count` (≤ 4) truncated unit Gaussians for one particle, starting at pair `first_pair`.
FF_HD void gaussians(RngKey key, std::uint32_t particle, std::uint64_t step, std::uint32_t attempt,
                     std::uint32_t first_pair, int count, double* out) {
  double z0, z1;
  gaussian_pair(key, particle, step, attempt, first_pair, z0, z1);
  out[0] = z0;
  if (count > 1) out[1] = z1;
  if (count > 2) {
    gaussian_pair(key, particle, step, attempt, first_pair + 1, z0, z1);
    out[2] = z0;
    if (count > 3) out[3] = z1;
  }
}

}  // namespace ff
