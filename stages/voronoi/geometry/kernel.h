// voronoi.geometry's per-particle work: the Voronoi cell of particle v from the maintained
// periodic Delaunay triangulation (De Fabritiis & Coveney §2, spec D1). FF_HD only; nvcc-clean.
//
// The cell's vertices are the circumcentres of the triangles around v. One thread walks v's fan
// of half-edges twice: once to find its lowest half-edge and its length, then from that
// half-edge, computing each circumcentre from minimum-image vectors relative to v and summing
// the cell's faces in that fixed order. So every sum has one order, whatever the thread count,
// the backend or which half-edge delaunay.vertex_edge happens to name: the same bits on the CPU
// and on CUDA. No multiply-add is contracted by the compiler (cmake/flipflow_plugin.cmake); the
// ones written out as fmadd() are std::fma, rounded once and correctly on both (the CPU loops are
// built for x86-64-v3, which has the instruction; without it std::fma is libm's, as exact). The
// CUDA kernel is bound by issuing instructions, FP64 ones the most (bench/experiments/README.md,
// "voronoi.geometry CUDA variants", sessions 16 and 17): an fma is one for a multiply and an add.
// Each face (Delaunay edge e) is written by the walk of origin(2e) only, each circumcentre copy
// (one per half-edge) by the walk of that half-edge's origin: no two threads write the same
// element. The second walk may read the far ends from a cache that the first filled (cell(v, fan):
// geometry/cuda.cu keeps them in shared memory) instead of the half-edge records: the same values
// in the same order.
//
// Walk order: next(twin(h)) is the half-edge leaving v clockwise after h (overlap_correct walks
// the same way). With u_k the far end of the k-th half-edge h_k, the triangle between h_k and
// h_{k+1} is (v, u_{k+1}, u_k), counter-clockwise; its circumcentre is o_k. Face k (edge v–u_k)
// runs from o_R = o_k (right of v -> u_k) to o_L = o_{k-1} (left of it).
//
// Both ends of face k lie on the bisector of v–u_k: with d = u_k − v (relative to v) and
// n = d turned by +90°, o_R = d/2 + t_R n and o_L = d/2 + t_L n. The walk computes each
// triangle's circumcentre as its two parameters t (bisectors()) rather than as a point, and the
// face's terms follow from t_L − t_R without the points: its signed length A = (t_L − t_R)|d|,
// four times the area of the triangle (v, o_R, o_L) w = (t_L − t_R)|d|², and
// o_R + o_L = d + (t_R + t_L) n: fewer instructions than the points and their shoelace sums, and
// no division a face.
//
// The metrics' terms come out of the same walk (cell() returns them): integers, so that the
// backend loops (geometry/cpu.cpp, geometry/cuda.cu) may add them in any order.
#pragma once
#include <cmath>
#include <cstdint>

#include "core/base/hd.h"
#include "stages/delaunay/common/mesh.h"

