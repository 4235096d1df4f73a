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
//   visited  breadth-first with a queue that is also the visited set, in kFastSlots slots of
//            fast memory (CUDA: the thread's column of shared memory, read with shared-memory
//            loads; CPU: the stack); a search that needs more runs again with its queue in the
//            row of neighbors.list (FastQueue, RowQueue). A 128-bit filter in registers
//            answers "not seen" for most new vertices without a scan of the queue (newest entry
//            first), and a vertex seen before is skipped before its distance is computed again.
//            The expansion of a queued vertex skips its parent and the parent's two neighbours
//            in its ring, which the parent's expansion tested (apex_mask): 3 of ~6 members, most
//            of the queue scans. One flat loop tests up to four ring members an iteration (their
//            records loaded together) and refills from the next ring or queued vertex, so the
//            lanes of a warp stay in step whatever their rings. The lanes meet after the loop,
//            and the accepted entries are then compacted, sorted (up to 16 by a sorting network
//            in registers) and written to the row, once a warp.
//   parent   depth-first without a visited set: q's parent is its ring member closest to p
//            (ties: lower index), which the lemma makes closer to p than q, so the parent links
//            form a tree rooted at p; the search descends from u to w iff parent(w) = u. The
//            row holds the tree's vertices from its front and the depth-first stack (pairs of a
//            vertex and the table slot to resume its scan at) from its back.
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

// Returned by a search whose queue outgrew its fast slots: the caller searches again with the
// queue in the row of the list (not a result the stage sees).
inline constexpr std::uint32_t kNeedRow = 0x20000000u;

// CUDA: the lanes of `lanes` wait here for each other, so the code after runs once for all of
// them instead of once per group that arrived together. Every lane of `lanes` must call it. CPU:
// nothing (lanes is 0).
FF_HD void converge(std::uint32_t lanes) {
#if defined(__CUDA_ARCH__)
  __syncwarp(lanes);
#else
  (void)lanes;
#endif
}

// CUDA: the lanes of `lanes` (which all call it) for which `pred` holds. CPU: 0.
FF_HD std::uint32_t lanes_where(std::uint32_t lanes, bool pred) {
#if defined(__CUDA_ARCH__)
  return __ballot_sync(lanes, pred);
#else
  (void)lanes;
  (void)pred;
  return 0;
#endif
}

// The visited search's queue in fast memory: kFastSlots slots `Stride` apart (a column of a
// shared-memory block on CUDA, so the threads of a warp never share a bank; the stack on the
// CPU). Its pointer never changes, so on the device every access is a shared-memory load at a
// constant stride (a queue that could move to the row made them generic loads with 64-bit
// address arithmetic, which cost time: bench/README.md, "Session 16 on an H200").
template <std::uint32_t Stride>
struct FastQueue {
  std::uint32_t* fast;
  std::uint32_t lim;  // min(kFastSlots, row length)
  FF_HD std::uint32_t get(std::uint32_t a) const { return fast[a * Stride]; }
  FF_HD void set(std::uint32_t a, std::uint32_t v) const { fast[a * Stride] = v; }
  FF_HD std::uint32_t limit() const { return lim; }
  FF_HD bool can_grow() const { return true; }  // into the row: search again
};

// The queue in the row of the list, for the searches that need more than kFastSlots.
struct RowQueue {
  std::uint32_t* row;
  std::uint32_t cap;
  FF_HD std::uint32_t get(std::uint32_t a) const { return row[a]; }
  FF_HD void set(std::uint32_t a, std::uint32_t v) const { row[a] = v; }
  FF_HD std::uint32_t limit() const { return cap; }
  FF_HD bool can_grow() const { return false; }
};

// Traversal `visited`: breadth-first, the queue as visited set. `fast`: kFastSlots slots,
// Stride apart.
template <class R>
struct SearchVisited : SearchBase<R> {
  // First with the queue in fast memory; a search that needs more slots (none at r = 2σ in the
  // hard-disk benchmark, where at most ~14 are queued) starts again with it in the row.
  // lanes (CUDA): the lanes of the calling warp that search, all of which call this together;
  // the CPU passes 0 (see converge).
  template <std::uint32_t Stride>
  FF_HD std::uint32_t search(std::size_t pi, std::uint32_t* fast, std::uint32_t lanes) const {
    const std::uint32_t cap = this->capacity;
    const std::uint32_t r = run(pi, FastQueue<Stride>{fast, cap < kFastSlots ? cap : kFastSlots}, lanes);
    const std::uint32_t again = lanes_where(lanes, r == kNeedRow);
    if (r != kNeedRow) return r;
    return run(pi, RowQueue{this->list + pi * cap, cap}, again);
  }

