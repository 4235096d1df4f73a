// neighbors.delaunay: fixed-radius neighbours by graph search on the maintained Delaunay
// triangulation (Porro et al.; spec seed-gaps P1), per-element math for both backends.
//
// Why a search over Delaunay edges finds every neighbour: in a Delaunay triangulation, every
// q ≠ p has a Delaunay neighbour s with |ps| < |pq| (walk the segment q → p; where it leaves
// q's Voronoi cell, the cell beyond belongs to such an s). So each q within r of p is joined to
// p by a path of edges along which the distance to p strictly decreases: a search from p that
// expands only vertices within r of p reaches all of them.
//
// The triangulation is Delaunay for delaunay.position_prev (the positions delaunay.lawson
// worked on), and overlap correction may have moved particles since. With m the largest move
// since (GatherRing::move_bits gives each vertex's), a pair within r now was within r + 2m then, so the
// search walks the old positions expanding vertices within r_expand = r + 2m (plus a relative
// margin for Lawson's co-circular tolerance and rounding; expand_radius), and a vertex it
// reaches is accepted when its current distance is within r, by the same formula as
// neighbors.verlet's BuildList (so both sources list the same pairs at the same cutoff, bit for
// bit). The search reads m from the word the gather's max-reduction left in memory, so the host
// does not wait between the two loops.
//
// Layout (ring_table.h): GatherRing writes a table of one-rings each step: vertex u's neighbours
// (turning clockwise from vertex_edge) in one row of the table, padded to a multiple of 4 slots
// and read four at a time, and a 16-byte record of u (its position as the search needs it,
// float; its row's start; its degree), so the search touches ~6 slots and one record per vertex: ~48 bytes a vertex in
// all, which the GPU's L2 holds at 2^20 particles where per-vertex padded rows with positions
// beside them (192 bytes) did not.
// Two traversals share this header's SearchBase (radii, positions, the ring table, the output):
//   visited  breadth-first with a queue that is also the visited set (search_visited.h);
//   parent   depth-first over the tree of parent links, no visited set (search_parent.h).
// Both write the row's slots up to the next multiple of 4 past the count (kRingEnd after the
// last neighbour), the same slots on both backends. Either returns (through a max-reduction)
// the most slots it held at once, or capacity + 1 when the row overflowed, kRingOverflow when
// the one-rings did not fit in the table (only a corrupt triangulation: a periodic one has 6N
// half-edges) and kTooFar when r_expand reaches half the box: the stage then grows the row and
// searches again, or stops, so an overflow is never silent.
// nvcc-clean.
#pragma once
#include <cmath>
#include <cstdint>
#include <cstring>

#include "core/base/hd.h"
#include "core/physics/box.h"
#include "stages/delaunay/common/mesh.h"
#include "stages/neighbors/delaunay/ring_table.h"

