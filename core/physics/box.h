// Periodic box: minimum-image differences and wrapping, written once for both backends.
#pragma once
#include <cmath>

#include "core/base/hd.h"

namespace ff {

// Box edge lengths in the precision of the run; dim = 2 ignores L[2].
template <class R>
struct PeriodicBox {
  R L[3];
  R inv_L[3];

  static PeriodicBox make(const double* lengths) {
    PeriodicBox b{};
    for (int k = 0; k < 3; ++k) {
      b.L[k] = R(lengths[k]);
      b.inv_L[k] = lengths[k] > 0 ? R(1.0 / lengths[k]) : R(0);
    }
    return b;
  }

  // Minimum image of a coordinate difference along axis k.
  FF_HD R min_image(R d, int k) const { return d - L[k] * std::rint(d * inv_L[k]); }

  // Bring x into [0, L) along axis k; `image` counts the box crossings (H5MD `image`).
  FF_HD void wrap(R& x, int& image, int k) const {
    const R shift = std::floor(x * inv_L[k]);
    x -= shift * L[k];
    image += int(shift);
    if (x >= L[k]) {  // rounding can land a tiny negative x exactly on L
      x -= L[k];
      image += 1;
    }
    if (x < R(0)) x = R(0);
  }
};

}  // namespace ff
