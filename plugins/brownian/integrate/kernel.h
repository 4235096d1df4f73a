// Free overdamped Brownian motion: x += sqrt(2 D Δt) ξ per component, ξ a truncated unit
// Gaussian (core/rng.h), then wrap into the periodic box and count image crossings.
#pragma once
#include <cstdint>

#include "core/box.h"
#include "core/overdamped.h"
#include "core/hd.h"
#include "core/rng.h"
#include "core/step_params.h"

namespace ff::brownian {

template <class R, int D>
struct BrownianStep {
  R* position;          // N x D
  std::int32_t* image;  // N x D
  PeriodicBox<R> box;
  double two_D;         // 2 × diffusion coefficient
  RngKey key;
  const StepParams* params;  // step, attempt, Δt (on the side this runs on)

  FF_HD void operator()(std::size_t i) const {
    const std::uint64_t step = params->step;
    const std::uint32_t attempt = params->attempt;
    const R amplitude = R(std::sqrt(two_D * params->dt));  // sqrt(2 D Δt)
    double z[4];
    gaussians(key, std::uint32_t(i), step, attempt, 0, D, z);
    overdamped_move<R, D>(position, image, box, i, nullptr, amplitude, z);
  }
};

}  // namespace ff::brownian