namespace ff::neighbors {

// Queue slots of the visited search kept out of the list (shared memory on CUDA). At r = 2σ a
// search queues at most ~14; 16 slots (8 KB a block) leave the SM more L1 than 32 did (3 %
// faster at 2^20 on an H200), 8 send too many searches to the row (8 % slower).
inline constexpr std::uint32_t kFastSlots = 16;

// The slots of a ring row (bit k: slot k) that the expansion of its vertex u need not test when
// v, a vertex expanded before u (the search uses the entry whose expansion queued u), is in u's
// ring: v itself and v's two neighbours in u's ring, the apexes of the two triangles on edge uv.
// Both apexes are in v's ring too, so v's expansion tested them (queued them, or found them
// beyond the radius: the same test would reject them again). Skipping them saves the test and,
// for queued ones, the scan of the queue. 0 when v is not among the first 32 slots.
FF_HD std::uint32_t apex_mask(const std::uint32_t* row, std::uint32_t degree, std::uint32_t v) {
  if (degree > 32) return 0;
  std::uint32_t at = degree;
  for (std::uint32_t k = 0; k < degree && at == degree; k += 4) {
    std::uint32_t c[4];
    load4(row + k, c);
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
    for (std::uint32_t j = 0; j < 4; ++j)
      if (k + j < degree && at == degree && c[j] == v) at = k + j;
  }
  if (at == degree) return 0;
  const std::uint32_t before = at == 0 ? degree - 1 : at - 1, after = at + 1 == degree ? 0 : at + 1;
  return (1u << before) | (1u << at) | (1u << after);
}

// The lowest k bits set (k ≤ 32).
FF_HD std::uint32_t low_bits(std::uint32_t k) { return k >= 32 ? ~0u : (1u << k) - 1; }

// The index of the lowest set bit of x ≠ 0.
FF_HD std::uint32_t lowest_bit_index(std::uint32_t x) {
#if defined(__CUDA_ARCH__)
  return std::uint32_t(__ffs(int(x)) - 1);
#else
  return std::uint32_t(__builtin_ctz(x));
#endif
}

// Eight consecutive slots of a ring row in named registers (an indexed array would live in
// local memory on the device), kRingEnd past the row's end.
struct Row8 {
  std::uint32_t c0, c1, c2, c3, c4, c5, c6, c7;
  // The slots from `row` (16-byte aligned), `left` of them in the ring.
  FF_HD void load(const std::uint32_t* row, std::uint32_t left) {
    std::uint32_t a[4];
    load4(row, a);
    c0 = a[0];
    c1 = a[1];
    c2 = a[2];
    c3 = a[3];
    c4 = c5 = c6 = c7 = kRingEnd;
    if (left > 4) {
      load4(row + 4, a);
      c4 = a[0];
      c5 = a[1];
      c6 = a[2];
      c7 = a[3];
    }
  }
  // Slot k (0..7), by a tree of selects.
  FF_HD std::uint32_t pick(std::uint32_t k) const {
    const std::uint32_t a = k & 1 ? c1 : c0, b = k & 1 ? c3 : c2, c = k & 1 ? c5 : c4, d = k & 1 ? c7 : c6;
    const std::uint32_t e = k & 2 ? b : a, f = k & 2 ? d : c;
    return k & 4 ? f : e;
  }
  // apex_mask for a whole ring of degree ≤ 8 held here: compares instead of a loop.
  FF_HD std::uint32_t apex_mask(std::uint32_t degree, std::uint32_t v) const {
    std::uint32_t at = std::uint32_t(c0 == v) | std::uint32_t(c1 == v) << 1 | std::uint32_t(c2 == v) << 2 |
                       std::uint32_t(c3 == v) << 3 | std::uint32_t(c4 == v) << 4 | std::uint32_t(c5 == v) << 5 |
                       std::uint32_t(c6 == v) << 6 | std::uint32_t(c7 == v) << 7;
    at &= ~at + 1;  // the first, as apex_mask's scan finds it
    const std::uint32_t after = (at << 1 | at >> (degree - 1)) & low_bits(degree);
    const std::uint32_t before = at >> 1 | (at & 1u) << (degree - 1);
    return at | after | before;
  }
};

// d (a difference of two coordinates in [0, L]) shifted by L once when beyond L/2: its
// minimum image up to the rounding float_expand2 allows for.
FF_HD float image_once(float d, float l) {
  const float h = 0.5f * l;
  return d > h ? d - l : (d < -h ? d + l : d);
}

// What both traversals share: the radii, the two position sets, the ring table and the output.
template <class R>
struct SearchBase {
  delaunay::Points<R> old;      // delaunay.position_prev: the positions the mesh is Delaunay for
  const R* x;                   // position now
  PeriodicBox<R> box;           // the acceptance test's minimum image (BuildList's)
  R accept2;                    // r², in the run's precision
  double radius;                // r, and expand_radius's margin, which covers the float rounding
  double margin;                // of the records' positions too: ≤ half an ulp of the box edge
  double lmin;                  // the smallest box edge
  const std::uint32_t* move2;   // GatherRing's max-reduction: the bits of an upper bound of m²
  const std::uint32_t* table;   // GatherRing's
  const std::uint32_t* record;
  std::uint32_t capacity;       // row length of the list, a multiple of 4
  std::uint32_t* list;          // n x capacity
  std::uint32_t* count;         // accepted neighbours per row
  R* at_build;                  // neighbors.position_at_build: the positions the rows are exact for

