// delaunay.lawson per-element math: which edges are not locally Delaunay. A round is this mark
// pass, then decide + apply (common/flip.h). FF_HD; nvcc-clean.
//
// Edge e = (a, b) with c left and d right is flipped when d lies inside the circle through the
// CCW triangle (a, b, c) by more than `tol` times the in-circle permanent (the rounding-error
// scale of the determinant, so the tolerance follows the geometry: co-circular points, as in a
// square lattice, are left alone instead of flipping back and forth), and when the flip keeps
// both triangles positive by more than their own rounding scale. A flip whose new edge (c, d)
// would be longer than half the box is not done but reported (the triangulation could not store
// it).
#pragma once
#include <cmath>
#include <cstdint>

#include "stages/delaunay/common/atomics.h"
#include "stages/delaunay/common/flip.h"
#include "stages/delaunay/common/mesh.h"

namespace ff::delaunay {

enum LawsonCounter : int {
  kLawsonMarked = 0,  // edges not locally Delaunay in this round
  kLawsonFlips,       // of which flipped this round
  kLawsonTooLong,     // flips refused: the new edge would exceed half the box
  kLawsonTooLongAt,   //   lowest such edge
  kLawsonCounters
};

// orient(p, q, r) minus its rounding-error scale: > 0 only when surely counter-clockwise.
FF_HD double orient_surely(V2 p, V2 q, V2 r) {
  const V2 u = q - p, v = r - p;
  return (u.x * v.y - u.y * v.x) - 1e-12 * (std::fabs(u.x * v.y) + std::fabs(u.y * v.x));
}

template <class R>
struct MarkNonDelaunay {
  Mesh mesh;
  Points<R> pts;
  double tol;  // relative to the in-circle permanent
  std::uint8_t* mark;
  unsigned* counters;

  FF_HD void operator()(std::size_t i) const {
    const int e = int(i);
    const Quad q = quad(mesh, e);
    const V2 o{0, 0};
    const V2 ab = pts.rel(q.a, q.b), ac = pts.rel(q.a, q.c), ad = pts.rel(q.a, q.d);
    double perm;
    const double det = incircle(o, ab, ac, ad, perm);
    bool m = false;
    if (det > tol * perm && orient_surely(ac, o, ad) > 0 && orient_surely(ad, ab, ac) > 0) {
      if (is_min_image(ad - ac, pts.box))
        m = true;
      else
        record(counters, kLawsonTooLong, kLawsonTooLongAt, unsigned(e));
    }
    mark[e] = m ? 1 : 0;
    if (m) count_one(counters + kLawsonMarked);
  }
};

}  // namespace ff::delaunay