namespace ff::voronoi {

using delaunay::V2;

// A fan longer than this is taken for a corrupt triangulation (sides = 0, reported by the stage).
inline constexpr int kMaxSides = 64;

// a b + c rounded once: the same bits on the host and the device.
FF_HD double fmadd(double a, double b, double c) { return std::fma(a, b, c); }
// a.x b.y − a.y b.x and |a|², each one multiply and one fma.
FF_HD double cross_fma(V2 a, V2 b) { return fmadd(a.x, b.y, -(a.y * b.x)); }
FF_HD double norm2(V2 a) { return fmadd(a.x, a.x, a.y * a.y); }

// The circumcentre o of the triangle (0, b, c) (counter-clockwise) on the bisectors of its sides
// from the origin: o = c/2 + tc c⊥ = b/2 + tb b⊥ (x⊥: x turned by +90°). From o·b = |b|²/2 and
// o·c = |c|²/2, with D = cross(b, c): tc = (b·c − |b|²) / 2D, tb = (|c|² − b·c) / 2D (spec D1's
// circumcentre, bb = |b|² and cc = |c|² given: the fan walk computes each far end's once).
struct Bisectors {
  double tb, tc;
};
FF_HD Bisectors bisectors(V2 b, V2 c, double bb, double cc) {
  const double inv_2D = 0.5 * (1.0 / cross_fma(b, c));  // one reciprocal per circumcentre (= 0.5 / D)
  return {fmadd(-b.x, c.x, fmadd(-b.y, c.y, cc)) * inv_2D, fmadd(b.x, c.x, fmadd(b.y, c.y, -bb)) * inv_2D};
}
// The point on the bisector of the origin and d at parameter t: d/2 + t d⊥.
FF_HD V2 on_bisector(V2 d, double t) { return {fmadd(-t, d.y, 0.5 * d.x), fmadd(t, d.x, 0.5 * d.y)}; }

// x brought into [0, L): a position written by the stage (midpoints, centroids, circumcentres).
FF_HD double wrap_into(double x, double L, double inv_L) {
  double w = x - L * std::floor(x * inv_L);
  if (w >= L) w -= L;
  if (w < 0) w = 0;
  return w;
}

// The metrics' terms of one cell, as integers so that their sums do not depend on the order
// (stored as two's complement modulo 2^64): the area in units of the mean area / 2^bits, its
// square in units of (mean area)² / 2^bits2, sides². A corrupt fan (sides 0) adds kBrokenTerm to
// sides2, far above any Σ sides² (N kMaxSides² < 2^44 for N < 2^32): the stage reads it back as
// the count of corrupt fans.
inline constexpr std::uint64_t kBrokenShift = 44;
struct MetricTerms {
  std::uint64_t area = 0, area2 = 0, sides2 = 0;
  FF_HD MetricTerms& operator+=(const MetricTerms& o) {
    area += o.area;
    area2 += o.area2;
    sides2 += o.sides2;
    return *this;
  }
};
// The fixed-point scales of the terms (the stage's report() says how they are chosen).
struct MetricScales {
  double area = 0;      // 2^bits / mean area
  double inv_mean = 0;  // 1 / mean area
  double area2 = 0;     // 2^bits2
};
// The area term: the area in units of 1 / scale, rounded to an integer.
FF_HD std::uint64_t area_term(double area, double scale) {
  return std::uint64_t(std::int64_t(std::rint(area * scale)));
}
// The area term as an element functor of the backend's integer sum (voronoi.mirror's area check).
template <class R>
struct AreaTerm {
  const R* area;
  double scale;  // 2^bits / mean area
  FF_HD std::uint64_t operator()(std::size_t i) const { return area_term(double(area[i]), scale); }
};

// Where a loop leaves Σ MetricTerms (null pointers: no metrics). `device`: four words on the
// loop's backend, zero between launches (the three sums and a count of finished blocks: the
// CUDA loop's last block moves the sums to `out` and zeroes them again); `out`: three words of
// host memory (pinned on CUDA, written by the kernel) that hold the sums once the loop is done.
struct MetricSums {
  std::uint64_t* device = nullptr;
  std::uint64_t* out = nullptr;
};

// Where cell() may keep the far ends of a fan between its two walks: none (the CPU loop; the
// second walk reads the half-edge records again, from cache). geometry/cuda.cu keeps up to
// kFanCache of them per thread in shared memory (a longer fan, rare, walks again).
inline constexpr int kFanCache = 12;
struct NoFanCache {
  static constexpr int capacity = 0;
  FF_HD void put(int, int) const {}
  FF_HD int get(int) const { return 0; }
};

template <class R>
struct CellGeometry {
  const std::int32_t* he;     // 2 x 6N: {origin, next} (delaunay.halfedge)
  const std::int32_t* vedge;  // N: one half-edge leaving each vertex
  delaunay::Points<R> pts;    // the positions the cells are built on, with the box
  int n;
  R* area;             // N
  R* perimeter;        // N: Σ of the signed face lengths
  R* centroid;         // 2 x N, wrapped into the box
  std::int32_t* sides; // N: faces = Delaunay neighbours; 0 when the fan is corrupt
  R* face_length;      // 3N or null: signed length A_e of the Voronoi face of edge e
  R* face_midpoint;    // 2 x 3N or null: its midpoint, wrapped into the box
  R* circumcenter;     // 2 x 6N or null: per half-edge h, the circumcentre of the triangle left of h
  MetricScales scale;  // of the terms cell() returns

  // dest(h) and next(twin(h)) from half-edge twin(h)'s record (one 8-byte load on the device).
  FF_HD void turn(int h, int& dest, int& next_out) const {
#if defined(__CUDA_ARCH__)
    const int2 r = __ldg(reinterpret_cast<const int2*>(he) + (h ^ 1));
    dest = r.x;
    next_out = r.y;
#else
    dest = he[2 * (h ^ 1)];
    next_out = he[2 * (h ^ 1) + 1];
#endif
  }

