// Philox Gaussians: moments, truncation, determinism, independence of attempts and stages.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstring>

#include <oneapi/tbb/global_control.h>

#include <vector>

#include "core/backend/overdamped_cpu.h"
#include "core/physics/rng.h"

using namespace ff;

TEST_CASE("truncated Gaussians have zero mean and unit variance", "[rng]") {
  const RngKey key = make_rng_key(12345, "brownian.integrate");
  const std::uint32_t n = 1u << 20;
  double sum = 0, sum2 = 0, sum4 = 0, max_abs = 0;
  for (std::uint32_t i = 0; i < n / 2; ++i) {
    double z0, z1;
    gaussian_pair(key, i, 7, 0, 0, z0, z1);
    for (double z : {z0, z1}) {
      sum += z;
      sum2 += z * z;
      sum4 += z * z * z * z;
      max_abs = std::max(max_abs, std::fabs(z));
    }
  }
  const double mean = sum / n, var = sum2 / n - mean * mean;
  // Standard errors: mean 1/sqrt(n); variance sqrt((m4 - 1)/n) with m4 ≈ 2.8 for this law.
  CHECK(std::fabs(mean) < 5.0 / std::sqrt(double(n)));
  CHECK(std::fabs(var - 1.0) < 5.0 * std::sqrt(1.9 / n));
  // Truncated at 3σ of the unit normal, then scaled by 1/sqrt(var_3).
  CHECK(max_abs <= 3.0 * 1.013604197642207 + 1e-12);
  CHECK(max_abs > 2.9);
  // The kurtosis of a normal truncated at ±3 (rescaled) is below 3: it is not a plain normal.
  const double kurt = (sum4 / n) / (var * var);
  CHECK(kurt < 2.95);
  CHECK(kurt > 2.7);
}

TEST_CASE("uniforms lie in (0,1] with mean 1/2", "[rng]") {
  const RngKey key = make_rng_key(1, "init");
  const std::uint32_t n = 1u << 18;
  double sum = 0, lo = 1, hi = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    const double u = uniform01(key, i, 0, 0, 0);
    sum += u;
    lo = std::min(lo, u);
    hi = std::max(hi, u);
  }
  CHECK(lo > 0.0);
  CHECK(hi <= 1.0);
  CHECK(std::fabs(sum / n - 0.5) < 5.0 * std::sqrt(1.0 / 12 / n));
}

TEST_CASE("same counter, same numbers; attempt, step, stage and seed change them", "[rng]") {
  const RngKey a = make_rng_key(42, "abp.integrate");
  double x0, x1, y0, y1;
  gaussian_pair(a, 5, 100, 0, 0, x0, x1);
  gaussian_pair(a, 5, 100, 0, 0, y0, y1);
  CHECK(x0 == y0);
  CHECK(x1 == y1);
  gaussian_pair(a, 5, 100, 1, 0, y0, y1);  // a retried step draws fresh numbers
  CHECK(x0 != y0);
  gaussian_pair(a, 5, 101, 0, 0, y0, y1);
  CHECK(x0 != y0);
  gaussian_pair(make_rng_key(42, "other.stage"), 5, 100, 0, 0, y0, y1);
  CHECK(x0 != y0);
  gaussian_pair(make_rng_key(43, "abp.integrate"), 5, 100, 0, 0, y0, y1);
  CHECK(x0 != y0);
  // Seeds that differ only in the high word differ too.
  gaussian_pair(make_rng_key(42 + (std::uint64_t(1) << 32), "abp.integrate"), 5, 100, 0, 0, y0, y1);
  CHECK(x0 != y0);
}

TEST_CASE("consecutive pairs of one particle are uncorrelated", "[rng]") {
  const RngKey key = make_rng_key(9, "s");
  const std::uint32_t n = 1u << 18;
  double c = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    double a0, a1, b0, b1;
    gaussian_pair(key, i, 3, 0, 0, a0, a1);
    gaussian_pair(key, i, 3, 0, 1, b0, b1);
    c += a0 * b0 + a1 * b1;
  }
  CHECK(std::fabs(c / (2.0 * n)) < 5.0 / std::sqrt(2.0 * n));
}

TEST_CASE("the lanes of gaussian_pair_lanes equal gaussian_pair, redraws included", "[rng]") {
  // The CPU integrators draw 16 particles at once; every lane must give gaussian_pair's bits.
  const RngKey key = make_rng_key(2024, "brownian.integrate");
  std::size_t mismatches = 0, redrawn = 0;
  for (std::uint64_t step : {std::uint64_t(0), std::uint64_t(123456789012345)}) {
    for (std::uint32_t pair : {0u, 3u}) {
      for (std::uint32_t first = 7; first < 7 + (1u << 16); first += 16) {
        double z0[16], z1[16];
        gaussian_pair_lanes<16>(key, first, step, 2, pair, z0, z1);
        for (std::uint32_t l = 0; l < 16; ++l) {
          double a0, a1;
          gaussian_pair(key, first + l, step, 2, pair, a0, a1);
          mismatches += (a0 != z0[l]) || (a1 != z1[l]);
          const auto r = rng_detail::raw(key, first + l, step, 2, pair);
          rng_detail::box_muller(r[0], r[1], r[2], r[3], a0, a1);
          redrawn += !rng_detail::inside_truncation(a0, a1);
        }
      }
    }
  }
  CHECK(mismatches == 0);
  CHECK(redrawn > 1000);  // ≈ 0.5 % of the 2^18 pairs took the redraw path
}

