// delaunay.flip per-element math: the repair round is decide + apply (common/flip.h) followed
// by the detection pass of delaunay.detect_inversion (MarkInversions, without the r⁰·r¹ test),
// which re-marks whatever inverted triangles remain. For `on_unrepairable: substep` (Porro et
// al. §3, "intermediate position"), passes over lists: which particles have an inverted
// triangle around them or an edge whose vector reversed since the valid positions (r⁰·r¹ < 0);
// those go a level deeper (half as far from where the triangulation was valid), and after a
// try that works every particle not at its target goes a level shallower.
// FF_HD; nvcc-clean.
#pragma once
#include <cmath>
#include <cstdint>

#include "stages/delaunay/common/flip.h"
#include "stages/delaunay/detect_inversion/kernel.h"

namespace ff::delaunay {

// Sub-stepping works on lists (untangle.h): each try re-marks only the edges whose
// status can have changed (those around particles that moved, the ones a flip changed, the
// ones troubled before), and the particles, edges and topology records a try touches are
// gathered in lists, so a try costs what the trouble costs, not a pass over N. A list is an
// array of ids with its length in a counter slot; ids are appended by atomics (their order
// differs between runs and backends, the set does not), so every list pass below gives the
// same result in any order: marks and flips depend only on the marks (common/flip.h), counts
// are sums and minima.

// Slots of the sub-stepping's counter block, after the detection counters (detect_inversion's
// kernel.h): list lengths and the step's statistics.
enum SubstepCounter : int {
  kTroubledCount = kInversionCounters,  // edges appended to a marking's troubled list
  kWorkCount,                           // edges in the next work list
  kMovingCount,                         // particles that go a level deeper
  kActiveCount,                         // particles not at their target (depth > 0)
  kTouchedEdgeCount,                    // edges whose records a flip changed since V's topology
  kTouchedVertexCount,                  // vertices whose vertex_edge a flip may have changed
  kHalvedCount,                         // distinct particles halved at least once in the step
  kDepthNot,                            // ~(deepest depth reached in the step): a minimum slot
  kSubstepCounters
};

// Claims id for the list being built: true for exactly one caller per stamp value.
FF_HD bool claim(unsigned* stamp, unsigned gen) {
  unsigned old = *stamp;
  while (old != gen) {
    const unsigned seen = compare_and_swap(stamp, old, gen);
    if (seen == old) return true;
    old = seen;
  }
  return false;
}

// The elements of a list a thread of a loop takes: i, i + launched, ... below the list's length,
// read on the backend when `length` is set (a loop launched over a guess of the length, so that
// the host need not read it first: every element is taken whatever the guess), else `launched`.
struct ListSpan {
  const unsigned* length;
  std::size_t launched;
  template <class F>
  FF_HD void each(std::size_t i, const F& f) const {
    const std::size_t n = length ? std::size_t(*length) : launched;
    for (std::size_t j = i; j < n; j += launched) f(j);
  }
};

// Appends id to `list` (length in *count) once per stamp generation.
FF_HD void append_once(std::int32_t* list, unsigned* count, unsigned* stamp, unsigned gen, int id) {
  if (claim(stamp + id, gen)) list[append_index(count, 1)] = id;
}

// The detection pass (MarkInversions, with or without the r⁰·r¹ test) on a list of edges
// (`list` null: every edge), appending the troubled ones: an edge is troubled unless it is
// quiet, i.e. both its triangles close and are positive and (with `prev`) its vector did not
// reverse; a quiet edge gets mark 0 and nothing else, exactly as MarkInversions::test leaves it
// (same expressions), every other edge goes through test() itself. Troubled are thus the marked
// edges, the edges of inverted triangles, the reversed ones: every edge whose mark is 1 or whose
// triangles count, so a later marking need visit only these and the edges whose quads or
// vertices changed.
template <class R>
struct MarkListed {
  MarkInversions<R> marking;  // without candidates (delaunay.flip never lists them)
  const std::int32_t* list;
  ListSpan span;
  std::int32_t* troubled;
  unsigned* counters;  // kTroubledCount

