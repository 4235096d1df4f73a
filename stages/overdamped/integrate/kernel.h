// The overdamped (Euler–Maruyama) step with drift, per particle i of type t:
//   x += (v_i + μ_t F_i) Δt + sqrt(2 D_t Δt) ξ,   then wrapped into the box (image counted),
// v the `velocity` field and F the `force` field when the stage reads them, ξ truncated unit
// Gaussians (core/physics/rng.h; rescaled, or clamped with `noise: clamp`). Δt, the step and the attempt come from StepParams on the side
// the loop runs on (never by value: a captured CUDA graph replays the step). OverdampedStep is
// the step other integrators reuse with a drift of their own (abp.integrate). nvcc-clean.
#pragma once
#include <cmath>
#include <cstdint>
#include <type_traits>
#include <utility>

#include "core/backend/atomics.h"
#include "core/physics/box.h"
#include "core/base/hd.h"
#include "core/physics/overdamped.h"
#include "core/physics/rng.h"
#include "core/stage/step_params.h"
#include "stages/neighbors/verlet/kernel.h"

namespace ff::overdamped {

inline constexpr int kMaxTypes = 16;

// The non-finite check every overdamped step makes (finite_check.h holds the host's side). A
// particle whose position, or a field its drift moves (abp.integrate's orientation), is not
// finite after its step is reported here; nothing is touched while every value is finite, so in
// the good case the check costs a subtract and a compare per value and no memory traffic.
//  - counters (the backend's memory): the step and attempt of the first report, and how many
//    particles were found in that step and attempt and the lowest of them. Only that step counts:
//    on CUDA the host learns of a report a few steps later, and the particles stay non-finite in
//    the steps between (kBadKey, claimed by the first report, tells them apart);
//  - published: one word of host memory (pinned on CUDA: the kernel writes it directly) set to 1,
//    which the host reads every step without waiting for the device.
enum NonFiniteSlot : int { kBadCount, kBadFirst, kBadStepLow, kBadStepHigh, kBadAttempt, kBadKey, kNonFiniteSlots };

struct NonFiniteReport {
  unsigned* counters = nullptr;   // kNonFiniteSlots, kBadFirst starting at ~0u; null: no check
  unsigned* published = nullptr;  // host-visible

  FF_HD void report(std::size_t i, const StepParams* p) const {
    // The step and attempt as one nonzero word: unique within any 2^27 steps and 16 attempts,
    // far more than the host can fall behind (finite_check.h: at most 2 × kPace steps).
    const unsigned key = unsigned(p->step) << 5 | (p->attempt & 15u) << 1 | 1u;
    const unsigned claimed = compare_and_swap(counters + kBadKey, 0u, key);
    if (claimed != 0u && claimed != key) return;  // a later step than the one reported
    if (claimed == 0u) {
      counters[kBadStepLow] = unsigned(p->step);
      counters[kBadStepHigh] = unsigned(p->step >> 32);
      counters[kBadAttempt] = p->attempt;
    }
    count_one(counters + kBadCount);
    keep_min(counters + kBadFirst, unsigned(i));
#if defined(__CUDA_ARCH__)
    __threadfence_system();
    *static_cast<volatile unsigned*>(published) = 1u;
#else
    __atomic_store_n(published, 1u, __ATOMIC_RELEASE);
#endif
  }
};

// Whether x[0 .. n-1] are all finite: x - x is 0 for a finite x and NaN for a NaN or an
// infinity. No branch, an OR of compares: the CPU loop's check of a block vectorises.
template <class R>
FF_HD bool all_finite(const R* x, std::size_t n) {
  unsigned bad = 0;
  for (std::size_t k = 0; k < n; ++k) bad |= unsigned(!(x[k] - x[k] == R(0)));
  return bad == 0;
}

// A drift that moves fields of its own (abp.integrate's orientation) may say whether particles
// [first, first + count) have finite values there after their step:
// `FF_HD bool finite(std::size_t first, std::size_t count) const`. Optional.
template <class G, class = void>
struct DriftChecksFinite : std::false_type {};
template <class G>
struct DriftChecksFinite<G, std::void_t<decltype(std::declval<const G&>().finite(std::size_t{}, std::size_t{}))>>
    : std::true_type {};

// The drift of overdamped.integrate (a drift functor, core/physics/overdamped.h): (v + μ_t F) Δt
// from the `velocity` and `force` fields, each when set; none when neither is.
template <class R, int D>
struct FieldDrift {
  const R* velocity;           // N x D, or null: no drift velocity
  const R* force;              // N x D, or null: no force
  double mobility[kMaxTypes];  // μ_t

