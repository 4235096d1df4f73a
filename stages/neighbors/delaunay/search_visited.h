// neighbors.delaunay, traversal `visited` (kernel.h says why a search over Delaunay edges is exact
// and holds what both traversals share):
// breadth-first with a queue that is also the visited set, in kFastSlots slots of
// fast memory (CUDA: the thread's column of shared memory, read with shared-memory
// loads; CPU: the stack); a search that needs more runs again with its queue in the
// row of neighbors.list (FastQueue, RowQueue). A 128-bit filter in registers
// answers "not seen" for most new vertices without a scan of the queue (newest entry
// first), and a vertex seen before is skipped before its distance is computed again.
// The expansion of a queued vertex skips its parent and the parent's two neighbours
// in its ring, which the parent's expansion tested (apex_mask): 3 of ~6 members, most
// of the queue scans. One flat loop tests up to four ring members an iteration (their
// records loaded together) and refills from the next ring or queued vertex, so the
// lanes of a warp stay in step whatever their rings. The lanes meet after the loop,
// and the accepted entries are then compacted, sorted (up to 16 by a sorting network
// in registers) and written to the row, once a warp.
// nvcc-clean.

#pragma once

#include <cstdint>

#include "core/base/hd.h"
#include "stages/neighbors/delaunay/kernel.h"

namespace ff::neighbors {

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

}  // namespace ff::neighbors