  FF_HD bool quiet(int e) const {
    const QuadVertices q = quad_vertices(marking.mesh, e);
    const Points<R>& pts = marking.pts;
    const V2 ab = pts.rel(q.a, q.b), ac = pts.rel(q.a, q.c), ad = pts.rel(q.a, q.d);
    if (!closes(ab, ac, pts.box) || !closes(ab, ad, pts.box)) return false;
    if (marking.prev) {
      const Points<R> before{marking.prev, pts.box};
      if (dot(before.rel(q.a, q.b), ab) < 0) return false;
    }
    const V2 o{0, 0};
    return orient(o, ab, ac) > 0 && orient(ab, o, ad) > 0;
  }
  FF_HD void one(int e) const {
    if (quiet(e)) {
      marking.mark[e] = 0;
      return;
    }
    marking.test(e);
    troubled[append_index(counters + kTroubledCount, 1)] = e;
  }
  FF_HD void operator()(std::size_t i) const {
    span.each(i, [&](std::size_t j) { one(list ? list[j] : int(j)); });
  }
};

// What a round's winning flips will change, recorded before any of them flips (DecideListed):
// each flip's edge and the four around it (their half-edge and opposite records: the edges whose
// quads change) and its two end vertices (vertex_edge). The first flip of a generation (since
// V's topology was last kept or put back) to touch a record saves its value, V's, into the
// copy (`kept_*`), so that a failed try puts back exactly those records (TouchedRecords) and an
// accepted one needs no copy at all: every record untouched since equals V's topology.
struct TouchLog {
  std::int32_t* edges;
  unsigned* edge_stamp;
  std::int32_t* vertices;
  unsigned* vertex_stamp;
  unsigned gen;
  unsigned* counts;  // kTouchedEdgeCount, kTouchedVertexCount of the first block
  std::int32_t *kept_he, *kept_opp, *kept_vedge;

  FF_HD void record(const Mesh& m, int e) const {
    const Quad q = quad(m, e);
    const int around[5] = {e, q.h0n >> 1, q.h0p >> 1, q.h1n >> 1, q.h1p >> 1};
    for (int k = 0; k < 5; ++k) {
      const int g = around[k];
      if (!claim(edge_stamp + g, gen)) continue;
      edges[append_index(counts + kTouchedEdgeCount, 1)] = g;
      for (int w = 0; w < 4; ++w) kept_he[4 * g + w] = m.he[4 * g + w];
      kept_opp[2 * g] = m.opp[2 * g];
      kept_opp[2 * g + 1] = m.opp[2 * g + 1];
    }
    const int ends[2] = {q.a, q.b};
    for (int k = 0; k < 2; ++k) {
      const int v = ends[k];
      if (!claim(vertex_stamp + v, gen)) continue;
      vertices[append_index(counts + kTouchedVertexCount, 1)] = v;
      kept_vedge[v] = m.vedge[v];
    }
  }
};

// DecideFlips on the edges of a list (the troubled ones: every marked edge is among them); the
// winners' records are logged (TouchLog) while nothing flips.
struct DecideListed {
  DecideFlips decide;
  const std::int32_t* list;
  ListSpan span;
  TouchLog touched;
  FF_HD void operator()(std::size_t i) const {
    span.each(i, [&](std::size_t j) {
      const int e = list[j];
      decide(std::size_t(e));
      if (decide.go[e]) touched.record(decide.mesh, e);
    });
  }
};

// The winning flips of a list; the five edges of each flip's quad go to the next round's work
// list, as does every edge of the list (troubled: marked again next round whether it flips or
// not). Winning flips share no triangle, so no other flip writes the records read here.
struct ApplyListed {
  Mesh mesh;
  const std::uint8_t* go;
  const std::int32_t* list;
  ListSpan span;
  std::int32_t* work;  // next marking's edges
  unsigned* work_stamp;
  unsigned work_gen;
  unsigned* work_count;

