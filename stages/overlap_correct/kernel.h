// overlap_correct per-element math (Carter et al. 2017, sec. 2.3 eq. 4 and sec. 4.4), shared by
// the CPU and CUDA loops. FF_HD only; nvcc-clean.
//
// One iteration is two passes over the particles:
//   Gather (Mesh::gather): particle v walks the Delaunay edges around it (its fan of outgoing
//     half-edges, always in the same order: from vertex_edge[v], turning by next(twin(h)), one
//     8-byte load per neighbour) and sums, for each neighbour u closer than σ_vu = (σ_v + σ_u)/2,
//     a push of length δ away from u along the line of centres:
//       reflect: δ = σ_vu − r   (both move by δ: r' = 2σ_vu − r, the pair bounces off contact)
//       contact: δ = (σ_vu − r)/2  (r' = σ_vu, tangential contact)
//     The sum is capped at `cap`·σ_v in length (the paper's σ/4 against runaway corrections).
//     The summation order is fixed by the mesh, so the result is the same bits for any thread
//     count and on either backend (cuda.cu is compiled without FMA contraction).
//   Apply (apply_one): x_v += d_v, wrapped into the box (image counts box crossings).
// Counters (pairs found, pairs beyond the tolerance, summed |d_v| in 64-bit fixed point) are
// integer sums, hence order-independent too.
//
// A particle's gather depends only on its own position and its neighbours', so it gives d_v = 0
// and no pairs unless it has an overlapping edge. The CUDA loop uses that to gather, after the
// first iteration, only the particles that can have one (those that had an overlapping edge in
// the previous iteration, and the neighbours of those that moved): the same values as gathering
// every particle, so the same bits as the CPU loop, which gathers every particle every time.
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
// pair_push's answer for a pair that does not overlap.
inline constexpr double kNoOverlap = -1.0;

FF_HD void add_u64(std::uint64_t* p, std::uint64_t v) {
#if defined(__CUDA_ARCH__)
  atomicAdd(reinterpret_cast<unsigned long long*>(p), static_cast<unsigned long long>(v));
#else
  __atomic_fetch_add(p, v, __ATOMIC_RELAXED);
#endif
}

