// A decomposed team's slab geometry and its migration test, per particle, for the host
// (core/run/domain.cpp, domain_migration.cpp) and the device (core/run/cuda/ghost_traffic.cu):
// one definition, so both sides take the same decisions from the same position bits (the device
// file is compiled with -fmad=false, as the host's arithmetic has no fused operations).
// nvcc-clean.
#pragma once
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/base/hd.h"
#include "core/physics/box.h"

namespace ff {

// Slabs of width L/ranks along x; this rank's index; ghosts within band of a slab.
struct SlabGeometry {
  double L;
  int ranks;
  int rank;
  double band;

  // The rank whose slab holds x (a position in [0, L), rounding clamped to the last slab).
  FF_HD int owner_of(double x) const {
    const int r = int(std::floor(x / L * double(ranks)));
    return r < 0 ? 0 : (r > ranks - 1 ? ranks - 1 : r);
  }

  // Whether rank q holds x as a ghost: the distance along x from x, or one of its periodic
  // images, to q's slab is within the band; a particle on the slab's edge (rounding may give it
  // to the neighbour) is at distance 0: a ghost.
  FF_HD bool ghost_of(int q, double x) const {
    const double lo = L * double(q) / double(ranks), hi = L * double(q + 1) / double(ranks);
    double best = L;
    for (int k = -1; k <= 1; ++k) {
      const double y = x + double(k) * L;
      double d = lo - y;
      if (y - hi > d) d = y - hi;
      if (d < 0.0) d = 0.0;
      if (d < best) best = d;
    }
    return best <= band + 1e-9 * L;  // a margin for the rounding of positions near a slab's edge
  }
};

// The order a rank holds its particles in after a migration: one key a source (a kept particle
// or a received record, `source` < 2^31), sorted: owned first, then ghosts, each by global id.
FF_HD std::uint64_t held_key(bool owned, std::uint32_t id, std::size_t source) {
  return (owned ? 0 : std::uint64_t(1) << 63) | std::uint64_t(id) << 31 | std::uint64_t(source);
}
inline constexpr std::uint64_t kHeldSourceMask = (std::uint64_t(1) << 31) - 1;

// The squared distance particle i moved from x0 since the last migration (minimum image), in
// the state's precision R: the migration test compares it with (slack as R)², as
// neighbors.verlet's rebuild test does.
template <class R, class X0>
FF_HD R moved_squared(const R* x, const X0* x0, std::size_t i, int dim, const PeriodicBox<R>& box) {
  R d2 = 0;
  for (int k = 0; k < dim; ++k) {
    const R d = box.min_image(x[i * std::size_t(dim) + std::size_t(k)] - R(x0[i * std::size_t(dim) + std::size_t(k)]), k);
    d2 += d * d;
  }
  return d2;
}

}  // namespace ff
