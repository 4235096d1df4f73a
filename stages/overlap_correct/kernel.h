// overlap_correct per-element math (Carter et al. 2017, sec. 2.3 eq. 4 and sec. 4.4), shared by
// the CPU and CUDA loops. FF_HD only; nvcc-clean.
//
// One iteration is two passes over the particles:
//   Gather: particle v walks the Delaunay edges around it (its fan of half-edges, always in the
//     same order, starting at vertex_edge[v]) and sums, for each neighbour u closer than
//     σ_vu = (σ_v + σ_u)/2, a push of length δ away from u along the line of centres:
//       reflect: δ = σ_vu − r   (both move by δ: r' = 2σ_vu − r, the pair bounces off contact)
//       contact: δ = (σ_vu − r)/2  (r' = σ_vu, tangential contact)
//     The sum is capped at `cap`·σ_v in length (the paper's σ/4 against runaway corrections).
//     The summation order is fixed by the mesh, so the result is the same bits for any thread
//     count and on either backend (cuda.cu is compiled without FMA contraction).
//   Apply: x_v += d_v, wrapped into the box (image counts box crossings).
// Counters (pairs found, pairs beyond the tolerance, summed |d_v| in 64-bit fixed point) are
// integer sums, hence order-independent too.
#pragma once
#include <cmath>
#include <cstdint>

#include "core/box.h"
#include "core/hd.h"

namespace ff::overlap {

enum Counter : int {
  kBad = 0,     // pairs with (σ_ij − r)/σ_ij > tolerance (each pair once)
  kPairs,       // pairs with r < σ_ij (each pair once)
  kCorrection,  // Σ_v |d_v| in units of 2^-32 · length_unit
  kBroken,      // vertices whose fan of half-edges does not close (corrupt triangulation)
  kCounters
};

// No vertex of a sane triangulation has this many neighbours; a longer walk means a broken mesh.
inline constexpr int kMaxFan = 4096;
inline constexpr double kFixedOne = 4294967296.0;  // 2^32

FF_HD void add_u64(std::uint64_t* p, std::uint64_t v) {
#if defined(__CUDA_ARCH__)
  atomicAdd(reinterpret_cast<unsigned long long*>(p), static_cast<unsigned long long>(v));
#else
  __atomic_fetch_add(p, v, __ATOMIC_RELAXED);
#endif
}

// The push on particle v from neighbour u at minimum-image offset (rx, ry) = x_u − x_v,
// added to (dx, dy). Returns the relative overlap (σ_vu − r)/σ_vu when r < σ_vu, else −1.
FF_HD double pair_push(double rx, double ry, double sv, double su, double factor, int v, int u, double& dx,
                       double& dy) {
  const double s = 0.5 * (sv + su);
  const double r2 = rx * rx + ry * ry;
  if (!(r2 < s * s)) return -1.0;
  const double r = std::sqrt(r2);
  const double delta = factor * (s - r);
  if (r > 0) {
    dx -= delta * (rx / r);
    dy -= delta * (ry / r);
  } else {  // coincident centres: separate along x, the lower index towards −x
    dx -= v < u ? delta : -delta;
  }
  return (s - r) / s;
}

template <class R>
struct Gather {
  const R* pos;                // N x 2
  const R* diameter;           // N
  const std::int32_t* he;      // 2 x 6N: {origin, next}
  const std::int32_t* vedge;   // N
  PeriodicBox<double> box;
  double factor;               // 1 = reflect, 0.5 = contact
  double cap;                  // fraction of σ_v
  double tol;                  // relative overlap that still counts as converged
  double inv_unit;             // 1 / length unit of the correction counter
  double* disp;                // N x 2, out
  std::uint64_t* counters;     // kCounters

  FF_HD void operator()(std::size_t i) const {
    const int v = int(i);
    const double xv = double(pos[2 * v]), yv = double(pos[2 * v + 1]);
    const double sv = double(diameter[v]);
    double dx = 0, dy = 0;
    unsigned bad = 0, pairs = 0;
    const int h0 = vedge[v];
    int h = h0, steps = 0;
    do {
      const int hn = he[2 * h + 1];
      const int u = he[2 * hn];  // origin(next(h)) = the other end of h
      const double rx = box.min_image(double(pos[2 * u]) - xv, 0);
      const double ry = box.min_image(double(pos[2 * u + 1]) - yv, 1);
      const double o = pair_push(rx, ry, sv, double(diameter[u]), factor, v, u, dx, dy);
      if (v < u && o > 0) {
        ++pairs;
        if (o > tol) ++bad;
      }
      h = he[2 * hn + 1] ^ 1;  // twin(next(next(h))): the next half-edge leaving v
      if (++steps > kMaxFan) {
        add_u64(counters + kBroken, 1);
        break;
      }
    } while (h != h0);
    double len = std::sqrt(dx * dx + dy * dy);
    const double limit = cap * sv;
    if (len > limit) {
      const double s = limit / len;
      dx *= s;
      dy *= s;
      len = limit;
    }
    disp[2 * v] = dx;
    disp[2 * v + 1] = dy;
    if (pairs) add_u64(counters + kPairs, pairs);
    if (bad) add_u64(counters + kBad, bad);
    if (len > 0) add_u64(counters + kCorrection, std::uint64_t(std::llround(len * inv_unit * kFixedOne)));
  }
};

template <class R>
struct Apply {
  R* pos;                 // N x 2
  std::int32_t* image;    // N x 2
  const double* disp;     // N x 2
  PeriodicBox<R> box;

  FF_HD void operator()(std::size_t i) const {
    for (int k = 0; k < 2; ++k) {
      const double d = disp[2 * i + k];
      if (d == 0) continue;
      R x = R(double(pos[2 * i + k]) + d);
      box.wrap(x, image[2 * i + k], k);
      pos[2 * i + k] = x;
    }
  }
};

}  // namespace ff::overlap