  // r_expand², or a negative number when r_expand reaches half the smallest box edge.
  FF_HD double expand2() const {
    const double re = expand_radius(*move2, radius, margin);
    return 2 * re < lmin ? re * re : -1.0;
  }

  // The bound of the expansion test computed in float from two records' positions (wrapped
  // into [0, L], so a difference is within ±L and one shift of L gives its minimum image): per
  // axis the two roundings of the differences and L's own rounding to float cost at most
  // 1.25 eps_f L, so the distance at most 2 eps_f L, and the squares and their sum at most
  // 2 eps_f relative. r_expand² (e2) widened by that, rounded up to a float.
  FF_HD float float_expand2(double e2) const {
    constexpr double eps_f = 1.1920928955078125e-07;
    const double lmax = old.box.L[0] > old.box.L[1] ? old.box.L[0] : old.box.L[1];
    const double re = std::sqrt(e2) + 2 * eps_f * lmax;
    const double w = re * re * (1 + 4 * eps_f);
    const float f = float(w);
    return double(f) < w ? bits_float(float_bits(f) + 1) : f;
  }

  // Squared distance from p (its old position (px, py)) to vertex w, in the old positions.
  FF_HD double old_d2(double px, double py, std::uint32_t w) const {
    R wx, wy;
    load_xy(old.p, w, wx, wy);
    const double dx = old.image(double(wx) - px, 0);
    const double dy = old.image(double(wy) - py, 1);
    return dx * dx + dy * dy;
  }

  // Within r now: neighbors.verlet's test (verlet/kernel.h BuildList), term for term.
  FF_HD bool accepted(R px, R py, std::uint32_t j) const {
    R jx, jy;
    load_xy(x, j, jx, jy);
    const R dx = box.min_image(jx - px, 0);
    const R dy = box.min_image(jy - py, 1);
    R d2 = 0;
    d2 += dx * dx;
    d2 += dy * dy;
    return d2 <= accept2;
  }

  // Writes the row: the m entries (ascending) of `sorted`, then kRingEnd to the next multiple of
  // 4; count[p] and position_at_build[p].
  template <class Get>
  FF_HD void write_row(std::uint32_t p, R px, R py, std::uint32_t m, const Get& sorted) const {
    std::uint32_t* row = list + std::size_t(p) * capacity;
    // Streaming stores (evict first): the rows, counts and positions written here (~80 MB at
    // 2^20) are read by the next stages, not by this search, and would push the ring table and
    // records out of the L2 that the searches of the other particles read them from.
    for (std::uint32_t a = 0; a < m; a += 4) {
      std::uint32_t v[4];
      for (std::uint32_t b = 0; b < 4; ++b) v[b] = a + b < m ? sorted(a + b) : kRingEnd;
#if defined(__CUDA_ARCH__)
      __stcs(reinterpret_cast<uint4*>(row + a), make_uint4(v[0], v[1], v[2], v[3]));
#else
      store4(row + a, v);
#endif
    }
#if defined(__CUDA_ARCH__)
    __stcs(count + p, m);
    __stcs(at_build + 2 * std::size_t(p), px);
    __stcs(at_build + 2 * std::size_t(p) + 1, py);
#else
    count[p] = m;
    at_build[2 * std::size_t(p)] = px;
    at_build[2 * std::size_t(p) + 1] = py;
#endif
  }

