// neighbors.delaunay's table of one-rings (GatherRing), rebuilt each step from the half-edges,
// and the loads and stores the search reads it with; kernel.h's header says why the table looks
// as it does. Per-element math for both backends; nvcc-clean.
#pragma once
#include <cmath>
#include <cstdint>
#include <cstring>

#include "core/base/hd.h"
#include "core/physics/box.h"
#include "stages/delaunay/common/mesh.h"

namespace ff::neighbors {

using delaunay::load_halfedge;

// Set in the gather's word when the one-rings did not fit in the table, and then in every
// search's result.
inline constexpr std::uint32_t kRingOverflow = 0x80000000u;
// Set in a search's result when the radius to expand reaches half the smallest box edge.
inline constexpr std::uint32_t kTooFar = 0x40000000u;
// The padding after the last member of a ring's row in the table, and after the last
// neighbour of a row of the list.
inline constexpr std::uint32_t kRingEnd = 0xFFFFFFFFu;

// The bits of a non-negative float as an unsigned integer, which order as the floats do.
FF_HD std::uint32_t float_bits(float f) {
#if defined(__CUDA_ARCH__)
  return __float_as_uint(f);
#else
  std::uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
#endif
}
FF_HD float bits_float(std::uint32_t u) {
#if defined(__CUDA_ARCH__)
  return __uint_as_float(u);
#else
  float f;
  std::memcpy(&f, &u, sizeof f);
  return f;
#endif
}

// The radius the search expands, from the bits of an upper bound of m² (the largest move since
// the triangulation's positions, squared). margin: Lawson leaves co-circular quads within its
// relative tolerance, and the acceptance test rounds in the run's precision (its minimum image
// to ~ulp(L)): expanding more costs a few distance tests, expanding less could miss a pair.
FF_HD double expand_radius(std::uint32_t m2_bits, double radius, double margin) {
  const double m = std::sqrt(double(bits_float(m2_bits)));
  return (radius + 2 * m) * (1 + 1e-6) + margin;
}

// Four slots at once (16-byte aligned: the ring and list rows are multiples of 4 slots).
FF_HD void load4(const std::uint32_t* p, std::uint32_t v[4]) {
#if defined(__CUDA_ARCH__)
  const uint4 q = __ldg(reinterpret_cast<const uint4*>(p));
  v[0] = q.x;
  v[1] = q.y;
  v[2] = q.z;
  v[3] = q.w;
#else
  for (int k = 0; k < 4; ++k) v[k] = p[k];
#endif
}
FF_HD void store4(std::uint32_t* p, const std::uint32_t v[4]) {
#if defined(__CUDA_ARCH__)
  *reinterpret_cast<uint4*>(p) = make_uint4(v[0], v[1], v[2], v[3]);
#else
  for (int k = 0; k < 4; ++k) p[k] = v[k];
#endif
}

FF_HD void store4(std::uint32_t* p, std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) {
  const std::uint32_t v[4] = {a, b, c, d};
  store4(p, v);
}

// Two ring members' positions at once ({x, y, x, y}, 16-byte aligned).
FF_HD void load4(const float* p, float v[4]) {
#if defined(__CUDA_ARCH__)
  const float4 q = __ldg(reinterpret_cast<const float4*>(p));
  v[0] = q.x;
  v[1] = q.y;
  v[2] = q.z;
  v[3] = q.w;
#else
  for (int k = 0; k < 4; ++k) v[k] = p[k];
#endif
}
FF_HD void store4(float* p, float a, float b, float c, float d) {
#if defined(__CUDA_ARCH__)
  *reinterpret_cast<float4*>(p) = make_float4(a, b, c, d);
#else
  p[0] = a;
  p[1] = b;
  p[2] = c;
  p[3] = d;
#endif
}

// Particle i's two coordinates (one load on the device; the arrays are not written while a
// search runs).
template <class R>
FF_HD void load_xy(const R* pos, std::size_t i, R& x, R& y) {
#if defined(__CUDA_ARCH__)
  if constexpr (sizeof(R) == 8) {
    const double2 p = __ldg(reinterpret_cast<const double2*>(pos) + i);
    x = p.x;
    y = p.y;
  } else {
    const float2 p = __ldg(reinterpret_cast<const float2*>(pos) + i);
    x = p.x;
    y = p.y;
  }
#else
  x = pos[2 * i];
  y = pos[2 * i + 1];
#endif
}

// Where the table of one-rings (GatherRing) keeps vertex u: 4 words at record[4u], read in one
// vector load: its position in the triangulation's positions, wrapped into the box and rounded
// to float (the bits of x and y), the first slot of its ring in the table, and its degree.
// (A candidate's position and its ring's place come from one record: the search touches two
// compact arrays, ~6 table slots and 16 bytes a vertex, instead of per-vertex padded rows.)
struct RingRecord {
  float x, y;
  std::uint32_t start, degree;
};
FF_HD RingRecord load_record(const std::uint32_t* record, std::uint32_t u) {
  std::uint32_t v[4];
  load4(record + 4 * std::size_t(u), v);
  return {bits_float(v[0]), bits_float(v[1]), v[2], v[3]};
}

// Table slots of a ring of d members: rows start on a multiple of 4 (read four slots a load).
FF_HD std::uint32_t ring_slots(std::uint32_t d) { return (d + 3) & ~3u; }

// The first members of a ring, in registers (named, not indexed: an indexed array would live in
// local memory on the device): GatherRing::walk fills them, GatherRing::write stores them.
inline constexpr std::uint32_t kHeldMembers = 8;
struct HeldRing {
  std::uint32_t degree = 0;
  std::uint32_t c0 = kRingEnd, c1 = kRingEnd, c2 = kRingEnd, c3 = kRingEnd;
  std::uint32_t c4 = kRingEnd, c5 = kRingEnd, c6 = kRingEnd, c7 = kRingEnd;
  FF_HD void hold(std::uint32_t k, std::uint32_t e) {
    switch (k) {
      case 0: c0 = e; break;
      case 1: c1 = e; break;
      case 2: c2 = e; break;
      case 3: c3 = e; break;
      case 4: c4 = e; break;
      case 5: c5 = e; break;
      case 6: c6 = e; break;
      case 7: c7 = e; break;
      default: break;
    }
  }
};

// The table of one-rings, rebuilt each step from the half-edges: vertex u's ring (its
// neighbours turning clockwise from vertex_edge[u]) in table[start, start + degree), the row padded
// with kRingEnd to a multiple of 4 slots, and u's record (RingRecord). A periodic triangulation
// has 6N half-edges, so the rows take at most 6N + 3N slots. The rows are placed by the loop
// (loops.h: each block of vertices takes its rows' space with one atomic add, so their order
// in the table is not the vertices' order; only `start` says where a row is).
//   walk(u)        u's degree and first kHeldMembers members (the walk of its half-edges)
//   write(u, ...)  u's row at `start` (walking again only past kHeldMembers members) and record
//   move_bits(u)   the bits of u's squared minimum-image move since the triangulation's
//                  positions, rounded up to a float, so an integer max-reduction gives an upper
//                  bound of m² (all the expansion radius needs)
template <class R>
struct GatherRing {
  const std::int32_t* he;     // delaunay.halfedge: {origin, next} per half-edge
  const std::int32_t* vedge;  // delaunay.vertex_edge
  std::uint32_t n;            // vertices: no valid ring is longer (guards a corrupt mesh)
  std::uint32_t* table;       // the rows, table_slots long
  std::uint32_t table_slots;
  std::uint32_t* record;      // 4 words per vertex
  delaunay::Points<R> now;    // position
  const R* prev;              // delaunay.position_prev