  // The traversal loop ends after a different number of iterations in each lane; lanes that
  // finished first would run the rest (compaction, sorting network, row stores) on their own and
  // the others again after them (frnn5's ncu of the nested search: the tail issued 4.4 times a
  // warp with ~7 of 32 lanes active). So the loop has one exit, also when the queue is full, and
  // the lanes wait for each other there (converge): the tail issues once a warp.
  template <class Q>
  FF_HD std::uint32_t run(std::size_t pi, const Q& q, std::uint32_t lanes) const {
    const std::uint32_t p = std::uint32_t(pi);
    // These two return before the meeting point in every lane alike (one word for all).
    if (*this->move2 & kRingOverflow) return kRingOverflow;
    const double e2 = this->expand2();
    if (e2 < 0) return kTooFar;
    const RingRecord rp = load_record(this->record, p);
    // p where its record has it (wrapped, float), as its ring members are: the margin covers
    // the rounding of both ends. The expansion test runs in float (float_expand2).
    const float px = rp.x, py = rp.y;
    const float e2f = this->float_expand2(e2);
    const float lx = float(this->old.box.L[0]), ly = float(this->old.box.L[1]);
    // Bit (hash of w) set for every w in the queue: 128 bits in two named words (an indexed pair
    // would live in local memory on the device).
    std::uint64_t filter_lo = 0, filter_hi = 0;
    std::uint32_t n = 0, head = 0;
    // Which entry queued each of the first 16 queue entries (4 bits each: queue index + 1 of
    // the parent, 0 for p; an entry queued by entry i has a queue index above i, so it fits),
    // and the entry being expanded (cur: its index + 1). Later entries skip nothing.
    std::uint32_t cur = 0;
    std::uint64_t parents = 0;
    // One flat loop, up to four ring members an iteration: the row being expanded is held eight
    // slots at a time (row, from slot `base`), and `todo` has a bit for each held slot still to
    // test (within the degree, not skipped by apex_mask). When it empties, the next eight slots
    // or the next queued vertex's row are loaded. So the lanes of a warp each test members in
    // every iteration, whatever their rows' lengths and skips (nested loops over queue, chunks
    // and members left ~10 of 32 lanes active: bench/experiments/README.md, frnn5).
    std::uint32_t start = rp.start, degree = rp.degree, base = 0, skip = 0;
    Row8 row;
    row.load(this->table + start, degree);
    std::uint32_t todo = low_bits(degree < 8 ? degree : 8);
    std::uint32_t full = 0;  // what run returns when the queue had no slot for a vertex
    for (;;) {
      while (todo == 0) {
        if (base + 8 < degree) {  // a ring of more than 8: its next slots
          base += 8;
          row.load(this->table + start + base, degree - base);
          todo = low_bits(degree - base < 8 ? degree - base : 8) & ~(base < 32 ? skip >> base : 0u);
          continue;
        }
        if (head == n) break;
        const RingRecord ru = load_record(this->record, q.get(head));
        start = ru.start;
        degree = ru.degree;
        base = 0;
        row.load(this->table + start, degree);
        skip = 0;
        if (head < 16) {
          const std::uint32_t f = std::uint32_t((parents >> (4 * head)) & 15u);
          const std::uint32_t v = f == 0 ? p : q.get(f - 1);
          skip = degree <= 8 ? row.apex_mask(degree, v) : apex_mask(this->table + start, degree, v);
        }
        cur = ++head;
        todo = low_bits(degree < 8 ? degree : 8) & ~skip;
      }
      if (todo == 0) break;
      // Up to four members an iteration (as many as the held slots have left): their records
      // are loaded together (four loads in flight), then the members are tested in turn.
      const std::uint32_t w1 = row.pick(lowest_bit_index(todo));
      todo &= todo - 1;
      const bool has2 = todo != 0;
      const std::uint32_t w2 = has2 ? row.pick(lowest_bit_index(todo)) : w1;
      todo &= has2 ? todo - 1 : todo;
      const bool has3 = todo != 0;
      const std::uint32_t w3 = has3 ? row.pick(lowest_bit_index(todo)) : w1;
      todo &= has3 ? todo - 1 : todo;
      const bool has4 = todo != 0;
      const std::uint32_t w4 = has4 ? row.pick(lowest_bit_index(todo)) : w1;
      todo &= has4 ? todo - 1 : todo;
      const RingRecord r1 = load_record(this->record, w1);
      const RingRecord r2 = load_record(this->record, w2);
      const RingRecord r3 = load_record(this->record, w3);
      const RingRecord r4 = load_record(this->record, w4);
      // 0 when w was seen, too far or queued; else what run returns (the queue is full).
      const auto visit = [&](std::uint32_t w, const RingRecord& rw) -> std::uint32_t {
        const std::uint32_t hash = (w * 0x9E3779B1u) >> 25;  // 7 bits
        const std::uint64_t bit = std::uint64_t(1) << (hash & 63);
        const bool hi = (hash >> 6) != 0;
        if ((hi ? filter_hi : filter_lo) & bit) {
          bool seen = false;
          // Newest first: a member seen before was mostly queued by a recent expansion (CPU
          // counters, bench-frnn 2^16: 4.9 scan steps a particle instead of 17 from the oldest).
          for (std::uint32_t a = n; a-- > 0 && !seen;) seen = q.get(a) == w;
          if (seen) return 0;
        }
        if (w == p) return 0;
        const float dx = image_once(rw.x - px, lx);
        const float dy = image_once(rw.y - py, ly);
        if (dx * dx + dy * dy > e2f) return 0;
        if (n == q.limit()) return q.can_grow() && q.limit() < this->capacity ? kNeedRow : this->overflow(p);
        if (hi) filter_hi |= bit;
        else filter_lo |= bit;
        if (n < 16) parents |= std::uint64_t(cur) << (4 * n);
        q.set(n++, w);
        return 0;
      };
      full = visit(w1, r1);
      if (!full && has2) full = visit(w2, r2);
      if (!full && has3) full = visit(w3, r3);
      if (!full && has4) full = visit(w4, r4);
      if (full) break;
    }
    converge(lanes);
    if (full) return full;
    // The accepted ones, compacted to the front in queue order, then sorted (rows are short).
    R x0, y0;
    load_xy(this->x, p, x0, y0);
    std::uint32_t m = 0;
    for (std::uint32_t a = 0; a < n; ++a) {
      const std::uint32_t w = q.get(a);
      if (this->accepted(x0, y0, w)) q.set(m++, w);
    }
    if (m <= 16) {
      this->write_sorted16(p, x0, y0, m, [&](std::uint32_t a) { return a < m ? q.get(a) : kRingEnd; });
      return n;
    }
    for (std::uint32_t a = 1; a < m; ++a) {
      const std::uint32_t v = q.get(a);
      std::uint32_t b = a;
      for (; b > 0 && q.get(b - 1) > v; --b) q.set(b, q.get(b - 1));
      q.set(b, v);
    }
    this->write_row(p, x0, y0, m, [&](std::uint32_t a) { return q.get(a); });
    return n;
  }
};

