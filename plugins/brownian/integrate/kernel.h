// Free overdamped Brownian motion: x += sqrt(2 D Δt) ξ per component, ξ a truncated unit
// Gaussian (core/rng.h), then wrap into the periodic box and count image crossings.
#pragma once
#include <cstdint>

#include "core/box.h"
#include "core/hd.h"
#include "core/rng.h"

namespace ff::brownian {

template <class R, int D>
struct BrownianStep {
  R* position;          // N x D
  std::int32_t* image;  // N x D
  PeriodicBox<R> box;
  R amplitude;          // sqrt(2 D Δt)
  RngKey key;
  std::uint64_t step;
  std::uint32_t attempt;

  FF_HD void operator()(std::size_t i) const {
    double z[4];
    gaussians(key, std::uint32_t(i), step, attempt, 0, D, z);
    for (int k = 0; k < D; ++k) {
      R x = position[i * D + k] + amplitude * R(z[k]);
      box.wrap(x, image[i * D + k], k);
      position[i * D + k] = x;
    }
  }
};

}  // namespace ff::brownian
