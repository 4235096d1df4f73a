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
// displacement in a step, which keeps the triangulation repairable. GaussianTail::clamped is
// Carter et al. 2017's variant instead (§2.4, seed-gaps C2): each number clamped to ±3, no redraw
// and no rescaling (variance 0.99501: the tails become point masses at ±3).
//
// Box–Muller's log and sincos are core/physics/math.h's (musl's fdlibm polynomials, < 1 ulp), not the
// platform's libm: branch-free code that a CPU loop vectorizes over particles, the same on both
// backends, and sincos(2πu) needs no general range reduction because u ∈ (0, 1] reduces exactly
// to a quadrant. The numbers are the same bits on every path (gaussian_pair_lanes in the host
// loops, gaussian_pair per thread on CUDA) as long as no translation unit contracts a·b + c
// into fma: the CPU loops are built with -ffp-contract=off, the CUDA loops with -fmad=false.
#pragma once
#include <Random123/philox.h>

#include <cmath>
#include <cstdint>
#include <cstring>

#include "core/base/hd.h"
#include "core/physics/math.h"

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

// The elementary functions are core/physics/math.h's, shared with the physics kernels.
using math::log_positive;

// cos(2πu) and sin(2πu) for u in [0, 1]: 4u = q + r exactly (q = rint(4u), |r| ≤ 1/2), then
// the sin/cos kernels of core/physics/math.h at x = r·π/2 (exact argument, no general reduction) and
// the quadrant q.
FF_HD void sincos_2pi(double u, double& s_out, double& c_out) {
  constexpr double kHalfPi = 1.5707963267948966;
  const double t = 4.0 * u;
  const double q = std::rint(t);
  const double x = (t - q) * kHalfPi;
  math::quadrant_sincos(int(q), math::kernel_sin(x), math::kernel_cos(x), s_out, c_out);
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

// z clamped to [−3, 3] (comparisons and selects only: the same bits everywhere).
FF_HD double clamp_to_truncation(double z) { return z < -kTruncation ? -kTruncation : (z > kTruncation ? kTruncation : z); }

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

// How a Gaussian pair is kept within ±3: rescaled (flipflow's default): a pair with a member
// outside is redrawn, then both are scaled to unit variance; clamped (Carter et al. 2017 §2.4,
// their "method b"): each member clamped to ±3, neither redrawn nor rescaled, variance
// (1 − p) − 6φ(3) + 9p = 0.99501, p = P(|z| > 3) = 0.0027. Either way |z| ≤ kLargestGaussian.
enum class GaussianTail : std::uint8_t { rescaled, clamped };

// Uniform in (0, 1] (double), draw index `draw` (0 .. 0x7fff), two per Philox call.
FF_HD double uniform01(RngKey key, std::uint32_t particle, std::uint64_t step,
                       std::uint32_t attempt, std::uint32_t draw) {
  const auto r = rng_detail::raw(key, particle, step, attempt, draw >> 1);
  return (draw & 1) ? rng_detail::u01_open0(r[2], r[3]) : rng_detail::u01_open0(r[0], r[1]);
}

// The largest magnitude a Gaussian of gaussian_pair can have (the truncation times the variance
// correction, 3.0408...): what bounds a step's displacement (delaunay.dt_bound).
constexpr double kLargestGaussian = rng_detail::kTruncation * rng_detail::kTruncatedVarianceScale;

// Pair number `pair` (0 .. 0x3fff) of truncated, variance-corrected unit Gaussians (or, with
// GaussianTail::clamped, of unit Gaussians clamped to ±3).
FF_HD void gaussian_pair(RngKey key, std::uint32_t particle, std::uint64_t step,
                         std::uint32_t attempt, std::uint32_t pair, double& z0, double& z1,
                         GaussianTail tail = GaussianTail::rescaled) {
  using namespace rng_detail;
  const auto r = raw(key, particle, step, attempt, pair);
  box_muller(r[0], r[1], r[2], r[3], z0, z1);
  if (tail == GaussianTail::clamped) {
    z0 = clamp_to_truncation(z0);
    z1 = clamp_to_truncation(z1);
    return;
  }
  if (!inside_truncation(z0, z1)) redraw_pair(key, particle, step, attempt, pair, z0, z1);
  z0 *= kTruncatedVarianceScale;
  z1 *= kTruncatedVarianceScale;
}

namespace rng_detail {
// Philox4x32-10 (Random123's round and key schedule) of the counters (first + l, step, attempt
// << 16 | draw) for the lanes l < W, as plain loops over the lanes; c[word][lane]. With
// `particle` set, lane l's particle is particle[l] instead of first + l.
template <int W>
inline void philox_lanes(RngKey key, std::uint32_t first, std::uint64_t step, std::uint32_t attempt,
                         std::uint32_t draw, std::uint32_t (&c)[4][W], const std::uint32_t* particle = nullptr) {
  for (int l = 0; l < W; ++l) {
    c[0][l] = particle ? particle[l] : first + std::uint32_t(l);
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
                             std::uint32_t draw, std::uint32_t (&c)[4][16], const std::uint32_t* particle) {
  const __m256i m0 = _mm256_set1_epi32(int(0xD2511F53u)), m1 = _mm256_set1_epi32(int(0xCD9E8D57u));
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  __m256i a[2], b[2], d[2], e[2];  // counter words 0..3, lanes 0-7 and 8-15
  for (int h = 0; h < 2; ++h) {
    a[h] = particle ? _mm256_loadu_si256(reinterpret_cast<const __m256i*>(particle + 8 * h))
                    : _mm256_add_epi32(_mm256_set1_epi32(int(first + 8u * h)), lane);
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

namespace rng_detail {
template <int W>
inline void gaussian_pair_lanes_impl(RngKey key, std::uint32_t first, const std::uint32_t* particle,
                                     std::uint64_t step, std::uint32_t attempt, std::uint32_t pair, double* z0,
                                     double* z1, GaussianTail tail) {
  std::uint32_t c[4][W];
  philox_lanes<W>(key, first, step, attempt, pair, c, particle);
  double a0[W], a1[W];
  for (int l = 0; l < W; ++l) box_muller(c[0][l], c[1][l], c[2][l], c[3][l], a0[l], a1[l]);
  if (tail == GaussianTail::clamped) {
    for (int l = 0; l < W; ++l) {
      z0[l] = clamp_to_truncation(a0[l]);
      z1[l] = clamp_to_truncation(a1[l]);
    }
    return;
  }
  int outside = 0;
  for (int l = 0; l < W; ++l) outside |= int(!inside_truncation(a0[l], a1[l]));
  if (outside)
    for (int l = 0; l < W; ++l)
      if (!inside_truncation(a0[l], a1[l]))
        redraw_pair(key, particle ? particle[l] : first + std::uint32_t(l), step, attempt, pair, a0[l], a1[l]);
  for (int l = 0; l < W; ++l) {
    z0[l] = a0[l] * kTruncatedVarianceScale;
    z1[l] = a1[l] * kTruncatedVarianceScale;
  }
}
}  // namespace rng_detail

// gaussian_pair for the W particles first .. first + W − 1, for CPU loops: Philox4x32-10 and
// Box–Muller as loops over the lanes with no branches (the compiler vectorizes them), then the
// rare lane that needs a truncation redraw (≈ 0.5 %) finished one at a time. Same numbers as
// gaussian_pair (checked in tests/test_rng.cpp).
template <int W>
inline void gaussian_pair_lanes(RngKey key, std::uint32_t first, std::uint64_t step, std::uint32_t attempt,
                                std::uint32_t pair, double* z0, double* z1,
                                GaussianTail tail = GaussianTail::rescaled) {
  rng_detail::gaussian_pair_lanes_impl<W>(key, first, nullptr, step, attempt, pair, z0, z1, tail);
}

// The same for the W particles particle[0 .. W − 1], any numbers (a decomposed team's rank draws
// for its particles' global ids, core/physics/overdamped.h's NoiseCounter::id).
template <int W>
inline void gaussian_pair_lanes_of(RngKey key, const std::uint32_t* particle, std::uint64_t step,
                                   std::uint32_t attempt, std::uint32_t pair, double* z0, double* z1,
                                   GaussianTail tail = GaussianTail::rescaled) {
  rng_detail::gaussian_pair_lanes_impl<W>(key, 0, particle, step, attempt, pair, z0, z1, tail);
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
