// delaunay.dt_bound's element operations (De Fabritiis & Coveney §5.1, spec D3): per edge, the
// distance h_i from each particle to its nearest Delaunay neighbour (an atomic min); per
// particle, the largest Δt_i for which its step cannot exceed fraction·h_i; then the exact
// minimum over particles through integer max-reductions of an order-reversing key. nvcc-clean.
#pragma once
#include <cmath>
#include <cstdint>

#include "core/base/hd.h"
#include "core/physics/math.h"
#include "stages/delaunay/common/mesh.h"

namespace ff::delaunay {

inline constexpr int kDtBoundMaxTypes = 16;

// The largest Δt with a·Δt + b·√Δt <= c (a = drift speed, b = noise bound per √Δt, c = the
// allowed displacement): the positive root of a·s² + b·s − c in s = √Δt, written
// 2c / (b + √(b² + 4ac)) rather than (−b + √(b² + 4ac)) / (2a): the same number without the
// cancellation when a·c << b², and valid for a = 0 (s = c/b) and b = 0 (s = √(c/a)) alike.
// a = b = 0 (nothing moves the particle): infinity. c = 0 (a neighbour on top of it) or a
// non-finite input: 0, which stops the run below dt_min instead of hiding the particle.
FF_HD double largest_dt(double a, double b, double c) {
  if (!(c > 0)) return 0;
  if (a == 0 && b == 0) return INFINITY;
  const double s = 2 * c / (b + std::sqrt(b * b + 4 * a * c));
  const double dt = s * s;
  return dt >= 0 ? dt : 0;  // (NaN from a non-finite a or b)
}

// A key that orders Δt >= 0 (infinity included) the other way round: the largest key is the
// smallest Δt. The bits of a non-negative double grow with its value, so the integer max of
// the keys is exact and the same for any order of the terms, thread count or backend.
FF_HD std::uint64_t dt_order_key(double dt) { return ~math::bits_of(dt); }
FF_HD double dt_of_key(std::uint64_t key) { return math::from_bits(~key); }

// The smallest of *p and v, kept in *p (an atomic min: the result does not depend on the order).
FF_HD void keep_min_u64(std::uint64_t* p, std::uint64_t v) {
#if defined(__CUDA_ARCH__)
  atomicMin(reinterpret_cast<unsigned long long*>(p), static_cast<unsigned long long>(v));
#else
  std::uint64_t cur = __atomic_load_n(p, __ATOMIC_RELAXED);
  while (v < cur && !__atomic_compare_exchange_n(p, &cur, v, true, __ATOMIC_RELAXED, __ATOMIC_RELAXED)) {
  }
#endif
}

// Edge e = (a, b): its squared length, kept as the minimum of both endpoints' `nearest2` (the
// bits of a non-negative double, which order as its value; start: a huge value). One pass over
// the edges in storage order — every Delaunay neighbour of a particle is the other end of one of
// its edges, and the nearest particle is always a Delaunay neighbour — instead of a walk around
// each vertex, a chain of dependent loads per neighbour.
template <class R>
struct EdgeNearest {
  Mesh m;
  Points<R> pts;
  std::uint64_t* nearest2;  // N

  FF_HD void operator()(std::size_t e) const {
    const int a = m.origin(int(2 * e)), b = m.origin(int(2 * e + 1));
    const V2 r = pts.rel(a, b);
    const std::uint64_t d2 = math::bits_of(r.x * r.x + r.y * r.y);
    keep_min_u64(nearest2 + a, d2);
    keep_min_u64(nearest2 + b, d2);
  }
};

// Particle i of type t: h_i from EdgeNearest, the bound on its drift speed, and the key of its
// largest Δt; h_i into `nearest` (for the message naming the particle that sets the limit).
template <class R>
struct ParticleDtBound {
  const R* velocity;            // N x 2, or null
  const R* force;               // N x 2, or null
  const std::int32_t* type;     // N, or null: every particle is type 0
  double mobility[kDtBoundMaxTypes];
  double speed[kDtBoundMaxTypes];  // drift speed the fields do not hold (self-propulsion)
  double noise[kDtBoundMaxTypes];  // b_t: the noise displacement's bound divided by √Δt
  double fraction;                 // of h_i a step may cover (the paper's quarter)
  const std::uint64_t* nearest2;   // N: EdgeNearest's squared distances (bits)
  std::uint64_t* key;              // N: dt_order_key(Δt_i)
  double* nearest;                 // N: h_i

  // |v_i + μ_t F_i| (as the integrator forms the drift) plus the speed the fields do not hold.
  FF_HD double drift_speed(std::size_t i, int t) const {
    double v[2] = {0, 0};
    for (int k = 0; k < 2; ++k) {
      if (velocity) v[k] = double(velocity[2 * i + k]);
      if (force) v[k] = v[k] + mobility[t] * double(force[2 * i + k]);
    }
    return speed[t] + std::sqrt(v[0] * v[0] + v[1] * v[1]);
  }

  FF_HD void operator()(std::size_t i) const {
    const int t = type ? type[i] : 0;
    const double h = std::sqrt(math::from_bits(nearest2[i]));
    nearest[i] = h;
    key[i] = dt_order_key(largest_dt(drift_speed(i, t), noise[t], fraction * h));
  }
};

// The exact minimum of the 64-bit keys' order, in two 32-bit max-reductions: the high words,
// then the low words of the keys whose high word is the largest.
struct KeyHigh {
  const std::uint64_t* key;
  FF_HD std::uint32_t operator()(std::size_t i) const { return std::uint32_t(key[i] >> 32); }
};
struct KeyLowWhereHigh {
  const std::uint64_t* key;
  std::uint32_t high;
  FF_HD std::uint32_t operator()(std::size_t i) const {
    return std::uint32_t(key[i] >> 32) == high ? std::uint32_t(key[i]) : 0u;
  }
};
// The lowest particle whose key is `best`, as n − i (a max-reduction): the particle a message
// names, the same on every backend.
struct FirstWithKey {
  const std::uint64_t* key;
  std::uint64_t best;
  std::uint32_t n;
  FF_HD std::uint32_t operator()(std::size_t i) const { return key[i] == best ? n - std::uint32_t(i) : 0u; }
};

}  // namespace ff::delaunay
