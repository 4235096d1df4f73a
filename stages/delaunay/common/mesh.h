// Per-element topology and geometry shared by every delaunay stage and both backends:
// the half-edge view of the triangulation, minimum-image vectors, the orientation and
// in-circle predicates, and the edge flip itself. FF_HD only; nvcc-clean.
//
// Predicates are evaluated in double for both precisions: the inputs are differences of the
// stored coordinates (exact or nearly so in double), so float runs get accurate signs too.
#pragma once
#include <cmath>
#include <cstdint>

#include "core/physics/box.h"
#include "core/base/hd.h"

namespace ff::delaunay {

// ---- topology ---------------------------------------------------------------------------
// Half-edge h: he[2h] = origin vertex, he[2h+1] = next half-edge (CCW around its triangle).
// twin(h) = h ^ 1, edge(h) = h >> 1. A triangle is a cycle h -> next -> next -> h.
FF_HD int twin(int h) { return h ^ 1; }

// {origin, next} of half-edge h in one load (a read-only 8-byte load on the device).
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

struct Mesh {
  std::int32_t* he;     // 2 x 6N
  std::int32_t* vedge;  // N: one outgoing half-edge per vertex
  // 6N: vertex opposite each half-edge (fields::opposite). May be null in read-only views that
  // walk triangles by `next`; every view that flips edges or calls quad_vertices has it.
  std::int32_t* opp = nullptr;

