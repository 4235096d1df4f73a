// Squared displacement of one particle's unwrapped position (position + image·L) from its
// reference, in double whatever the run's precision.
#pragma once
#include <cstddef>
#include <cstdint>

#include "core/base/hd.h"

namespace ff::observe {

template <class R, int D>
struct Unwrap {
  const R* position;           // N x D, wrapped into the box
  const std::int32_t* image;   // N x D box crossings
  double L[3];

  FF_HD double operator()(std::size_t i, int k) const {
    return double(position[i * D + k]) + double(image[i * D + k]) * L[k];
  }
};

template <class R, int D>
FF_HD double squared_displacement(const Unwrap<R, D>& u, const double* reference, std::size_t i) {
  double s = 0;
  for (int k = 0; k < D; ++k) {
    const double d = u(i, k) - reference[i * D + k];
    s += d * d;
  }
  return s;
}

}  // namespace ff::observe
