// delaunay.detect_inversion per-element math: inverted-triangle detection (Carter et al. 2017,
// sec. 4.3), also used by
// delaunay.flip after each repair round.
//
// Per edge e = (a, b) with c left and d right (common/mesh.h), coordinates by minimum image
// from a:
//  * r⁰·r¹ < 0 for the edge vector before/after the step: a and b went through each other.
//  * both triangles non-positive: the edge was crossed twice (or flattened from both sides).
//  * exactly one triangle non-positive and both triangles of the flipped edge (c, a, d) and
//    (d, b, c) positive: one vertex crossed this one edge into the other triangle, and flipping
//    the edge repairs it. This is Carter's barycentric test (eqs. 5–8): the mover lies inside
//    the triangle formed by the edge and the other opposite vertex. The edge is marked.
//  * the triangles must close under minimum image (every edge shorter than half the box).
// A second pass (CheckInverted) requires each inverted triangle to have exactly one marked
// edge; anything else (a vertex across two edges, a vertex across a vertex) is not repairable
// by single flips. FF_HD; nvcc-clean.
#pragma once
#include <cstdint>

#include "core/backend/atomics.h"
#include "stages/delaunay/common/fields.h"
#include "stages/delaunay/common/mesh.h"

namespace ff::delaunay {

// Counter slots (unsigned); *_at slots hold the lowest edge / half-edge id of the event (they
// start at ~0u and come last, so a reset is two fills).
enum InversionCounter : int {
  kInverted = 0,      // inverted (non-positive) triangles, each counted once
  kMarked,            // edges marked for a repair flip
  kThrough,           // edges whose vector reversed (r⁰·r¹ < 0)
  kTwice,             // edges with both triangles inverted
  kUnrepairable,      // inverted triangles without exactly one repairing edge
  kTooLong,           // edges with a triangle that does not close under minimum image
  kRepairFlips,       // flips done by DecideFlips (delaunay.flip)
  kCandidateCount,    // edges appended to `candidates` (may exceed its capacity)
  kThroughAt,         // lowest edge counted in kThrough
  kTwiceAt,           // lowest edge counted in kTwice
  kUnrepairableAt,    // lowest canonical half-edge of a triangle counted in kUnrepairable
  kTooLongAt,         // lowest edge counted in kTooLong
  kInversionCounters
};

// Start values of the counters: counts 0, the *_at slots ~0u (they keep a minimum).
FF_HD void reset_inversion_counters(unsigned* c) {
  for (int k = 0; k < kInversionCounters; ++k) c[k] = k >= kThroughAt ? ~0u : 0u;
}

// Whether an attempt decided on the device goes on without the host (StepContext::gate open),
// from the final counters: nothing inverted, marked, through each other, crossed twice or too
// long, and every Lawson candidate listed (within `capacity`): delaunay.lawson's gated launch
// takes any number of them (its tail kernel alone, or a grid round first: lawson/stage.h).
// The host's decision (DetectInversion::decide) is the same function of the same counters.
FF_HD bool device_decision_open(const unsigned* c, unsigned capacity) {
  return c[kInverted] == 0 && c[kMarked] == 0 && c[kThrough] == 0 && c[kTwice] == 0 && c[kUnrepairable] == 0 &&
         c[kTooLong] == 0 && c[kCandidateCount] <= capacity;
}

template <class R>
struct MarkInversions {
  Mesh mesh;
  Points<R> pts;
  const R* prev;  // positions at which the triangulation was valid; nullptr: skip r⁰·r¹
  std::uint8_t* mark;
  unsigned* counters;
  // When set: every edge with both triangles positive that is not locally Delaunay
  // (in-circle > 0 and a convex quad: a superset of delaunay.lawson's first round) is appended,
  // so Lawson's first round need not test every edge again (same quads, same positions).
  std::int32_t* candidates = nullptr;
  unsigned capacity = 0;
  int edges = 0;  // 3N: bound for the host's prefetch (0: none)
  // The counters' other bank (Counters::next), set to its start values for the stage's next
  // run, or nullptr: instead of fills before that run's loop (one host call and a GPU gap
  // fewer on the step's critical path). Nothing else touches that bank during this loop.
  unsigned* reset_next = nullptr;
  // The device loop only: copy points [0, copy_points) of copy_from (the positions) to copy_to
  // (position_prev's new storage, which the rollback snapshot handed the field: `prev` is the old
  // one, so no element read here is written), one point per thread of the first copy_points
  // edges. Saves the copy's own pass and launch after this loop; 0: no copy.
  const R* copy_from = nullptr;
  R* copy_to = nullptr;
  std::size_t copy_points = 0;
  // The device loop only (detect_inversion/cuda.cu): when set, the loop's last block writes the
  // final counters to `publish` (pinned host memory, Counters::landing) itself, so no copy
  // follows the loop before the host's wait; `blocks_done` (device memory, 0 between launches)
  // counts the blocks that finished.
  unsigned* publish = nullptr;
  unsigned* blocks_done = nullptr;
  // With `publish`, in an attempt decided on the device (StepContext::gate): the last block
  // also writes 0 to *gate when device_decision_open (else 1), and the candidates' count to
  // *candidate_count, 0 when the gate closes (delaunay.lawson's gated launch reads both; its grid
  // kernels only the count).
  unsigned* gate = nullptr;
  std::int32_t* candidate_count = nullptr;