  FF_HD int origin(int h) const { return he[2 * h]; }
  FF_HD int next(int h) const { return he[2 * h + 1]; }
  FF_HD int opposite(int h) const { return opp[h]; }
  // Whether the device may read and write an edge's records as vectors: he[4e .. 4e+3] as one
  // 16-byte access (he_vectors: quad) and, with them, opp[2e .. 2e+1] as one 8-byte access
  // (vector_records: quad_vertices, flip_edge). The edge loops and a round of flips are bound by
  // their memory instructions, not by bytes. Field storage is cudaMalloc'ed (256-byte aligned); a
  // view at another offset takes the scalar accesses, which read and write the same words.
  FF_HD bool he_vectors() const { return (reinterpret_cast<std::uintptr_t>(he) & 15u) == 0; }
  FF_HD bool vector_records() const {
    return ((reinterpret_cast<std::uintptr_t>(he) | reinterpret_cast<std::uintptr_t>(opp)) & 15u) == 0;
  }
  // True for exactly one half-edge of each triangle (its lowest id): count triangles once.
  FF_HD bool canonical(int h) const {
    const int n = next(h);
    return h < n && h < next(n);
  }
};

// The quad around edge e: a -> b is half-edge 2e, c closes the triangle on its left (a, b, c),
// d the triangle on its right (b, a, d); both CCW. hXn / hXp are next / previous of hX.
struct Quad {
  int h0, h1, h0n, h0p, h1n, h1p;
  int a, b, c, d;
};

FF_HD Quad quad(const Mesh& m, int e) {
  Quad q;
  q.h0 = 2 * e;
  q.h1 = 2 * e + 1;
#if defined(__CUDA_ARCH__)
  // Edge e's two records in one 16-byte load (a plain load: flips write the mesh meanwhile, so
  // not through the read-only cache), as quad_vertices.
  if (m.he_vectors()) {
    const int4 r = *reinterpret_cast<const int4*>(m.he + 4 * e);
    q.a = r.x;
    q.h0n = r.y;
    q.b = r.z;
    q.h1n = r.w;
  } else
#endif
  {
    q.a = m.origin(q.h0);
    q.h0n = m.next(q.h0);
    q.b = m.origin(q.h1);
    q.h1n = m.next(q.h1);
  }
  q.h0p = m.next(q.h0n);
  q.h1p = m.next(q.h1n);
  q.c = m.origin(q.h0p);
  q.d = m.origin(q.h1p);
  return q;
}

// The quad's vertices alone, from two contiguous records per field (no pointer chasing): what
// the per-edge tests need. Equal to quad(m, e)'s a, b, c, d while `opp` is current.
struct QuadVertices {
  int a, b, c, d;
};
FF_HD QuadVertices quad_vertices(const Mesh& m, int e) {
#if defined(__CUDA_ARCH__)
  // The two records of edge e in one 16-byte load and its opposite vertices in one 8-byte load
  // instead of four 4-byte ones (Mesh::vector_records).
  if (m.vector_records()) {
    const int4 r = *reinterpret_cast<const int4*>(m.he + 4 * e);
    const int2 o = *reinterpret_cast<const int2*>(m.opp + 2 * e);
    return {r.x, r.z, o.x, o.y};
  }
#endif
  return {m.origin(2 * e), m.origin(2 * e + 1), m.opposite(2 * e), m.opposite(2 * e + 1)};
}

// Software prefetch for the edge loops on the host (no-op on the device, where many warps in
// flight hide latency instead). Once the mesh and coordinates outgrow the L2 cache, a loop that
// reads edge e's quad waits on a chain of misses (list entry -> records -> coordinates); asking
// for edge e + k's data k elements ahead overlaps those waits.
template <class R>
FF_HD void prefetch_quad_points(const Mesh& m, const R* p, const R* p2, int e) {
#if !defined(__CUDA_ARCH__)
  const QuadVertices q = quad_vertices(m, e);
  __builtin_prefetch(p + 2 * q.a);
  __builtin_prefetch(p + 2 * q.b);
  __builtin_prefetch(p + 2 * q.c);
  __builtin_prefetch(p + 2 * q.d);
  if (p2) {
    __builtin_prefetch(p2 + 2 * q.a);
    __builtin_prefetch(p2 + 2 * q.b);
  }
#endif
}
FF_HD void prefetch_quad_records(const Mesh& m, int e) {
#if !defined(__CUDA_ARCH__)
  __builtin_prefetch(m.he + 4 * e);
  __builtin_prefetch(m.opp + 2 * e);
#endif
}
// How many elements ahead the host loops prefetch.
constexpr int kPrefetchAhead = 8;

// opp[h] for every half-edge of a valid `he` (host or device element loop, one h per call).
FF_HD int opposite_of(const std::int32_t* he, int h) { return he[2 * he[2 * he[2 * h + 1] + 1]]; }

// Relaxed atomic load/store of a topology word that a concurrent flip may also touch
// (vertex_edge); plain accesses on the device, where word accesses are atomic.
FF_HD int load_relaxed(const std::int32_t* p) {
#if defined(__CUDA_ARCH__)
  return *(volatile const std::int32_t*)p;
#else
  return __atomic_load_n(p, __ATOMIC_RELAXED);
#endif
}
FF_HD void store_relaxed(std::int32_t* p, int v) {
#if defined(__CUDA_ARCH__)
  *(volatile std::int32_t*)p = v;
#else
  __atomic_store_n(p, v, __ATOMIC_RELAXED);
#endif
}

// Replace edge (a, b) by (c, d). Writes only the six half-edges of the two triangles (their
// `he` and `opp` records, plus vertex_edge of a and b when it pointed at the removed edge), so
// flips of edges that share no triangle can run concurrently. Afterwards h0 = d -> c in triangle (d, c, a) and
// h1 = c -> d in triangle (c, d, b), both CCW when the quad a, d, b, c is convex.
FF_HD void flip_edge(const Mesh& m, int e) {
  const Quad q = quad(m, e);
  // a's and b's vertex edges read before the stores, not after them: on the device loads issued
  // behind a flip's scattered stores wait for them (bench/experiments/README.md, "Lawson's tail
  // and detect's end"). No other flip of the round changes either word while it is h0 or h1 (only
  // this flip removes those half-edges), so the tests below decide as they would after the stores.
  const int va = load_relaxed(m.vedge + q.a), vb = load_relaxed(m.vedge + q.b);
#if defined(__CUDA_ARCH__)
  // Edge e's two records in one 16-byte store and its opposite vertices in one 8-byte store, as
  // quad_vertices loads them (Mesh::vector_records): a round of flips from one SM is bound by its
  // scattered stores (lawson/cuda.cu). The same words as the scalar stores below.
  if (m.vector_records()) {
    *reinterpret_cast<int4*>(m.he + 4 * e) = make_int4(q.d, q.h0p, q.c, q.h1p);  // d -> c -> a, c -> d -> b
    *reinterpret_cast<int2*>(m.opp + 2 * e) = make_int2(q.a, q.b);
  } else
#endif
  {
    m.he[2 * q.h0] = q.d;
    m.he[2 * q.h1] = q.c;
    m.he[2 * q.h0 + 1] = q.h0p;  // d -> c -> a
    m.he[2 * q.h1 + 1] = q.h1p;  // c -> d -> b
    m.opp[q.h0] = q.a;  // (d, c, a): d -> c faces a, c -> a faces d, a -> d faces c
    m.opp[q.h1] = q.b;  // (c, d, b): c -> d faces b, d -> b faces c, b -> c faces d
  }
  m.he[2 * q.h0p + 1] = q.h1n;  // c -> a -> d
  m.he[2 * q.h1n + 1] = q.h0;   // a -> d -> c
  m.he[2 * q.h1p + 1] = q.h0n;  // d -> b -> c
  m.he[2 * q.h0n + 1] = q.h1;   // b -> c -> d
  m.opp[q.h0p] = q.d;
  m.opp[q.h1n] = q.c;
  m.opp[q.h1p] = q.c;
  m.opp[q.h0n] = q.d;
  if (va == q.h0) store_relaxed(m.vedge + q.a, q.h1n);
  if (vb == q.h1) store_relaxed(m.vedge + q.b, q.h0n);
}

// ---- geometry ---------------------------------------------------------------------------
struct V2 {
  double x, y;
};
FF_HD V2 operator-(V2 p, V2 q) { return {p.x - q.x, p.y - q.y}; }
FF_HD double cross(V2 p, V2 q) { return p.x * q.y - p.y * q.x; }
FF_HD double dot(V2 p, V2 q) { return p.x * q.x + p.y * q.y; }

// Positions (N x 2, precision R) seen through the periodic box.
template <class R>
struct Points {
  const R* p;
  PeriodicBox<double> box;