  FF_HD void operator()(std::size_t i) const {
    span.each(i, [&](std::size_t j) { one(list[j]); });
  }
  FF_HD void one(int e) const {
    append_once(work, work_count, work_stamp, work_gen, e);
    if (!go[e]) return;
    const Quad q = quad(mesh, e);
    const int edges[4] = {q.h0n >> 1, q.h0p >> 1, q.h1n >> 1, q.h1p >> 1};
    for (int k = 0; k < 4; ++k) append_once(work, work_count, work_stamp, work_gen, edges[k]);
    flip_edge(mesh, e);
  }
};

// Appends the edges of a list to a work list (once each).
struct ListEdges {
  const std::int32_t* list;
  ListSpan span;
  std::int32_t* work;
  unsigned* work_stamp;
  unsigned work_gen;
  unsigned* work_count;
  FF_HD void operator()(std::size_t i) const {
    span.each(i, [&](std::size_t j) { append_once(work, work_count, work_stamp, work_gen, list[j]); });
  }
};

// The counters a try starts from, set by one thread (one launch instead of a fill per run of
// slots). Two blocks: `first` counts the try's first marking and holds the lists' lengths and
// the step's statistics, `round` the repair round(s) after it (sub-step mode reads both at
// once). `active`: the active list is rebuilt (Shallower); `step`: the step's statistics too.
FF_HD void reset_marking(unsigned* c) {
  reset_inversion_counters(c);
  c[kTroubledCount] = 0;
  c[kWorkCount] = 0;
}
struct ResetTry {
  unsigned* first;  // null: only `round`
  unsigned* round;
  bool active, step;
  FF_HD void operator()(std::size_t) const {
    reset_marking(round);
    if (!first) return;
    reset_marking(first);
    first[kMovingCount] = 0;
    first[kTouchedEdgeCount] = 0;
    first[kTouchedVertexCount] = 0;
    if (active) first[kActiveCount] = 0;
    if (step) {
      first[kHalvedCount] = 0;
      first[kDepthNot] = ~0u;
    }
  }
};

// Appends the edges of every triangle around each vertex of a list (whose status changes when
// the vertex moves: every edge whose quad holds it) to a work list, once each.
struct EdgesAround {
  Mesh mesh;
  const std::int32_t* vertices;
  ListSpan span;
  std::int32_t* work;
  unsigned* work_stamp;
  unsigned work_gen;
  unsigned* counters;  // kWorkCount
  FF_HD void one(int v) const {
    const int h0 = mesh.vedge[v];
    int h = h0;
    do {  // CCW around the vertex: the half-edges leaving it, one per triangle
      append_once(work, counters + kWorkCount, work_stamp, work_gen, h >> 1);
      append_once(work, counters + kWorkCount, work_stamp, work_gen, mesh.next(h) >> 1);
      h = twin(mesh.next(mesh.next(h)));
    } while (h != h0);
  }
  FF_HD void operator()(std::size_t i) const {
    span.each(i, [&](std::size_t j) { one(vertices[j]); });
  }
};

// The records the flips of a try changed (TouchLog's lists), put back from the copy of V's
// topology after a failed try.
struct TouchedRecords {
  const std::int32_t* edges;
  std::size_t n_edges;  // then the vertices
  const std::int32_t* vertices;
  const std::int32_t *from_he, *from_opp, *from_vedge;
  std::int32_t *to_he, *to_opp, *to_vedge;
  FF_HD void operator()(std::size_t i) const {
    if (i < n_edges) {
      const int e = edges[i];
      for (int k = 0; k < 4; ++k) to_he[4 * e + k] = from_he[4 * e + k];
      to_opp[2 * e] = from_opp[2 * e];
      to_opp[2 * e + 1] = from_opp[2 * e + 1];
    } else {
      const int v = vertices[i - n_edges];
      to_vedge[v] = from_vedge[v];
    }
  }
};

// Whether particle i must go a level deeper after a failed try: a triangle around i is
// inverted, or the vector of an edge at i reversed since `valid` (MarkInversions' r⁰·r¹ test,
// the same formula from either end: a pair passing each other closer than the step's move).
// Each triangle's orientation is computed from its canonical half-edge exactly as
// MarkInversions / CheckInverted compute it, so a near-flat triangle is judged the same way by
// every pass (and by all three of its vertices).
template <class R>
struct MovingRule {
  Mesh mesh;
  Points<R> pts;
  Points<R> valid;  // where the triangulation was valid (delaunay.position_prev)