TEST_CASE("gaussian_pair_lanes_of: lanes for any particle numbers equal gaussian_pair", "[rng]") {
  // A decomposed team's rank draws for its particles' global ids, in no particular pattern.
  const RngKey key = make_rng_key(7, "overdamped.integrate");
  std::size_t mismatches = 0, redrawn = 0;
  std::uint32_t next = 12345;
  for (int block = 0; block < (1 << 14); ++block) {
    std::uint32_t ids[16];
    for (auto& id : ids) id = next = next * 1664525u + 1013904223u;  // scattered, any value
    for (GaussianTail tail : {GaussianTail::rescaled, GaussianTail::clamped}) {
      double z0[16], z1[16];
      gaussian_pair_lanes_of<16>(key, ids, 99, 1, 2, z0, z1, tail);
      for (int l = 0; l < 16; ++l) {
        double a0, a1;
        gaussian_pair(key, ids[l], 99, 1, 2, a0, a1, tail);
        mismatches += (a0 != z0[l]) || (a1 != z1[l]);
        if (tail == GaussianTail::rescaled) {
          const auto r = rng_detail::raw(key, ids[l], 99, 1, 2);
          rng_detail::box_muller(r[0], r[1], r[2], r[3], a0, a1);
          redrawn += !rng_detail::inside_truncation(a0, a1);
        }
      }
    }
  }
  CHECK(mismatches == 0);
  CHECK(redrawn > 500);  // ≈ 0.5 % of the 2^18 pairs took the redraw path
}

TEST_CASE("clamped Gaussians (Carter's variant): ±3 point masses, variance 0.99501, lanes = scalar", "[rng]") {
  // GaussianTail::clamped: Box–Muller's numbers clamped to ±3, not redrawn, not rescaled. Where
  // the first draw is inside ±3 it is the rescaled variant's number before its scaling.
  const RngKey key = make_rng_key(99, "phoretic.integrate");
  const std::uint32_t pairs = 1u << 21;  // 2^22 numbers
  double sum = 0, sum2 = 0;
  std::size_t at_edge = 0, mismatches = 0, unscaled = 0, beyond = 0;
  for (std::uint32_t first = 0; first < pairs; first += 16) {
    double z0[16], z1[16];
    gaussian_pair_lanes<16>(key, first, 5, 0, 1, z0, z1, GaussianTail::clamped);
    for (std::uint32_t l = 0; l < 16; ++l) {
      double a0, a1, r0, r1;
      gaussian_pair(key, first + l, 5, 0, 1, a0, a1, GaussianTail::clamped);
      mismatches += (a0 != z0[l]) || (a1 != z1[l]);
      gaussian_pair(key, first + l, 5, 0, 1, r0, r1);
      if (std::fabs(a0) < 3 && std::fabs(a1) < 3)
        unscaled += (r0 != a0 * rng_detail::kTruncatedVarianceScale) || (r1 != a1 * rng_detail::kTruncatedVarianceScale);
      for (double z : {a0, a1}) {
        sum += z;
        sum2 += z * z;
        at_edge += std::fabs(z) == 3.0;
        beyond += std::fabs(z) > 3.0;
      }
    }
  }
  const double n = 2.0 * pairs, var = sum2 / n - (sum / n) * (sum / n);
  CHECK(mismatches == 0);
  CHECK(unscaled == 0);
  CHECK(beyond == 0);
  // P(|z| > 3) = 0.0026998: the point masses at ±3 (standard error sqrt(p/n) relative ≈ 1 %).
  CHECK(at_edge / n == Approx(0.0026998).epsilon(0.05));
  // (1 − p) − 6φ(3) + 9p = 0.995007, p = P(|z| > 3); standard error sqrt(1.9/n) = 0.0007: 1 is 7 errors away.
  CHECK(std::fabs(var - 0.995007) < 5.0 * std::sqrt(1.9 / n));
}