  FF_HD HeldRing walk(std::size_t u) const {
    HeldRing r;
    const int h0 = vedge[u];
    int h = h0;
    std::uint32_t k = 0;
    do {
      // One load a member: twin(h) = h ^ 1 starts at h's other end, and its next is the next
      // half-edge out of u clockwise (the search needs the members, not their order).
      int end, next;
      load_halfedge(he, h ^ 1, end, next);
      r.hold(k, std::uint32_t(end));
      ++k;
      h = next;
    } while (h != h0 && k < n);
    r.degree = k;
    return r;
  }

  FF_HD void write(std::size_t u, std::uint32_t start, const HeldRing& r) const {
    std::uint32_t* row = table + start;
    store4(row, r.c0, r.c1, r.c2, r.c3);
    if (r.degree > 4) store4(row + 4, r.c4, r.c5, r.c6, r.c7);
    if (r.degree > kHeldMembers) {  // rare: walk again for the members past the held ones
      const int h0 = vedge[u];
      int h = h0;
      for (std::uint32_t k = 0; k < r.degree; ++k) {
        int end, next;
        load_halfedge(he, h ^ 1, end, next);
        if (k >= kHeldMembers) row[k] = std::uint32_t(end);
        h = next;
      }
      for (std::uint32_t k = r.degree; k < ring_slots(r.degree); ++k) row[k] = kRingEnd;
    }
    R ux, uy;
    load_xy(prev, u, ux, uy);
    store4(record + 4 * u, float_bits(wrapped(ux, 0)), float_bits(wrapped(uy, 1)), start, r.degree);
  }

  FF_HD std::uint32_t move_bits(std::size_t u) const {
    R xu, yu, pu, qu;
    load_xy(now.p, u, xu, yu);
    load_xy(prev, u, pu, qu);
    const double dx = now.image(double(xu) - double(pu), 0);
    const double dy = now.image(double(yu) - double(qu), 1);
    const double d2 = dx * dx + dy * dy;
    const float f = float(d2);
    const std::uint32_t b = float_bits(f);
    return double(f) < d2 ? b + 1 : b;  // the next float up
  }

  // Coordinate c along axis k wrapped into [0, L] (up to rounding) and rounded to float.
  FF_HD float wrapped(R c, int k) const {
    const double d = double(c);
    return float(d - now.box.L[k] * std::floor(d * now.box.inv_L[k]));
  }
};

}  // namespace ff::neighbors