  // Particle j's position: on the device one 16-byte (double) or 8-byte (float) read-only load,
  // the two coordinates being adjacent; the same values as pts.p[2j], pts.p[2j + 1].
  FF_HD V2 position(int j) const {
#if defined(__CUDA_ARCH__)
    if constexpr (sizeof(R) == 8) {
      const double2 q = __ldg(reinterpret_cast<const double2*>(pts.p) + j);
      return {q.x, q.y};
    } else {
      const float2 q = __ldg(reinterpret_cast<const float2*>(pts.p) + j);
      return {double(q.x), double(q.y)};
    }
#else
    return {double(pts.p[2 * j]), double(pts.p[2 * j + 1])};
#endif
  }
  // Minimum-image vector from v (at pv) to u: pts.rel(v, u) with v's position read once per cell.
  FF_HD V2 rel(V2 pv, int u) const { return rel(pv, position(u)); }
  FF_HD V2 rel(V2 pv, V2 pu) const { return {pts.image(pu.x - pv.x, 0), pts.image(pu.y - pv.y, 1)}; }
  // pv + rel wrapped into the box.
  FF_HD V2 absolute(V2 pv, V2 rel) const {
    const double x = pv.x + rel.x, y = pv.y + rel.y;
    return {wrap_into(x, pts.box.L[0], pts.box.inv_L[0]), wrap_into(y, pts.box.L[1], pts.box.inv_L[1])};
  }
  // Element i of a two-component field (x, y adjacent): one vector store on the device.
  FF_HD static void store2(R* a, std::size_t i, V2 w) {
#if defined(__CUDA_ARCH__)
    if constexpr (sizeof(R) == 8) reinterpret_cast<double2*>(a)[i] = double2{w.x, w.y};
    else reinterpret_cast<float2*>(a)[i] = float2{float(w.x), float(w.y)};
#else
    a[2 * i] = R(w.x);
    a[2 * i + 1] = R(w.y);
#endif
  }

  // What one face adds to its cell (face k: half-edge h = v -> u at d = u − v, dd = |d|², from
  // o_R to o_L at parameters tR, tL on the bisector of v–u).
  struct Sums {
    double area4 = 0, perimeter = 0, gx = 0, gy = 0;  // area4: four times the area
  };
  template <bool Edges>
  FF_HD void face(V2 pv, int h, V2 d, double dd, double tR, double tL, Sums& s) const {
    const double dt = tL - tR;
    // A = (o_L − o_R)·n̂ with n̂ = (v -> u)/|v -> u| turned by +90°: ≥ 0 on a Delaunay edge.
    const double A = dt * std::sqrt(dd);
    // The triangle (v, o_R, o_L) (base the face, height |d|/2), four times its area: the sums of
    // w and w (o_R + o_L) are divided once, at the end.
    const double w = dt * dd;
    s.area4 += w;
    s.perimeter += A;
    const double ts = tR + tL;
    s.gx = fmadd(w, fmadd(-ts, d.y, d.x), s.gx);  // × 1/3 (the triangle's centroid) once, at the end
    s.gy = fmadd(w, fmadd(ts, d.x, d.y), s.gy);
    if (Edges && face_length && (h & 1) == 0) {
      const int e = h >> 1;
      face_length[e] = R(A);
      store2(face_midpoint, e, absolute(pv, on_bisector(d, 0.5 * ts)));
    }
    if (Edges && circumcenter) store2(circumcenter, h, absolute(pv, on_bisector(d, tL)));
  }

  // The stored area (rounded to R, as the field holds it) and the fan's size as metric terms.
  FF_HD MetricTerms terms(R stored_area, int deg) const {
    MetricTerms t;
    t.area = area_term(double(stored_area), scale.area);
    const double q = double(stored_area) * scale.inv_mean;
    t.area2 = std::uint64_t(std::int64_t(std::rint(q * q * scale.area2)));
    const std::uint64_t d = std::uint64_t(deg);
    t.sides2 = d == 0 ? (std::uint64_t(1) << kBrokenShift) : d * d;
    return t;
  }