// Traversal `parent`: depth-first over the tree of parent links, no visited set.
template <class R>
struct SearchParent : SearchBase<R> {
  // The ring member of w closest to p in the old positions (ties: the lower index).
  FF_HD std::uint32_t parent(double px, double py, std::uint32_t w) const {
    const RingRecord rw = load_record(this->record, w);
    const std::uint32_t* ring = this->table + rw.start;
    std::uint32_t best = ring[0];
    double best_d2 = this->old_d2(px, py, best);
    for (std::uint32_t k = 1; k < rw.degree; ++k) {
      const std::uint32_t v = ring[k];
      const double d2 = this->old_d2(px, py, v);
      if (d2 < best_d2 || (d2 == best_d2 && v < best)) {
        best = v;
        best_d2 = d2;
      }
    }
    return best;
  }

  FF_HD std::uint32_t operator()(std::size_t pi) const {
    const std::uint32_t p = std::uint32_t(pi);
    if (*this->move2 & kRingOverflow) return kRingOverflow;
    const double e2 = this->expand2();
    if (e2 < 0) return kTooFar;
    const std::uint32_t cap = this->capacity;
    std::uint32_t* row = this->list + std::size_t(p) * cap;
    R ox, oy;
    load_xy(this->old.p, p, ox, oy);
    const double px = double(ox), py = double(oy);
    // The vertex being scanned, its next table slot and its end.
    std::uint32_t u = p;
    RingRecord ru = load_record(this->record, p);
    std::uint32_t slot = ru.start, end = ru.start + ru.degree;
    // Tree vertices in row[0, n); from the back, the stack of (vertex, slot to resume at) pairs.
    std::uint32_t n = 0, top = cap;
    std::uint32_t used = 0;  // the most slots held at once
    for (;;) {
      if (slot == end) {
        if (top == cap) break;
        u = row[top++];  // resume the parent's scan after the child it descended into
        slot = row[top++];
        ru = load_record(this->record, u);
        end = ru.start + ru.degree;
        continue;
      }
      const std::uint32_t w = this->table[slot++];
      if (w == p || this->old_d2(px, py, w) > e2) continue;
      if (parent(px, py, w) != u) continue;
      if (n + 3 > top) return this->overflow(p);  // w and the resume pair must fit
      row[n++] = w;
      row[--top] = slot;
      row[--top] = u;
      used = used > n + (cap - top) ? used : n + (cap - top);
      u = w;
      ru = load_record(this->record, w);
      slot = ru.start;
      end = ru.start + ru.degree;
    }
    R x0, y0;
    load_xy(this->x, p, x0, y0);
    std::uint32_t m = 0;
    for (std::uint32_t a = 0; a < n; ++a)
      if (this->accepted(x0, y0, row[a])) row[m++] = row[a];
    for (std::uint32_t a = 1; a < m; ++a) {  // insertion sort: rows are short
      const std::uint32_t v = row[a];
      std::uint32_t b = a;
      for (; b > 0 && row[b - 1] > v; --b) row[b] = row[b - 1];
      row[b] = v;
    }
    this->write_row(p, x0, y0, m, [&](std::uint32_t a) { return row[a]; });
    return used;
  }
};

}  // namespace ff::neighbors