  FF_HD bool inverted(int h) const {
    const int hn = mesh.next(h), hp = mesh.next(hn);
    int c = h;  // the triangle's canonical (lowest) half-edge
    if (hn < c) c = hn;
    if (hp < c) c = hp;
    const int a = mesh.origin(c), b = mesh.origin(mesh.next(c)), d = mesh.origin(mesh.next(mesh.next(c)));
    const V2 o{0, 0};
    return orient(o, pts.rel(a, b), pts.rel(a, d)) <= 0;
  }
  FF_HD bool moves(int i) const {
    const int h0 = mesh.vedge[i];
    int h = h0;
    do {  // CCW around the vertex: the half-edges leaving it, one per triangle
      if (inverted(h)) return true;
      const int j = mesh.origin(mesh.next(h));
      if (dot(valid.rel(i, j), pts.rel(i, j)) < 0) return true;
      h = twin(mesh.next(mesh.next(h)));
    } while (h != h0);
    return false;
  }
};

// The particles that go deeper, from the end vertices of a list of edges: after a failed try
// every particle the rule moves is an end of a troubled edge of the last marking (an inverted
// triangle's three edges are troubled), of the try's first marking (a reversed edge of V's
// topology) or of an edge a flip made in the try (touched): the lists given in turn. Each
// candidate is judged once (claimed), the moving ones appended. The edges of the first two
// lists also go to the next try's work list (their marks and status, at V's topology).
template <class R>
struct FindMoving {
  MovingRule<R> rule;
  const std::int32_t* edges[3];
  std::size_t counts[3];  // one loop over the three lists, one after the other
  std::int32_t* moving;
  unsigned* stamp;
  unsigned gen;
  unsigned* counters;  // kMovingCount, kWorkCount
  std::int32_t* work;
  unsigned* work_stamp;
  unsigned work_gen;
  FF_HD void operator()(std::size_t i) const {
    int l = 0;
    while (i >= counts[l]) i -= counts[l++];
    const int e = edges[l][i];
    if (l < 2) append_once(work, counters + kWorkCount, work_stamp, work_gen, e);
    for (int k = 0; k < 2; ++k) {
      const int v = rule.mesh.origin(2 * e + k);
      if (claim(stamp + v, gen) && rule.moves(v)) moving[append_index(counters + kMovingCount, 1)] = v;
    }
  }
};

// Substep mode, per particle i at depth d_i: tried at the integrator's target T_i when d_i = 0,
// else at V_i + 2^-d_i · minimage(T_i − V_i), V being where the triangulation is valid (one
// rounding, in double, on both backends). Only intermediate positions are made this way; depth 0
// copies the target's bits.
template <class R>
FF_HD void place_at_depth(const Points<R>& valid, const R* target, R* pos, std::uint32_t d, std::size_t i) {
  for (int k = 0; k < 2; ++k) {
    const double v = double(valid.p[2 * i + k]);
    const R t = target[2 * i + k];
    pos[2 * i + k] = d == 0 ? t : R(v + std::ldexp(valid.image(double(t) - v, k), -int(d)));
  }
}

// A failed try: the moving particles (a list) go one level deeper (half as far from V as they
// were); those leaving their target join the active list, and the step's statistics count the
// particles halved and the deepest depth.
template <class R>
struct Deepen {
  Points<R> valid;
  const R* target;
  R* pos;
  const std::int32_t* moving;
  ListSpan span;
  std::uint32_t* depth;
  std::int32_t* active;
  unsigned* halved_stamp;
  unsigned step_gen;
  unsigned* counters;  // kActiveCount, kHalvedCount, kDepthNot

  FF_HD void operator()(std::size_t k) const {
    span.each(k, [&](std::size_t j) { one(moving[j]); });
  }
  FF_HD void one(int i) const {
    const std::uint32_t d = depth[i] + 1;
    depth[i] = d;
    place_at_depth(valid, target, pos, d, std::size_t(i));
    if (d == 1) active[append_index(counters + kActiveCount, 1)] = i;
    if (claim(halved_stamp + i, step_gen)) count_one(counters + kHalvedCount);
    keep_min(counters + kDepthNot, ~d);
  }
};

// An accepted try became V: every active particle one level shallower (twice as far along what
// is left of its way to T as the try that just worked); those still short of T form the next
// active list.
template <class R>
struct Shallower {
  Points<R> valid;
  const R* target;
  R* pos;
  const std::int32_t* active;
  std::uint32_t* depth;
  std::int32_t* still;
  unsigned* counters;  // kActiveCount

  FF_HD void operator()(std::size_t k) const {
    const int i = active[k];
    const std::uint32_t d = depth[i] - 1;
    depth[i] = d;
    place_at_depth(valid, target, pos, d, std::size_t(i));
    if (d) still[append_index(counters + kActiveCount, 1)] = i;
  }
};

// A failed try in one launch: the records its flips changed back to V's (elements
// [0, n_restore)), and the moving particles a level deeper (the rest: Deepen's strided list).
// Neither reads what the other writes.
template <class R>
struct RestoreAndDeepen {
  TouchedRecords restore;
  std::size_t n_restore;
  Deepen<R> deepen;
  FF_HD void operator()(std::size_t i) const {
    if (i < n_restore) restore(i);
    else deepen(i - n_restore);
  }
};

// An accepted try in one launch (after V ← positions): each active particle a level shallower
// and the edges around it to the next marking's work list (the topology does not change here),
// then (elements [n_active, n_active + n_last)) the last marking's troubled edges to it too.
template <class R>
struct ShallowerAndList {
  Shallower<R> shallower;
  std::size_t n_active;
  EdgesAround around;
  ListEdges last;
  FF_HD void operator()(std::size_t i) const {
    if (i < n_active) {
      shallower(i);
      around.one(shallower.active[i]);
    } else {
      last(i - n_active);
    }
  }
};

// V ← the accepted positions, for the particles of two lists.
template <class R>
struct CopyListed {
  const std::int32_t* lists[2];
  std::size_t counts[2];  // one loop over both lists
  const R* from;
  R* to;
  FF_HD void operator()(std::size_t k) const {
    const int i = k < counts[0] ? lists[0][k] : lists[1][k - counts[0]];
    to[2 * i] = from[2 * i];
    to[2 * i + 1] = from[2 * i + 1];
  }
};

}  // namespace ff::delaunay