  FF_HD void operator()(std::size_t i) const { cell(int(i)); }

  // Writes particle v's cell (and its faces and circumcentres); returns its metric terms.
  FF_HD MetricTerms cell(int v) const { return cell<true>(v, NoFanCache{}); }

  // The same, keeping the fan's far ends in `fan` (FanCache) during the first walk: the second
  // then reads them there instead of walking the half-edge records again, when the fan fits and
  // nothing is written per half-edge (the faces and circumcentres need the half-edges' indices).
  // Edges = false: the caller knows that face_length and circumcenter are null (the per-edge
  // code is left out of the loop).
  template <bool Edges, class Fan>
  FF_HD MetricTerms cell(int v, Fan fan) const {
    const unsigned nh = 6u * unsigned(n);
    // Pass 1: the fan closes within kMaxSides half-edges, every index in range; its lowest
    // half-edge (the kmin-th from h0) starts pass 2.
    const int h0 = vedge[v];
    int deg = 0, hmin = h0, kmin = 0;
    bool ok = unsigned(h0) < nh;
    for (int h = h0; ok;) {
      int u, hn;
      turn(h, u, hn);
      if (unsigned(u) >= unsigned(n) || u == v || unsigned(hn) >= nh || ++deg > kMaxSides) {
        ok = false;
      } else {
        if (deg <= Fan::capacity) fan.put(deg - 1, u);
        if ((h = hn) == h0) break;
        if (h < hmin) {
          hmin = h;
          kmin = deg;
        }
      }
    }
    if (!ok || deg < 3) {
      sides[v] = 0;
      area[v] = perimeter[v] = R(0);
      centroid[2 * v] = centroid[2 * v + 1] = R(0);
      return terms(R(0), 0);
    }
    // Pass 2: o_k = circumcentre of (v, u_{k+1}, u_k); face k needs o_{k-1} and o_k, so face 0
    // (which needs o_{deg-1}) is summed last.
    // The k-th far end from the cache (index kmin + k modulo deg) or by one step of the walk.
    const bool cached = deg <= Fan::capacity && !(Edges && (face_length || circumcenter));
    int u, hk = hmin, hnext = hmin, j = kmin;
    if (cached) u = fan.get(j);
    else turn(hk, u, hnext);
    const V2 pv = position(v);
    const V2 d_first = rel(pv, u);
    // From the cache the next far end's position is loaded a face ahead: its load is in flight
    // while the current face is summed.
    V2 p_ahead{0, 0};
    if (cached && deg > 1) p_ahead = position(fan.get(j + 1 == deg ? 0 : j + 1));
    // |d|² of each far end once: each enters two circumcentres.
    const double dd_first = norm2(d_first);
    // tR_first: o_0 on the bisector of face 0; tL: o_{k-1} on the bisector of face k.
    V2 dk = d_first;
    double ddk = dd_first, tR_first = 0, tL = 0;
    Sums s;
    for (int k = 0; k < deg; ++k) {
      V2 dn = d_first;
      double ddn = dd_first;
      int hafter = hnext;
      if (k + 1 < deg) {
        if (!cached) {
          turn(hnext, u, hafter);
          dn = rel(pv, u);
        } else {
          dn = rel(pv, p_ahead);
          if (++j == deg) j = 0;
          if (k + 2 < deg) p_ahead = position(fan.get(j + 1 == deg ? 0 : j + 1));
        }
        ddn = norm2(dn);
      }
      const Bisectors t = bisectors(dn, dk, ddn, ddk);  // o_k
      if (k == 0) tR_first = t.tc;
      else face<Edges>(pv, hk, dk, ddk, t.tc, tL, s);
      tL = t.tb;
      dk = dn;
      ddk = ddn;
      hk = hnext;
      hnext = hafter;
    }
    face<Edges>(pv, hmin, d_first, dd_first, tR_first, tL, s);
    sides[v] = deg;
    const R a = R(0.25 * s.area4);
    area[v] = a;
    perimeter[v] = R(s.perimeter);
    // Σ w (o_R + o_L) / (3 Σ w): one division for both coordinates.
    const double inv_3w = 1.0 / (3.0 * s.area4);
    store2(centroid, std::size_t(v), absolute(pv, {s.gx * inv_3w, s.gy * inv_3w}));
    return terms(a, deg);
  }
};

}  // namespace ff::voronoi