  // The device loop: one edge per thread, each candidate appended on its own.
  FF_HD void operator()(std::size_t i) const {
    if (i == 0 && reset_next) reset_inversion_counters(reset_next);
    if (i < copy_points) {
      copy_to[2 * i] = copy_from[2 * i];
      copy_to[2 * i + 1] = copy_from[2 * i + 1];
    }
    const int e = int(i);
    if (test(e)) append(&e, 1);
  }
  // Appends the k edges es[0..k) to `candidates` (one counter update for all of them).
  FF_HD void append(const int* es, unsigned k) const {
    const unsigned at = append_index(counters + kCandidateCount, k);
    for (unsigned j = 0; j < k && at + j < capacity; ++j) candidates[at + j] = es[j];
  }

  // Everything for edge e (marks, counters) but the candidate list: returns whether e is a
  // Lawson candidate (always false without `candidates`). The host loop batches the appends:
  // one shared counter bumped per candidate from both threads moves its cache line between the
  // cores on every append. The host loop also restates this function's "nothing happens" case
  // for four edges at a time (detect_inversion/cpu.cpp, quiet4): a change here must be mirrored
  // there (the test comparing the two loops edge by edge fails otherwise).
  FF_HD bool test(int e) const {
    if (e + kPrefetchAhead < edges) prefetch_quad_points(mesh, pts.p, prev, e + kPrefetchAhead);
    // The common case (nothing inverted) needs only the quad's vertices: two contiguous records
    // per field, no `next` chasing. Topology beyond them is read only for rare events.
    const QuadVertices q = quad_vertices(mesh, e);
    const V2 ab = pts.rel(q.a, q.b), ac = pts.rel(q.a, q.c), ad = pts.rel(q.a, q.d);
    // Both triangles from every edge (so each triangle three times): the count is of edges.
    if (!closes(ab, ac, pts.box) || !closes(ab, ad, pts.box)) record(counters, kTooLong, kTooLongAt, unsigned(e));
    if (prev) {
      const Points<R> before{prev, pts.box};
      if (dot(before.rel(q.a, q.b), ab) < 0) record(counters, kThrough, kThroughAt, unsigned(e));
    }
    const V2 o{0, 0};
    const double left = orient(o, ab, ac);   // (a, b, c)
    const double right = orient(ab, o, ad);  // (b, a, d)
    // Each inverted triangle is counted once, from the edge of its lowest half-edge.
    if (left <= 0 && mesh.canonical(2 * e)) count_one(counters + kInverted);
    if (right <= 0 && mesh.canonical(2 * e + 1)) count_one(counters + kInverted);
    bool m = false;
    if (left <= 0 && right <= 0) {
      record(counters, kTwice, kTwiceAt, unsigned(e));
    } else if (left <= 0 || right <= 0) {
      m = orient(ac, o, ad) > 0 && orient(ad, ab, ac) > 0;  // (c, a, d) and (d, b, c)
    }
    mark[e] = m ? 1 : 0;
    if (m) count_one(counters + kMarked);
    // Lawson candidates: d inside the circle (cheap determinant from the orientations above;
    // Lawson's own test, with its tolerance, decides later) and both new triangles surely
    // positive, exactly as wants_flip checks them.
    return candidates && left > 0 && right > 0 && incircle_from_a(ab, ac, ad, left, right) > 0 &&
           orient_surely(ac, o, ad) > 0 && orient_surely(ad, ab, ac) > 0;
  }
};

// Per half-edge: an inverted triangle (seen from its canonical half-edge) must have exactly one
// marked edge.
template <class R>
struct CheckInverted {
  Mesh mesh;
  Points<R> pts;
  const std::uint8_t* mark;
  unsigned* counters;

  FF_HD void operator()(std::size_t i) const {
    const int h = int(i);
    if (!mesh.canonical(h)) return;
    const int hn = mesh.next(h), hp = mesh.next(hn);
    const int a = mesh.origin(h), b = mesh.origin(hn), c = mesh.origin(hp);
    const V2 o{0, 0};
    if (orient(o, pts.rel(a, b), pts.rel(a, c)) > 0) return;
    const int marked = mark[h >> 1] + mark[hn >> 1] + mark[hp >> 1];
    if (marked != 1) record(counters, kUnrepairable, kUnrepairableAt, unsigned(h));
  }
};

}  // namespace ff::delaunay
