// voronoi.mirror's per-element work (spec D2 W2): the doubled point set, the validity test of
// the stage's own triangulation of it, and Lawson's rounds on it. FF_HD only; nvcc-clean. The
// conflict rule is delaunay/common/flip.h's DecideFlips, the flip mesh.h's flip_edge, the cells
// voronoi/geometry/kernel.h's.
#pragma once
#include <cmath>
#include <cstdint>

#include "core/base/hd.h"
#include "core/physics/box.h"
#include "core/backend/atomics.h"
#include "stages/delaunay/common/mesh.h"

namespace ff::voronoi {

// Writes the 2N points of the doubled box: particle i as it is, its mirror image N + i with the
// coordinate along the wall axis reflected in the wall at 0 and wrapped, 2L − c (which is also
// its reflection in the wall at L). Real coordinates lie in [0, L), images in (L, 2L]; an image
// at exactly 2L (c = 0: a particle on the wall, which coincides with its image) is refused by
// the build that follows.
template <class R>
struct MirrorPoints {
  const R* pos;  // 2 x N
  R* out;        // 2 x 2N
  int n;
  int axis;     // 0 or 1
  R twice_L;    // 2 L along the wall axis
  FF_HD void operator()(std::size_t i) const {
    const R x = pos[2 * i], y = pos[2 * i + 1];
    out[2 * i] = x;
    out[2 * i + 1] = y;
    const std::size_t j = std::size_t(n) + i;
    out[2 * j] = axis == 0 ? twice_L - x : x;
    out[2 * j + 1] = axis == 1 ? twice_L - y : y;
  }
};

// Counters of a call (a Counters block, atomics: order-free).
enum MirrorCounter : int {
  kMirrorMarked = 0,  // edges marked in this round
  kMirrorTooLong,     // flips not marked: the new edge would exceed half the box
  kMirrorBad,         // edges with a triangle not closing or not surely positive
  kMirrorFlips,       // flips in this call (DecideFlips' winners)
  kMirrorCounters
};

// Lawson's mark of edge e (delaunay.lawson's test, wants_flip, at its tolerance): 1 when e is
// not locally Delaunay and its flip keeps both triangles surely positive and its new edge
// shorter than half the box (a longer one is counted, not marked: the stage stops).
template <class R>
FF_HD std::uint8_t lawson_mark(const delaunay::Points<R>& pts, delaunay::V2 ab, delaunay::V2 ac, delaunay::V2 ad,
                               double tol, unsigned* counters) {
  if (!delaunay::wants_flip(ab, ac, ad, tol)) return 0;
  if (!delaunay::is_min_image(ad - ac, pts.box)) {
    count_one(counters + kMirrorTooLong);
    return 0;
  }
  count_one(counters + kMirrorMarked);
  return 1;
}

// Round 0, per edge, fused with the test that the stage's triangulation is still one at the new
// points: the edge's two triangles, (a, b, c) and (b, a, d), must close under minimum image and
// be surely counter-clockwise (else kMirrorBad), and the triangles must cover the doubled box
// once: the sum of the returned terms, each edge's two triangle areas in fixed point (units of
// the box area / 2^kAreaBits), is 3 × 2^kAreaBits, every triangle being on the sides of its three
// edges (positive triangles wrapping the torus d times would sum to 3d × 2^kAreaBits). Marks are
// written for every edge (DecideFlips reads those around each marked edge); they are meaningful
// only when nothing was bad. `stamp` (per edge: the round in which to test it) is set to 0.
inline constexpr int kAreaBits = 50;
template <class R>
struct FirstRound {
  delaunay::Mesh mesh;
  delaunay::Points<R> pts;
  double tol;
  double scale;  // 2^kAreaBits / box area
  std::uint8_t* mark;
  std::int32_t* stamp;
  unsigned* counters;
  FF_HD std::uint64_t operator()(std::size_t i) const {
    const int e = int(i);
    const delaunay::QuadVertices q = delaunay::quad_vertices(mesh, e);
    const delaunay::V2 o{0, 0}, ab = pts.rel(q.a, q.b), ac = pts.rel(q.a, q.c), ad = pts.rel(q.a, q.d);
    const bool ok = delaunay::closes(ab, ac, pts.box) && delaunay::closes(ad, ab, pts.box) &&
                    delaunay::orient_surely(o, ab, ac) > 0 && delaunay::orient_surely(o, ad, ab) > 0;
    stamp[e] = 0;
    if (!ok) {
      count_one(counters + kMirrorBad);
      mark[e] = 0;
      return 0;
    }
    mark[e] = lawson_mark(pts, ab, ac, ad, tol, counters);
    return std::uint64_t(std::int64_t(std::rint(0.5 * (delaunay::cross(ab, ac) + delaunay::cross(ad, ab)) * scale)));
  }
};

// Rounds after the first: an edge is tested again only when its quad changed (one of the four
// edges around a flip) or it was marked and lost its conflict (stamp == round); every other edge
// keeps both its triangles, so its answer cannot change (delaunay.lawson's argument). The
// others get mark 0.
template <class R>
struct MarkRound {
  delaunay::Mesh mesh;
  delaunay::Points<R> pts;
  double tol;
  std::uint8_t* mark;
  const std::int32_t* stamp;
  std::int32_t round;
  unsigned* counters;
  FF_HD void operator()(std::size_t i) const {
    const int e = int(i);
    if (stamp[e] != round) {
      mark[e] = 0;
      return;
    }
    const delaunay::QuadVertices q = delaunay::quad_vertices(mesh, e);
    mark[e] = lawson_mark(pts, pts.rel(q.a, q.b), pts.rel(q.a, q.c), pts.rel(q.a, q.d), tol, counters);
  }
};

// Applies the winners of a round (DecideFlips' go) and stamps what the next round tests: the four
// edges around each flip (read before it: flips that share no triangle do not touch each other's
// around-edges' links) and each marked edge that lost. A flipped edge is locally Delaunay
// afterwards (its quad's in-circle changes sign) and is not stamped. Several threads may stamp
// one edge, all with the same value.
struct ApplyRound {
  delaunay::Mesh mesh;
  const std::uint8_t* mark;
  const std::uint8_t* go;
  std::int32_t* stamp;
  std::int32_t next_round;
  FF_HD void operator()(std::size_t i) const {
    const int e = int(i);
    if (!mark[e]) return;
    if (!go[e]) {
      delaunay::store_relaxed(stamp + e, next_round);
      return;
    }
    const int h0n = mesh.next(2 * e), h1n = mesh.next(2 * e + 1);
    const int around[4] = {h0n >> 1, mesh.next(h0n) >> 1, h1n >> 1, mesh.next(h1n) >> 1};
    delaunay::flip_edge(mesh, e);
    for (int k = 0; k < 4; ++k) delaunay::store_relaxed(stamp + around[k], next_round);
  }
};

}  // namespace ff::voronoi
