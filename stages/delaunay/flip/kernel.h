// delaunay.flip per-element math: the repair round is decide + apply (common/flip.h) followed
// by the detection pass of delaunay.detect_inversion (MarkInversions, without the r⁰·r¹ test),
// which re-marks whatever inverted triangles remain. For `on_unrepairable: substep` (Porro et
// al. §3, "intermediate position"), two per-vertex passes: which particles have an inverted
// triangle around them or an edge whose vector reversed since the valid positions (r⁰·r¹ < 0),
// then move those half way back to where the triangulation was valid.
// FF_HD; nvcc-clean.
#pragma once
#include <cstdint>

#include "stages/delaunay/common/flip.h"
#include "stages/delaunay/detect_inversion/kernel.h"

namespace ff::delaunay {

// Per vertex v: moving[v] = 1 when a triangle around v is inverted, or when the vector of an
// edge at v reversed since `valid` (MarkInversions' r⁰·r¹ test, the same formula from either
// end: a pair passing each other closer than the step's move). Each triangle's orientation
// is computed from its canonical half-edge exactly as MarkInversions / CheckInverted compute it,
// so a near-flat triangle is judged the same way by every pass (and by all three of its vertices).
// Per vertex (reads only) so that no two threads write the same byte.
template <class R>
struct MarkInvertedVertices {
  Mesh mesh;
  Points<R> pts;
  Points<R> valid;  // where the triangulation was valid (delaunay.position_prev)
  std::uint8_t* moving;

  FF_HD bool inverted(int h) const {
    const int hn = mesh.next(h), hp = mesh.next(hn);
    int c = h;  // the triangle's canonical (lowest) half-edge
    if (hn < c) c = hn;
    if (hp < c) c = hp;
    const int a = mesh.origin(c), b = mesh.origin(mesh.next(c)), d = mesh.origin(mesh.next(mesh.next(c)));
    const V2 o{0, 0};
    return orient(o, pts.rel(a, b), pts.rel(a, d)) <= 0;
  }
  FF_HD void operator()(std::size_t i) const {
    const int h0 = mesh.vedge[i];
    int h = h0;
    std::uint8_t m = 0;
    do {  // CCW around the vertex: the half-edges leaving it, one per triangle
      if (inverted(h)) m = 1;
      const int j = mesh.origin(mesh.next(h));
      if (dot(valid.rel(int(i), j), pts.rel(int(i), j)) < 0) m = 1;
      h = twin(mesh.next(mesh.next(h)));
    } while (h != h0);
    moving[i] = m;
  }
};

// Per particle: x ← v + ½ (x − v) for the moving ones, v being where the triangulation was
// valid (minimum image of x − v). The halving is exact and the sum rounds once, in double on
// both backends; only the intermediate positions are made this way, never the final ones
// (those are the integrator's targets, copied back).
template <class R>
struct MoveHalfway {
  Points<R> valid;
  R* pos;
  const std::uint8_t* moving;

  FF_HD void operator()(std::size_t i) const {
    if (!moving[i]) return;
    for (int k = 0; k < 2; ++k) {
      const double v = double(valid.p[2 * i + k]);
      pos[2 * i + k] = R(v + 0.5 * valid.image(double(pos[2 * i + k]) - v, k));
    }
  }
};

}  // namespace ff::delaunay
