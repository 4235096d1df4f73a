// The overdamped (Euler–Maruyama) step with drift, per particle i of type t:
//   x += (v_i + μ_t F_i) Δt + sqrt(2 D_t Δt) ξ,   then wrapped into the box (image counted),
// v the `velocity` field and F the `force` field when the stage reads them, ξ truncated unit
// Gaussians (core/physics/rng.h). Δt, the step and the attempt come from StepParams on the side the loop
// runs on. nvcc-clean.
#pragma once
#include <cmath>
#include <cstdint>

#include "core/backend/atomics.h"
#include "core/physics/box.h"
#include "core/base/hd.h"
#include "core/physics/overdamped.h"
#include "core/physics/rng.h"
#include "core/stage/step_params.h"

namespace ff::overdamped {

inline constexpr int kMaxTypes = 16;

// General = false: noise only, one D for every type, no max_step check — free Brownian motion,
// whose CPU loop must stay as lean as the plain step (a per-particle type lookup or branch in
// the element math keeps it from vectorizing). General = true: everything the members say
// (type tables when `type` is set, drift when `velocity` or `force` is, the check when
// `too_far` is).
template <class R, int D, bool General>
struct OverdampedStep {
  R* position;                // N x D
  std::int32_t* image;        // N x D
  const R* velocity;          // N x D, or null: no drift velocity
  const R* force;             // N x D, or null: no force
  const std::int32_t* type;   // N, or null: every particle uses entry 0 of the tables
  double two_D[kMaxTypes];    // 2 D_t
  double mobility[kMaxTypes]; // μ_t
  PeriodicBox<R> box;
  RngKey key;
  const StepParams* params;
  // With max_step (General only): steps longer than it are counted in too_far[0], the lowest
  // such particle kept in too_far[1] (the stage then asks for a rollback); null: no check.
  unsigned* too_far = nullptr;
  double max_step2 = 0;

  static constexpr int kNoisePairs = (D + 1) / 2;  // pairs 0 (and 1 in 3D)
  FF_HD std::uint32_t noise_pair(int j) const { return std::uint32_t(j); }
  FF_HD NoiseCounter noise_counter() const { return {key, params->step, params->attempt}; }

  // z: the particle's Gaussians, z[k] for component k.
  FF_HD void move(std::size_t i, const double* z) const {
    if constexpr (!General) {
      const R amplitude = R(std::sqrt(two_D[0] * params->dt));  // sqrt(2 D Δt)
      overdamped_move<R, D>(position, image, box, i, nullptr, amplitude, z);
      return;
    }
    const int t = type ? type[i] : 0;
    const R amplitude = R(std::sqrt(two_D[t] * params->dt));
    if (!velocity && !force) {
      if (too_far) check(i, nullptr, amplitude, z);
      overdamped_move<R, D>(position, image, box, i, nullptr, amplitude, z);
      return;
    }
    const R dt = R(params->dt);
    const R mu = R(mobility[t]);
    R drift[D];
    for (int k = 0; k < D; ++k) {
      R v = velocity ? velocity[i * D + k] : R(0);
      if (force) v = velocity ? v + mu * force[i * D + k] : mu * force[i * D + k];
      drift[k] = v * dt;
    }
    if (too_far) check(i, drift, amplitude, z);
    overdamped_move<R, D>(position, image, box, i, drift, amplitude, z);
  }
  // The step's length against max_step (the move itself is made regardless: a step that fails
  // the check is rolled back).
  FF_HD void check(std::size_t i, const R* drift, R amplitude, const double* z) const {
    double len2 = 0;
    for (int k = 0; k < D; ++k) {
      const double d = (drift ? double(drift[k]) : 0.0) + double(amplitude) * z[k];
      len2 += d * d;
    }
    if (len2 > max_step2) {
      count_one(too_far);
      keep_min(too_far + 1, unsigned(i));
    }
  }
  FF_HD void operator()(std::size_t i) const { overdamped_step(*this, i); }
};

}  // namespace ff::overdamped
