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
#pragma once
#include <Random123/philox.h>

#include <cmath>
#include <cstdint>

#include "core/hd.h"

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
constexpr double kTwoPi = 6.283185307179586;

FF_HD r123::Philox4x32::ctr_type raw(RngKey key, std::uint32_t particle, std::uint64_t step,
                                     std::uint32_t attempt, std::uint32_t draw) {
  r123::Philox4x32 philox;
  r123::Philox4x32::key_type k = {{key.seed_lo, key.seed_hi_stage}};
  r123::Philox4x32::ctr_type c = {
      {particle, std::uint32_t(step), std::uint32_t(step >> 32), (attempt << 16) | draw}};
  return philox(c, k);
}

// Uniform in (0, 1]: never 0, so log() in Box–Muller is finite.
FF_HD double u01_open0(std::uint32_t hi, std::uint32_t lo) {
  const std::uint64_t bits = (std::uint64_t(hi) << 21) ^ (lo >> 11);  // 53 bits
  return (double((bits & ((std::uint64_t(1) << 53) - 1))) + 1.0) * (1.0 / 9007199254740992.0);
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
  std::uint32_t draw = pair;
  for (std::uint32_t tries = 0;; ++tries) {
    const auto r = raw(key, particle, step, attempt, draw);
    const double u1 = u01_open0(r[0], r[1]);
    const double u2 = u01_open0(r[2], r[3]);
    const double rad = std::sqrt(-2.0 * std::log(u1));
    z0 = rad * std::cos(kTwoPi * u2);
    z1 = rad * std::sin(kTwoPi * u2);
    if ((std::fabs(z0) <= kTruncation && std::fabs(z1) <= kTruncation) || tries >= 64) break;
    // Redraws walk a region no first draw uses: kRedrawBase + pair * 64 + tries.
    draw = kRedrawBase + ((pair * 64u + tries) & 0x7fffu);
  }
  z0 *= kTruncatedVarianceScale;
  z1 *= kTruncatedVarianceScale;
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