  // Minimum-image vector from particle i to particle j. The same value as
  // box.min_image(d, k) = d - L rint(d / L), but the rounding is skipped when |d| <= L/2 (almost
  // every edge: positions are wrapped and edges are short), which the edge loops feel.
  FF_HD double image(double d, int k) const {
    return std::fabs(d) > 0.5 * box.L[k] ? d - box.L[k] * std::rint(d * box.inv_L[k]) : d;
  }
  FF_HD V2 rel(int i, int j) const {
    const V2 a = at(i), b = at(j);
    return {image(b.x - a.x, 0), image(b.y - a.y, 1)};
  }
  // Particle i's coordinates in double. On the device one vector load (16 bytes in double, 8 in
  // float) instead of one per coordinate: the edge loops gather four to six points an edge, and
  // each load instruction of a warp's scattered points costs the L1 a wavefront per line. The
  // same values as two scalar loads; storage is cudaMalloc'ed (checked, else scalar loads).
  FF_HD V2 at(int i) const {
#if defined(__CUDA_ARCH__)
    if ((reinterpret_cast<std::uintptr_t>(p) & (2 * sizeof(R) - 1)) == 0) {
      if constexpr (sizeof(R) == 8) {
        const double2 v = *reinterpret_cast<const double2*>(p + 2 * i);
        return {v.x, v.y};
      } else {
        const float2 v = *reinterpret_cast<const float2*>(p + 2 * i);
        return {double(v.x), double(v.y)};
      }
    }
#endif
    return {double(p[2 * i]), double(p[2 * i + 1])};
  }
};

// True when v is its own minimum image with a margin: |v_k| < L_k / 2.
FF_HD bool is_min_image(V2 v, const PeriodicBox<double>& box) {
  return std::fabs(v.x) < 0.5 * box.L[0] && std::fabs(v.y) < 0.5 * box.L[1];
}

// A triangle closes when its three minimum-image sides sum to zero. With every edge shorter than
// half the box this holds up to rounding; an edge that grew past half the box shows up as a
// residual of a whole box length.
FF_HD bool closes(V2 ab, V2 ac, V2 bc_min_image, const PeriodicBox<double>& box) {
  const V2 r = (ac - ab) - bc_min_image;
  return std::fabs(r.x) < 0.25 * box.L[0] && std::fabs(r.y) < 0.25 * box.L[1];
}
// The same test without the third side: ac - ab is congruent to c - b modulo the box, so it is
// b -> c's minimum image (and the sides sum to zero) exactly when it is a minimum image itself.
FF_HD bool closes(V2 ab, V2 ac, const PeriodicBox<double>& box) { return is_min_image(ac - ab, box); }

// orient(p, q, r) > 0 when p, q, r turn counter-clockwise.
FF_HD double orient(V2 p, V2 q, V2 r) { return cross(q - p, r - p); }

// In-circle determinant: > 0 when d lies inside the circle through the CCW triangle (a, b, c).
// `perm` receives the permanent (the same sum with absolute values), which bounds the rounding
// error: |computed - exact| <= ~1e-15 * perm for exact inputs (Shewchuk's iccerrboundA).
// In two parts, so that a caller that only needs the sign for det <= 0 skips the permanent.
struct InCircle {
  double adx, ady, bdx, bdy, cdx, cdy, alift, blift, clift, det;
  FF_HD double permanent() const {
    return alift * (std::fabs(bdx * cdy) + std::fabs(cdx * bdy)) + blift * (std::fabs(cdx * ady) + std::fabs(adx * cdy)) +
           clift * (std::fabs(adx * bdy) + std::fabs(bdx * ady));
  }
};
FF_HD InCircle incircle_terms(V2 a, V2 b, V2 c, V2 d) {
  InCircle t;
  t.adx = a.x - d.x, t.ady = a.y - d.y;
  t.bdx = b.x - d.x, t.bdy = b.y - d.y;
  t.cdx = c.x - d.x, t.cdy = c.y - d.y;
  t.alift = t.adx * t.adx + t.ady * t.ady;
  t.blift = t.bdx * t.bdx + t.bdy * t.bdy;
  t.clift = t.cdx * t.cdx + t.cdy * t.cdy;
  const double bc = t.bdx * t.cdy - t.cdx * t.bdy, ca = t.cdx * t.ady - t.adx * t.cdy, ab = t.adx * t.bdy - t.bdx * t.ady;
  t.det = t.alift * bc + t.blift * ca + t.clift * ab;
  return t;
}
FF_HD double incircle(V2 a, V2 b, V2 c, V2 d, double& perm) {
  const InCircle t = incircle_terms(a, b, c, d);
  perm = t.permanent();
  return t.det;
}

// The in-circle determinant of the quad around edge (a, b) (c left, d right), as vectors from a,
// given the two orientations detection has already computed: left = cross(ab, ac) and
// right = orient(ab, o, ad) = -cross(ab, ad). With a at the origin the 4x4 determinant is a 3x3
// one, expanded along its lift column; same sign as incircle(a, b, c, d) (> 0: d inside the
// circle through a, b, c) up to rounding, at a third of the cost. Used only as a pre-filter
// (detect_inversion's Lawson candidates, tolerance 0), never as Lawson's decision.
FF_HD double incircle_from_a(V2 ab, V2 ac, V2 ad, double left, double right) {
  return -(dot(ab, ab) * cross(ac, ad) + dot(ac, ac) * right + dot(ad, ad) * left);
}

// orient(p, q, r) minus its rounding-error scale: > 0 only when surely counter-clockwise.
FF_HD double orient_surely(V2 p, V2 q, V2 r) {
  const V2 u = q - p, v = r - p;
  return (u.x * v.y - u.y * v.x) - 1e-12 * (std::fabs(u.x * v.y) + std::fabs(u.y * v.x));
}

// Lawson's test for the quad around edge (a, b), c left and d right, given as vectors from a:
// d lies inside the circle through the CCW triangle (a, b, c) by more than `tol` times the
// in-circle permanent, and both triangles of the flipped edge, (c, a, d) and (d, b, c), are
// surely positive. With tol = 0 it accepts a superset of what any tol >= 0 accepts.
FF_HD bool wants_flip(V2 ab, V2 ac, V2 ad, double tol) {
  const V2 o{0, 0};
  const InCircle t = incircle_terms(o, ab, ac, ad);
  if (!(t.det > 0)) return false;  // tol x permanent >= 0: most edges stop here
  return t.det > tol * t.permanent() && orient_surely(ac, o, ad) > 0 && orient_surely(ad, ab, ac) > 0;
}

}  // namespace ff::delaunay
