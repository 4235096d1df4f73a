// Euler–Maruyama step of Carter et al. 2017, eq. 1: x += v Δt + sqrt(2 D Δt) ξ, with v the
// pair velocity from phoretic.forces and ξ truncated unit Gaussians (core/rng.h), then wrap.
#pragma once
#include <cstdint>

#include "core/box.h"
#include "core/overdamped.h"
#include "core/hd.h"
#include "core/rng.h"

namespace ff::phoretic {

template <class R, int D>
struct PhoreticStep {
  R* position;          // N x D
  std::int32_t* image;  // N x D
  const R* velocity;    // N x D
  PeriodicBox<R> box;
  R dt;
  R amplitude;          // sqrt(2 D Δt)
  RngKey key;
  std::uint64_t step;
  std::uint32_t attempt;

  static constexpr int kNoisePairs = (D + 1) / 2;  // pairs 0 (and 1 in 3D)
  FF_HD std::uint32_t noise_pair(int j) const { return std::uint32_t(j); }
  FF_HD NoiseCounter noise_counter() const { return {key, step, attempt}; }

  // z: the particle's Gaussians, z[k] for component k.
  FF_HD void move(std::size_t i, const double* z) const {
    R drift[D];
    for (int k = 0; k < D; ++k) drift[k] = velocity[i * D + k] * dt;
    overdamped_move<R, D>(position, image, box, i, drift, amplitude, z);
  }

  FF_HD void operator()(std::size_t i) const { overdamped_step(*this, i); }
};

}  // namespace ff::phoretic
