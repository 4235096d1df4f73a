// Phoretic pair velocities (Carter et al. 2017, eq. 2-3), physics written once for both backends:
//
//   v_i = μ_{t_i} Σ_{k≠i} α_{t_k} f(d_ik),   d_ik = minimum image of r_i - r_k
//   long range:  f(d) = d / |d|^3  over all pairs (exact O(N²))
//   short range: f(d) = d / |d|^7  for |d| ≤ cutoff, through the Verlet list
//
// Each particle sums its own terms in ascending k (the Verlet rows are sorted by index), in the
// precision of the run, so the sum is deterministic and the same on every backend and for any
// tiling: the CPU blocked loop and the GPU shared-memory tiles only change where data comes from.
#pragma once
#include <cmath>
#include <cstdint>

#include "core/physics/box.h"
#include "core/base/hd.h"
#include "core/physics/math.h"

namespace ff::phoretic {

constexpr int kMaxTypes = 16;

// Charges per particle type, passed by value into kernels.
template <class R>
struct Charges {
  R alpha[kMaxTypes];
  R mu[kMaxTypes];
};

// Minimum image of a difference of two wrapped positions (|d| < 1.5 L): shift by L towards zero
// when |d| > L/2. Exact comparisons, so it picks the same image as PeriodicBox::min_image (which
// rounds d/L) except possibly at |d| = L/2 itself; unlike rint it has no branches on CPUs
// without SSE4.1, so the CPU all-pairs loop vectorizes. One compare on |d| (a free operand
// modifier on the GPU) and a copysign (one bit operation) instead of a compare per side: the
// same results as `d > L/2 ? d - L : d`, then `d < -L/2 ? d + L : d` (at most one of them fires).
template <class R>
FF_HD R nearest_image(R d, const PeriodicBox<R>& box, int c) {
  return std::fabs(d) > R(0.5) * box.L[c] ? d - std::copysign(box.L[c], d) : d;
}

// 1/√x of the run's precision: IEEE 1/std::sqrt, except float on the GPU, where it is the
// hardware reciprocal square root alone (PTX rsqrt.approx.ftz.f32, one MUFU.RSQ: relative error
// at most 2^-22.9 per the PTX ISA; 2^-22.94 measured over every float in [1, 4) on the H100,
// against 1/√ in double). The CPU-vs-CUDA float test bounds what this changes. `.ftz` spares rsqrtf's four-instruction rescaling of
// subnormal x; it only changes x < 2^-126 (|d| < 1.1e-19), where α/|d|³ overflows float anyway
// (to ±inf, on both backends; only α = 0 then gives NaN on the GPU instead of 0). 1/√0 = +inf.
FF_HD double inv_sqrt(double x) { return 1.0 / std::sqrt(x); }
FF_HD float inv_sqrt(float x) {
#if defined(__CUDA_ARCH__)
  float y;
  asm("rsqrt.approx.ftz.f32 %0, %1;" : "=f"(y) : "f"(x));
  return y;
#else
  return 1.0f / std::sqrt(x);
#endif
}

// acc += α_k d / |d|^3. Branch-free, so CPU loops vectorize: a coincident point (k = i, or a
// distinct particle at the same place, whose term is undefined) adds exactly zero.
template <class R, int D>
FF_HD void add_long_range(R* acc, const R* xi, const R* xk, R alpha_k, const PeriodicBox<R>& box) {
  R d[D];
  R r2 = 0;
  for (int c = 0; c < D; ++c) {
    d[c] = nearest_image(xi[c] - xk[c], box, c);
    r2 += d[c] * d[c];
  }
  const R inv_r = inv_sqrt(r2);  // +inf when r2 = 0: s then selects 0 instead
  const R s = r2 > R(0) ? alpha_k * inv_r * inv_r * inv_r : R(0);  // selects values only
  for (int c = 0; c < D; ++c) acc[c] += s * d[c];
}

// acc += α_k d / |d|^7 for 0 < |d| ≤ cutoff. The same bits on the CPU and CUDA: the products
// that feed a sum are math::mul_rn, which nvcc cannot fuse into an fma (forces/cuda.cu keeps
// contraction for the all-pairs kernel; box.min_image needs none: L·rint(d/L) is L·{−1, 0, 1}).
template <class R, int D>
FF_HD void add_short_range(R* acc, const R* xi, const R* xk, R alpha_k, const PeriodicBox<R>& box, R cutoff2) {
  R d[D];
  R r2 = 0;
  for (int c = 0; c < D; ++c) {
    d[c] = box.min_image(xi[c] - xk[c], c);
    r2 += math::mul_rn(d[c], d[c]);
  }
  if (r2 > R(0) && r2 <= cutoff2) {
    const R inv_r = R(1) / std::sqrt(r2);
    const R inv_r2 = inv_r * inv_r;
    const R s = alpha_k * inv_r2 * inv_r2 * inv_r2 * inv_r;
    for (int c = 0; c < D; ++c) acc[c] += math::mul_rn(s, d[c]);
  }
}

// All pairs (k = i included: it adds zero). operator()(i) is the plain form (one particle
// against all, ascending k); the backends' tiled loops use alpha_of/add/store and keep the
// same order of additions.
template <class R, int D>
struct LongRangeVelocity {
  const R* position;
  const std::int32_t* type;
  R* velocity;
  Charges<R> q;
  PeriodicBox<R> box;
  std::size_t n;
  // The targets this call computes, [first_target, end_target()): all by default; in a team of
  // ranks each rank its share (core/backend/comm.h share_of). Sources are always all n, in
  // ascending order, so a target's sum is the same whichever rank computes it.
  std::size_t first_target = 0;
  std::size_t last_target = ~std::size_t(0);

  FF_HD std::size_t end_target() const { return last_target < n ? last_target : n; }
  FF_HD R alpha_of(std::size_t k) const { return q.alpha[type[k]]; }
  FF_HD void add(R* acc, const R* xi, const R* xk, R alpha_k) const {
    add_long_range<R, D>(acc, xi, xk, alpha_k, box);
  }
  FF_HD void store(std::size_t i, const R* acc) const {
    const R mu = q.mu[type[i]];
    for (int c = 0; c < D; ++c) velocity[i * D + c] = mu * acc[c];
  }
  FF_HD void operator()(std::size_t i) const {
    R acc[D] = {};
    for (std::size_t k = 0; k < n; ++k) add(acc, &position[i * D], &position[k * D], alpha_of(k));
    store(i, acc);
  }
};

// Short range through the Verlet list of neighbors.verlet (stages/neighbors/list.h).
template <class R, int D>
struct ShortRangeVelocity {
  const R* position;
  const std::int32_t* type;
  R* velocity;
  Charges<R> q;
  PeriodicBox<R> box;
  const std::uint32_t* list;  // N x capacity, rows ascending
  const std::uint32_t* count;
  std::uint32_t capacity;
  R cutoff2;

  FF_HD void operator()(std::size_t i) const {
    R acc[D] = {};
    const R* xi = &position[i * D];
    const std::uint32_t* row = &list[i * capacity];
    const std::uint32_t m = count[i];
    for (std::uint32_t a = 0; a < m; ++a) {
      const std::uint32_t k = row[a];
      add_short_range<R, D>(acc, xi, &position[std::size_t(k) * D], q.alpha[type[k]], box, cutoff2);
    }
    const R mu = q.mu[type[i]];
    for (int c = 0; c < D; ++c) velocity[i * D + c] = mu * acc[c];
  }
};

}  // namespace ff::phoretic