// The push on particle v from neighbour u at minimum-image offset (rx, ry) = x_u − x_v,
// added to (dx, dy). Returns the relative overlap (σ_vu − r)/σ_vu when r² < σ_vu², else
// kNoOverlap (−1; an overlapping pair cannot return it, since r < 2σ_vu).
FF_HD double pair_push(double rx, double ry, double sv, double su, double factor, int v, int u, double& dx,
                       double& dy) {
  const double s = 0.5 * (sv + su);
  const double r2 = rx * rx + ry * ry;
  if (!(r2 < s * s)) return kNoOverlap;
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

// Loads. On the device, positions move during the persistent kernel (other blocks write them
// between grid barriers), so they are read through L2 (ld.global.cg), never the read-only
// path; the half-edges are read-only for the whole stage.
template <class R>
FF_HD void load_xy(const R* pos, int v, double& x, double& y) {
#if defined(__CUDA_ARCH__)
  if constexpr (sizeof(R) == 8) {
    const double2 p = __ldcg(reinterpret_cast<const double2*>(pos) + v);
    x = p.x;
    y = p.y;
  } else {
    const float2 p = __ldcg(reinterpret_cast<const float2*>(pos) + v);
    x = double(p.x);
    y = double(p.y);
  }
#else
  x = double(pos[2 * v]);
  y = double(pos[2 * v + 1]);
#endif
}

// {origin, next} of half-edge h.
FF_HD void load_halfedge(const std::int32_t* he, int h, int& origin, int& next) {
#if defined(__CUDA_ARCH__)
  const int2 r = __ldg(reinterpret_cast<const int2*>(he) + h);
  origin = r.x;
  next = r.y;
#else
  origin = he[2 * h];
  next = he[2 * h + 1];
#endif
}

// What one particle's gather found.
struct VertexPush {
  double dx = 0, dy = 0;  // capped displacement
  double len = 0;         // its length
  unsigned pairs = 0;     // overlapping pairs with v < u
  unsigned bad = 0;       // of those, beyond the tolerance
  bool touched = false;   // some edge of v overlaps (r² < σ²), counted or not
  bool broken = false;    // the fan did not close within kMaxFan steps
};

template <class R>
struct Mesh {
  const R* pos;                // N x 2
  const R* diameter;           // N
  const std::int32_t* he;      // 2 x 6N: {origin, next}
  const std::int32_t* vedge;   // N
  PeriodicBox<double> box;
  double factor;               // 1 = reflect, 0.5 = contact
  double cap;                  // fraction of σ_v
  double tol;                  // relative overlap that still counts as converged
  double inv_unit;             // 1 / length unit of the correction counter

  // Calls f(u, h) for each neighbour u of v in fan order (h = the half-edge v -> u); returns
  // false when the fan does not close.
  template <class F>
  FF_HD bool for_each_neighbour(int v, F&& f) const {
    const int h0 = vedge[v];
    int h = h0, steps = 0;
    do {
      int u, hn;
      load_halfedge(he, h ^ 1, u, hn);  // twin(h) = u -> v; next(twin(h)) leaves v again
      f(u, h);
      h = hn;
      if (++steps > kMaxFan) return false;
    } while (h != h0);
    return true;
  }

  FF_HD VertexPush gather(int v) const {
    VertexPush out;
    double xv, yv;
    load_xy(pos, v, xv, yv);
    const double sv = double(diameter[v]);
    double dx = 0, dy = 0;
    out.broken = !for_each_neighbour(v, [&](int u, int) {
      double xu, yu;
      load_xy(pos, u, xu, yu);
      const double rx = box.min_image(xu - xv, 0);
      const double ry = box.min_image(yu - yv, 1);
      const double o = pair_push(rx, ry, sv, double(diameter[u]), factor, v, u, dx, dy);
      if (o != kNoOverlap) {
        out.touched = true;
        if (v < u && o > 0) {
          ++out.pairs;
          if (o > tol) ++out.bad;
        }
      }
    });
    double len = std::sqrt(dx * dx + dy * dy);
    const double limit = cap * sv;
    if (len > limit) {
      const double s = limit / len;
      dx *= s;
      dy *= s;
      len = limit;
    }
    out.dx = dx;
    out.dy = dy;
    out.len = len;
    return out;
  }

  // |d_v| in the correction counter's fixed point.
  FF_HD std::uint64_t fixed_len(double len) const {
    return len > 0 ? std::uint64_t(std::llround(len * inv_unit * kFixedOne)) : 0;
  }
};

// x_v += d_v, each coordinate wrapped into the box; a zero component leaves its coordinate alone.
template <class R>
FF_HD void apply_one(R* pos, std::int32_t* image, const PeriodicBox<R>& box, std::size_t i, double dx, double dy) {
  const double d[2] = {dx, dy};
  for (int k = 0; k < 2; ++k) {
    if (d[k] == 0) continue;
    R x = R(double(pos[2 * i + k]) + d[k]);
    box.wrap(x, image[2 * i + k], k);
    pos[2 * i + k] = x;
  }
}

// CPU loops: gather every particle into disp, then apply.
template <class R>
struct Gather {
  Mesh<R> mesh;
  double* disp;                // N x 2, out
  std::uint64_t* counters;     // kCounters

  FF_HD void operator()(std::size_t i) const {
    const VertexPush p = mesh.gather(int(i));
    disp[2 * i] = p.dx;
    disp[2 * i + 1] = p.dy;
    if (p.broken) add_u64(counters + kBroken, 1);
    if (p.pairs) add_u64(counters + kPairs, p.pairs);
    if (p.bad) add_u64(counters + kBad, p.bad);
    if (p.len > 0) add_u64(counters + kCorrection, mesh.fixed_len(p.len));
  }
};

template <class R>
struct Apply {
  R* pos;                 // N x 2
  std::int32_t* image;    // N x 2
  const double* disp;     // N x 2
  PeriodicBox<R> box;

  FF_HD void operator()(std::size_t i) const { apply_one(pos, image, box, i, disp[2 * i], disp[2 * i + 1]); }
};

}  // namespace ff::overlap