TEST_CASE("Box–Muller's own log and sincos(2πu) agree with libm to an ulp or two", "[rng]") {
  // rng_detail::log_positive and sincos_2pi replace std::log / std::sincos so the lanes
  // vectorize; check them on the uniforms they actually get and at the ends of (0, 1].
  using namespace rng_detail;
  const RngKey key = make_rng_key(5, "check");
  auto ulps = [](double a, double b) {
    std::int64_t x, y;
    std::memcpy(&x, &a, 8);
    std::memcpy(&y, &b, 8);
    return x > y ? x - y : y - x;
  };
  std::int64_t worst_log = 0;
  double worst_trig = 0;
  for (std::uint32_t i = 0; i < (1u << 18); ++i) {
    const auto r = raw(key, i, 0, 0, 0);
    const double u = u01_open0(r[0], r[1]), v = u01_open0(r[2], r[3]);
    worst_log = std::max(worst_log, ulps(log_positive(u), std::log(u)));
    double s, c;
    sincos_2pi(v, s, c);
    // 2πv in long double is good to ~1e-19 absolute, so compare absolutely.
    const long double a = 6.283185307179586476925286766559L * static_cast<long double>(v);
    worst_trig = std::max({worst_trig, std::fabs(s - double(std::sin(a))), std::fabs(c - double(std::cos(a)))});
  }
  CHECK(worst_log <= 1);
  CHECK(worst_trig <= 2.3e-16);
  CHECK(log_positive(1.0) == 0.0);
  CHECK(log_positive(std::ldexp(1.0, -53)) == std::log(std::ldexp(1.0, -53)));
  double s, c;
  sincos_2pi(1.0, s, c);
  CHECK((s == 0.0 && c == 1.0));
  sincos_2pi(0.25, s, c);
  CHECK((s == 1.0 && c == 0.0));
  sincos_2pi(0.5, s, c);
  CHECK((s == 0.0 && c == -1.0));
}

TEST_CASE("Philox lanes (AVX2 for 16 where the build has it, generic otherwise) equal Random123", "[rng]") {
  const RngKey key = make_rng_key(77, "lanes");
  INFO("AVX2 Philox lanes: " << FF_RNG_AVX2);
  std::size_t mismatches = 0;
  for (std::uint64_t step : {std::uint64_t(3), std::uint64_t(0xfedcba9876543ull)}) {
    for (std::uint32_t first = 0xfffff000u; first != 0x1000u; first += 16) {  // wraps past 2^32
      std::uint32_t c16[4][16], c8[4][8];
      rng_detail::philox_lanes<16>(key, first, step, 5, 0x8123, c16);
      rng_detail::philox_lanes<8>(key, first, step, 5, 0x8123, c8);
      for (std::uint32_t l = 0; l < 16; ++l) {
        const auto r = rng_detail::raw(key, first + l, step, 5, 0x8123);
        for (int w = 0; w < 4; ++w) mismatches += r[w] != c16[w][l] || (l < 8 && r[w] != c8[w][l]);
      }
    }
  }
  CHECK(mismatches == 0);
}

namespace {
// An overdamped functor that only records its noise (pairs 1 and 4, as an integrator with
// noise pairs that are not consecutive would), to test the CPU loop's lanes against the
// per-particle path the CUDA loop takes.
struct RecordNoise {
  double* out;  // N x 4
  RngKey key;
  std::uint64_t step;
  std::uint32_t attempt;
  static constexpr int kNoisePairs = 2;
  std::uint32_t noise_pair(int j) const { return j == 0 ? 1u : 4u; }
  NoiseCounter noise_counter() const { return {key, step, attempt}; }
  void move(std::size_t i, const double* z) const {
    for (int k = 0; k < 4; ++k) out[i * 4 + k] = z[k];
  }
};
}  // namespace

TEST_CASE("the CPU overdamped loop gives every particle its own noise for any N and thread count", "[rng]") {
  // N not a multiple of the 16-particle block (padded last block) and more than one task.
  const std::size_t n = (std::size_t(1) << 15) + 37;
  std::vector<double> expect(4 * n);
  const RecordNoise ref{expect.data(), make_rng_key(3, "loop"), 77, 1};
  for (std::size_t i = 0; i < n; ++i) overdamped_step(ref, i);
  for (int threads : {1, 2, 3}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    std::vector<double> got(4 * n, -100.0);
    cpu_overdamped_for_each(n, RecordNoise{got.data(), ref.key, ref.step, ref.attempt}, nullptr);
    std::size_t mismatches = 0;
    for (std::size_t k = 0; k < 4 * n; ++k) mismatches += got[k] != expect[k];
    INFO("threads " << threads);
    CHECK(mismatches == 0);
  }
  // Both builds of the block loop: the build's own ISA, and x86-64-v4 where this CPU has it
  // (core/backend/overdamped_cpu.h); the default above is the second on such a CPU.
  for (const bool v4 : {false, true}) {
    if (v4 && !cpu_has_x86_64_v4()) {
      WARN("no x86-64-v4 (AVX-512) on this CPU, or FLIPFLOW_NO_AVX512 set: its block loop is not tested here");
      continue;
    }
    std::vector<double> got(4 * n, -100.0);
    cpu_overdamped_loop(n, RecordNoise{got.data(), ref.key, ref.step, ref.attempt}, v4);
    std::size_t mismatches = 0;
    for (std::size_t k = 0; k < 4 * n; ++k) mismatches += got[k] != expect[k];
    INFO("x86-64-v4 blocks " << v4);
    CHECK(mismatches == 0);
  }
}