  static constexpr int kNoisePairs = 0;
  FF_HD std::uint32_t noise_pair(int) const { return 0; }
  FF_HD bool operator()(std::size_t i, int t, double dt, const double*, R* drift) const {
    if (!velocity && !force) return false;
    const R h = R(dt);
    const R mu = R(mobility[t]);
    for (int k = 0; k < D; ++k) {
      R v = velocity ? velocity[i * D + k] : R(0);
      if (force) v = velocity ? v + mu * force[i * D + k] : mu * force[i * D + k];
      drift[k] = v * h;
    }
    return true;
  }
};

// The overdamped step every integrator shares, per particle i of type t:
//   x += drift + sqrt(2 D_t Δt) ξ,   then wrapped into the box (image counted),
// the drift from the functor G (core/physics/overdamped.h): FieldDrift for overdamped.integrate,
// abp.integrate's self-propulsion, none (NoDrift) for free diffusion.
//
// General = false: one D for every type, no max_step check: free Brownian motion, whose CPU loop
// must stay as lean as the plain step (a per-particle type lookup or branch in the element math
// keeps it from vectorizing), and models that bring their own drift. General = true: the type
// tables when `type` is set, the check when `too_far` is. InPlace = false: particle i is read
// from (position_in, image_in), for a stage that hands the snapshot the field's storage
// (StepContext::will_overwrite); in place, reads and writes go through the same pointers, so the
// compiler knows they do not overlap and vectorizes the CPU loop's moves across particles.
template <class R, int D, bool General, class G = NoDrift, bool InPlace = true>
struct OverdampedStep {
  // InPlace = false: the step reads particle i from (position_in, image_in) and writes it to
  // (position, image): the previous step's arrays kept by the rollback snapshot, or the same ones.
  const R* position_in;                // N x D (InPlace = false)
  const std::int32_t* image_in;        // N x D (InPlace = false)
  R* position;                         // N x D
  std::int32_t* image;                 // N x D
  const std::int32_t* type;            // N, or null: every particle uses entry 0 (General only)
  double two_D[General ? kMaxTypes : 1];  // 2 D_t
  PeriodicBox<R> box;
  RngKey key;
  GaussianTail tail = GaussianTail::rescaled;  // `noise`: rescaled, or clamped as Carter et al.
  const std::uint32_t* id = nullptr;  // the noise's particle numbers (NoiseCounter::id); null: the index
  const StepParams* params;
  G drift;
  // With max_step (General only): steps longer than it are counted in too_far[0], the lowest
  // such particle kept in too_far[1] (the stage then asks for a rollback); particles whose
  // position at the start of the step or whose step is not finite in too_far[2] and [3] (the
  // stage then stops the run: a smaller Δt cannot mend a NaN force); null: no check.
  unsigned* too_far = nullptr;
  double max_step2 = 0;
  // With max_step, where a Verlet list is kept (stages/neighbors/list.h, neighbors.moved): its
  // rebuild test on the new positions — neighbors.verlet's own functor, reading `position` after
  // the move — counting particles farther than skin/2 from their build positions in *moved (on
  // the CPU at most one a block: after_moves). Null: no test.
  unsigned* moved = nullptr;
  neighbors::MovedTooFar<R, D> list_test{};
  // Particles whose position, or whose drift's own fields, are not finite after the step
  // (NonFiniteReport above; the stages always set it).
  NonFiniteReport non_finite;

