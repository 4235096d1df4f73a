// delaunay.lawson per-element math. FF_HD; nvcc-clean.
//
// Which edges are not locally Delaunay: edge e = (a, b) with c left and d right is flipped when
// d lies inside the circle through the CCW triangle (a, b, c) by more than `tol` times the
// in-circle permanent (the rounding-error scale of the determinant, so the tolerance follows the
// geometry: co-circular points, as in a square lattice, are left alone instead of flipping back
// and forth), and when the flip keeps both triangles positive by more than their own rounding
// scale. A flip whose new edge (c, d) would be longer than half the box is not done but reported
// (the triangulation could not store it).
//
// Rounds work on lists. Round 0 tests every edge; a round's marked edges are decided
// (lowest id wins both triangles, as common/flip.h) and applied, and only the edges whose quad
// changed — the flipped edge and the four around it — plus the marked edges that lost are tested
// again in the next round: every other edge keeps both triangles, so its answer cannot change.
// On the device lists are filled with atomic appends (their order varies from run to run; the
// CPU fills them chunk by chunk, cpu.cpp) but the *sets* are fixed, and every decision depends only on the set of marked edges, so the triangulation is the
// same for any thread count, launch order or backend. Per-edge stamps (`marked == round`,
// `queued == round`) replace clearing arrays between rounds.
#pragma once
#include <cmath>
#include <cstdint>

#include "core/backend/atomics.h"
#include "stages/delaunay/common/mesh.h"

namespace ff::delaunay {

enum LawsonCounter : int {
  kLawsonMarked = 0,  // edges marked in this round (length of the marked list)
  kLawsonQueued,      // length of the list of edges to test in the next round
  kLawsonFlips,       // flips in this step so far
  kLawsonRounds,      // rounds in this step that marked (and so flipped) something
  kLawsonTailRounds,  // rounds the last device tail kernel ran (LawsonTail)
  kLawsonTailLargest, // the most edges one of those rounds marked
  kLawsonTooLong,     // flips refused: the new edge would exceed half the box
  kLawsonTooLongAt,   //   lowest such edge
  kLawsonCounters
};

// Start values of the counters: counts 0, kLawsonTooLongAt ~0u (it keeps a minimum).
FF_HD void reset_lawson_counters(unsigned* c) {
  for (int k = 0; k < kLawsonCounters; ++k) c[k] = k == kLawsonTooLongAt ? ~0u : 0u;
}


// Claim edge e for `round` in `stamps`; true for the first claimant only.
FF_HD bool claim(std::int32_t* stamps, int e, std::int32_t round) {
#if defined(__CUDA_ARCH__)
  return atomicExch(reinterpret_cast<int*>(stamps + e), round) != round;
#else
  return __atomic_exchange_n(stamps + e, round, __ATOMIC_RELAXED) != round;
#endif
}

// Round pass 1: test the listed edges (all edges when `list` is null) and list the marked ones.
template <class R>
struct MarkNonDelaunay {
  Mesh mesh;
  Points<R> pts;
  double tol;                // relative to the in-circle permanent
  const std::int32_t* list;  // edges to test, or nullptr for 0 .. n-1
  const unsigned* list_len;  // backend-side length of `list` (the launch covers an upper bound),
                             // or nullptr: the length is list_count (the launch's own size)
  std::int32_t* marked;      // per edge: round in which it was last marked
  std::int32_t round;
  std::int32_t* marked_list;
  unsigned* counters;
  unsigned list_count = 0;
  // The counters' other bank, set to its start values by element 0 of the device loop (as
  // MarkInversions::reset_next), or nullptr.
  unsigned* reset_next = nullptr;

  // How many elements the launch really has (the list's length; n for all edges).
  FF_HD std::size_t length(std::size_t n) const { return list ? (list_len ? *list_len : list_count) : n; }
  // The edge of element i < length (prefetching those a few elements ahead on the host).
  FF_HD int edge_at(std::size_t i, std::size_t len) const {
    if (!list) return int(i);
    if (i + 2 * kPrefetchAhead < len) prefetch_quad_records(mesh, list[i + 2 * kPrefetchAhead]);
    if (i + kPrefetchAhead < len) prefetch_quad_points(mesh, pts.p, (const R*)nullptr, list[i + kPrefetchAhead]);
    return list[i];
  }
  // Tests edge e; true (and stamps it) when it is to be flipped in this round.
  FF_HD bool marks(int e) const {
    const QuadVertices q = quad_vertices(mesh, e);
    const V2 ab = pts.rel(q.a, q.b), ac = pts.rel(q.a, q.c), ad = pts.rel(q.a, q.d);
    if (!wants_flip(ab, ac, ad, tol)) return false;
    if (!is_min_image(ad - ac, pts.box)) {
      record(counters, kLawsonTooLong, kLawsonTooLongAt, unsigned(e));
      return false;
    }
    marked[e] = round;
    return true;
  }
  // The device loop: one element per thread, appended to the shared list.
  FF_HD void operator()(std::size_t i) const {
    if (i == 0 && reset_next) reset_lawson_counters(reset_next);
    const std::size_t len = length(~std::size_t(0));
    if (i >= len) return;
    const int e = edge_at(i, len);
    if (marks(e)) marked_list[append_index(counters + kLawsonMarked, 1)] = e;
  }
};

// Round pass 2: a marked edge flips when no edge around it is marked with a lower id.
struct DecideMarked {
  Mesh mesh;
  const std::int32_t* marked;
  std::int32_t round;
  const std::int32_t* marked_list;
  std::uint8_t* go;  // per edge, meaningful for listed edges only
  unsigned* counters;
  const unsigned* len = nullptr;  // backend-side length of marked_list (the launch covers an
                                  // upper bound), or nullptr: the launch's own size

