// The overdamped (Euler–Maruyama) position update every integrator shares, written once:
//   x_k += drift_k + amplitude · ξ_k,  then wrapped into the periodic box with the crossing
// counted in `image`. drift is the deterministic displacement of the step (v Δt, or none),
// amplitude = sqrt(2 D Δt), ξ truncated unit Gaussians (core/rng.h). nvcc-clean.
#pragma once
#include <cstddef>
#include <cstdint>

#include "core/box.h"
#include "core/hd.h"

namespace ff {

template <class R, int D>
FF_HD void overdamped_move(R* position, std::int32_t* image, const PeriodicBox<R>& box, std::size_t i,
                           const R* drift, R amplitude, const double* xi) {
  for (int k = 0; k < D; ++k) {
    R x = position[i * D + k];
    if (drift) x += drift[k];
    x += amplitude * R(xi[k]);
    box.wrap(x, image[i * D + k], k);
    position[i * D + k] = x;
  }
}

}  // namespace ff