  // A row of m ≤ 16 entries (get(a) for a < m; kRingEnd past m), sorted by Batcher's odd-even
  // merge network of 16 (63 compare-exchanges) in registers: no data-dependent loop (an
  // insertion sort's loops diverge within a warp and chain shared-memory loads). The kRingEnd
  // entries sort last and are the row's padding. Writes what write_row writes.
  template <class Get>
  FF_HD void write_sorted16(std::uint32_t p, R px, R py, std::uint32_t m, const Get& get) const {
    std::uint32_t r0 = get(0);
    std::uint32_t r1 = get(1);
    std::uint32_t r2 = get(2);
    std::uint32_t r3 = get(3);
    std::uint32_t r4 = get(4);
    std::uint32_t r5 = get(5);
    std::uint32_t r6 = get(6);
    std::uint32_t r7 = get(7);
    std::uint32_t r8 = get(8);
    std::uint32_t r9 = get(9);
    std::uint32_t r10 = get(10);
    std::uint32_t r11 = get(11);
    std::uint32_t r12 = get(12);
    std::uint32_t r13 = get(13);
    std::uint32_t r14 = get(14);
    std::uint32_t r15 = get(15);
    const auto ce = [](std::uint32_t& a, std::uint32_t& b) {
      const std::uint32_t lo = a < b ? a : b;
      b = a < b ? b : a;
      a = lo;
    };
    ce(r0, r1);
    ce(r2, r3);
    ce(r0, r2);
    ce(r1, r3);
    ce(r1, r2);
    ce(r4, r5);
    ce(r6, r7);
    ce(r4, r6);
    ce(r5, r7);
    ce(r5, r6);
    ce(r0, r4);
    ce(r2, r6);
    ce(r2, r4);
    ce(r1, r5);
    ce(r3, r7);
    ce(r3, r5);
    ce(r1, r2);
    ce(r3, r4);
    ce(r5, r6);
    ce(r8, r9);
    ce(r10, r11);
    ce(r8, r10);
    ce(r9, r11);
    ce(r9, r10);
    ce(r12, r13);
    ce(r14, r15);
    ce(r12, r14);
    ce(r13, r15);
    ce(r13, r14);
    ce(r8, r12);
    ce(r10, r14);
    ce(r10, r12);
    ce(r9, r13);
    ce(r11, r15);
    ce(r11, r13);
    ce(r9, r10);
    ce(r11, r12);
    ce(r13, r14);
    ce(r0, r8);
    ce(r4, r12);
    ce(r4, r8);
    ce(r2, r10);
    ce(r6, r14);
    ce(r6, r10);
    ce(r2, r4);
    ce(r6, r8);
    ce(r10, r12);
    ce(r1, r9);
    ce(r5, r13);
    ce(r5, r9);
    ce(r3, r11);
    ce(r7, r15);
    ce(r7, r11);
    ce(r3, r5);
    ce(r7, r9);
    ce(r11, r13);
    ce(r1, r2);
    ce(r3, r4);
    ce(r5, r6);
    ce(r7, r8);
    ce(r9, r10);
    ce(r11, r12);
    ce(r13, r14);
    std::uint32_t* row = list + std::size_t(p) * capacity;
#if defined(__CUDA_ARCH__)
    if (m > 0) __stcs(reinterpret_cast<uint4*>(row), make_uint4(r0, r1, r2, r3));
    if (m > 4) __stcs(reinterpret_cast<uint4*>(row + 4), make_uint4(r4, r5, r6, r7));
    if (m > 8) __stcs(reinterpret_cast<uint4*>(row + 8), make_uint4(r8, r9, r10, r11));
    if (m > 12) __stcs(reinterpret_cast<uint4*>(row + 12), make_uint4(r12, r13, r14, r15));
    __stcs(count + p, m);
    __stcs(at_build + 2 * std::size_t(p), px);
    __stcs(at_build + 2 * std::size_t(p) + 1, py);
#else
    if (m > 0) store4(row, r0, r1, r2, r3);
    if (m > 4) store4(row + 4, r4, r5, r6, r7);
    if (m > 8) store4(row + 8, r8, r9, r10, r11);
    if (m > 12) store4(row + 12, r12, r13, r14, r15);
    count[p] = m;
    at_build[2 * std::size_t(p)] = px;
    at_build[2 * std::size_t(p) + 1] = py;
#endif
  }

  // Row overflow: nothing valid in the row; the stage grows it and searches again.
  FF_HD std::uint32_t overflow(std::uint32_t p) const {
    count[p] = 0;
    return capacity + 1;
  }
};

}  // namespace ff::neighbors
