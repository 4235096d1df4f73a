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

  static constexpr int kNoisePairs = (D + 1) / 2;  // pairs 0 (and 1 in 3D)
  FF_HD std::uint32_t noise_pair(int j) const { return std::uint32_t(j); }
  FF_HD NoiseCounter noise_counter() const { return {key, params->step, params->attempt}; }

  // z: the particle's Gaussians, z[k] for component k.
  FF_HD void move(std::size_t i, const double* z) const {
    const R amplitude = R(std::sqrt(two_D * params->dt));  // sqrt(2 D Δt)
    overdamped_move<R, D>(position, image, box, i, nullptr, amplitude, z);
  }

  FF_HD void operator()(std::size_t i) const { overdamped_step(*this, i); }
};

}  // namespace ff::brownian