  static constexpr int kTranslationPairs = (D + 1) / 2;  // pairs 0 (and 1 in 3D); G's follow
  static constexpr int kNoisePairs = kTranslationPairs + G::kNoisePairs;
  FF_HD std::uint32_t noise_pair(int j) const {
    return j < kTranslationPairs ? std::uint32_t(j) : drift.noise_pair(j - kTranslationPairs);
  }
  FF_HD NoiseCounter noise_counter() const { return {key, params->step, params->attempt, tail, id}; }

  // z: the particle's Gaussians, z[k] for component k, then the drift's pairs.
  FF_HD void move(std::size_t i, const double* z) const {
    const int t = General && type ? type[i] : 0;
    const double dt = params->dt;
    const R amplitude = R(std::sqrt(two_D[t] * dt));  // sqrt(2 D_t Δt)
    R d[D];
    const R* by = drift(i, t, dt, z + 2 * kTranslationPairs, d) ? d : nullptr;
    if constexpr (General) {
      if (too_far) check(i, by, amplitude, z);
    }
    if constexpr (InPlace) overdamped_move<R, D>(position, image, box, i, by, amplitude, z);
    else overdamped_move<R, D>(position_in, image_in, position, image, box, i, by, amplitude, z);
  }
  // The non-finite check of particles [first, first + count) after their moves (NonFiniteReport).
  FF_HD bool finite(std::size_t first, std::size_t count) const {
    bool ok = all_finite(position + first * D, count * D);
    if constexpr (DriftChecksFinite<G>::value) ok = ok & drift.finite(first, count);
    return ok;
  }
  // The step's length against max_step (the move itself is made regardless: a step that fails
  // the check is rolled back or stops the run). Written so that NaN, which compares false with
  // everything, fails it: !(len2 <= max) and x − x == 0 (false for NaN and ±inf).
  FF_HD void check(std::size_t i, const R* by, R amplitude, const double* z) const {
    double len2 = 0, start = 0;
    for (int k = 0; k < D; ++k) {
      const double d = (by ? double(by[k]) : 0.0) + double(amplitude) * z[k];
      len2 += d * d;
      start += double((InPlace ? position : position_in)[i * D + k]);  // check runs before the move
    }
    if (len2 <= max_step2 && start - start == 0) return;
    unsigned* slot = len2 - len2 == 0 && start - start == 0 ? too_far : too_far + 2;
    count_one(slot);
    keep_min(slot + 1, unsigned(i));
  }
  // The GPU loop's element operation: the step, then the check.
  FF_HD void operator()(std::size_t i) const {
    overdamped_step(*this, i);
    if (non_finite.counters && !finite(i, 1)) non_finite.report(i, params);
    if constexpr (General) {
      if (moved && list_test(i)) count_one(moved);
    }
  }
  // The CPU loop's check, once per block of particles [first, first + count) after their moves
  // (core/physics/overdamped.h): one pass over values still in L1 whose compares vectorise,
  // where a branch inside move() would keep the compiler from vectorising the moves.
  // With a Verlet list's test (moved), the block's particles are tested there too, while they
  // are in L1; only whether the count is zero is read (neighbors.moved), so a block stops
  // counting at its first particle beyond skin/2.
  void after_moves(std::size_t first, std::size_t count) const {
    if constexpr (General) {
      if (moved)
        for (std::size_t l = 0; l < count; ++l)
          if (list_test(first + l)) {
            count_one(moved);
            break;
          }
    }
    if (!non_finite.counters || finite(first, count)) return;
    for (std::size_t l = 0; l < count; ++l)
      if (!finite(first + l, 1)) non_finite.report(first + l, params);
  }
};

}  // namespace ff::overdamped