  // Decides marked edge e (go[e]); true when it flips.
  FF_HD bool wins(int e) const {
    const int h0n = mesh.next(2 * e), h1n = mesh.next(2 * e + 1);
    const int around[4] = {h0n >> 1, mesh.next(h0n) >> 1, h1n >> 1, mesh.next(h1n) >> 1};
    bool win = true;
    for (int k = 0; k < 4; ++k) win = win && !(around[k] < e && marked[around[k]] == round);
    go[e] = win ? 1 : 0;
    return win;
  }
  FF_HD void operator()(std::size_t i) const {
    if (len && i >= *len) return;
    if (i == 0) count_one(counters + kLawsonRounds);
    if (wins(marked_list[i])) count_one(counters + kLawsonFlips);
  }
};

// Round pass 3: flip the winners and queue what the next round must test (each edge once,
// through the `queued` stamps): the four edges around each flip (their quads changed) and the
// marked edges that lost (a neighbour's flip changed their quad). A flipped edge itself is not
// queued: its new quad is the same four points, on which the new edge is locally Delaunay (the
// in-circle determinant changes sign with the flip; at the default tolerance tol x permanent
// is far above its rounding, so no retest could mark it), and no other flip of the round touches its two triangles (the winners share none).
struct ApplyMarked {
  Mesh mesh;
  const std::int32_t* marked_list;
  const std::uint8_t* go;
  std::int32_t* queued;      // per edge: round for which it was last queued
  std::int32_t next_round;
  std::int32_t* next_list;
  unsigned* counters;
  const unsigned* len = nullptr;  // as DecideMarked::len

  // Flips marked edge e when it won; writes the edges whose quads this changes (the four around
  // it, or e itself when it lost) to out and returns how many. Two elements may list the same
  // edge: the caller keeps each once (`queued`).
  FF_HD int flip_and_list(int e, int out[4]) const {
#if defined(__CUDA_ARCH__)
    // On the device e's records are read before its decision (not after): both loads wait on the
    // list entry only, so a winner's chain of dependent loads is one shorter (latency-bound). A
    // losing e's records may be written meanwhile by a neighbouring winner's flip; its value is
    // then not used (a word access on the device is atomic).
    const int h0n = mesh.next(2 * e), h1n = mesh.next(2 * e + 1);
    if (!go[e]) {
      out[0] = e;
      return 1;
    }
#else
    // On the host after it: that early read of a loser's records would race (C++: undefined) with
    // the winner's plain stores, even with the value discarded. The same flips either way.
    if (!go[e]) {
      out[0] = e;
      return 1;
    }
    const int h0n = mesh.next(2 * e), h1n = mesh.next(2 * e + 1);
#endif
    out[0] = h0n >> 1;
    out[1] = mesh.next(h0n) >> 1;
    out[2] = h1n >> 1;
    out[3] = mesh.next(h1n) >> 1;
    flip_edge(mesh, e);
    return 4;
  }
  // flip_and_list, keeping only the edges this element claims (no other element queues them
  // again in this round); returns how many it wrote to out.
  FF_HD int apply(int e, int out[4]) const {
    int listed[4];
    const int m = flip_and_list(e, listed);
    int n = 0;
    for (int k = 0; k < m; ++k)
      if (claim(queued, listed[k], next_round)) out[n++] = listed[k];
    return n;
  }
  FF_HD void operator()(std::size_t i) const {
    if (len && i >= *len) return;
    int out[4];
    const int n = apply(marked_list[i], out);
    if (n) {
      const unsigned at = append_index(counters + kLawsonQueued, unsigned(n));
      for (int k = 0; k < n; ++k) next_list[at + unsigned(k)] = out[k];
    }
  }
};

// The device's later rounds in one kernel of one block (lawson/cuda.cu), each round the three
// passes above over the device-side list lengths with block barriers between them: from the
// round whose marks are listed (`round`), while the marked list is not empty and at most
// `max_marked` long, at most `max_rounds` rounds. The count it ran goes to
// counters[kLawsonTailRounds], the longest marked list among them to kLawsonTailLargest, and,
// when `publish` is set, every counter to publish (pinned host memory: Counters::landing) as
// the kernel ends. The same rounds as separate launches, so the same flips; one launch instead
// of three per round (a round of a few edges costs little more than its launches).
template <class R>
struct LawsonTail {
  Mesh mesh;
  Points<R> pts;
  double tol;
  std::int32_t* marked;
  std::int32_t* queued;
  std::uint8_t* go;
  std::int32_t* list;
  std::int32_t* marked_list;
  unsigned* counters;
  std::int32_t round;
  unsigned max_marked;
  std::int64_t max_rounds;
  unsigned* publish = nullptr;
  // Round 0's marks made by the tail kernel itself (first_count > 0; MarkNonDelaunay over
  // first_list, stamped `round`, its element 0 setting first_reset_next to the counters' start
  // values) instead of by a grid launch before it: the marks of `round` then start from zero.
  const std::int32_t* first_list = nullptr;
  unsigned first_count = 0;
  unsigned* first_reset_next = nullptr;
  // An attempt delaunay.detect_inversion decided on the device (StepContext::gate): round 0's
  // list length is *first_count_at (detect's kernel wrote it), and none while *gate is non-zero
  // (the kernel then flips nothing and only sets first_reset_next to the start values).
  const unsigned* gate = nullptr;
  const std::int32_t* first_count_at = nullptr;
  // The mesh's edges (3N): the backend's launch shape follows the system's size (lawson/cuda.cu).
  std::size_t edges = 0;
};

}  // namespace ff::delaunay
