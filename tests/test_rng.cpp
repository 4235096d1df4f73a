// Philox Gaussians: moments, truncation, determinism, independence of attempts and stages.
#include <catch2/catch.hpp>
#include <cmath>

#include "core/rng.h"

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
