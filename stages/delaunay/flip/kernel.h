// delaunay.flip per-element math: the repair round is decide + apply (common/flip.h) followed
// by the detection pass of delaunay.detect_inversion (MarkInversions, without the r⁰·r¹ test),
// which re-marks whatever inverted triangles remain. For `on_unrepairable: substep` (Porro et
// al. §3, "intermediate position"), per-vertex passes: which particles have an inverted
// triangle around them or an edge whose vector reversed since the valid positions (r⁰·r¹ < 0);
// those go a level deeper (half as far from where the triangulation was valid), and after a
// try that works every particle goes a level shallower.
// FF_HD; nvcc-clean.
#pragma once
#include <cmath>
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

// A failed try: the moving particles go one level deeper (half as far from V as they were).
template <class R>
struct Deepen {
  Points<R> valid;
  const R* target;
  R* pos;
  const std::uint8_t* moving;
  std::uint32_t* depth;

  FF_HD void operator()(std::size_t i) const {
    if (!moving[i]) return;
    depth[i] += 1;
    place_at_depth(valid, target, pos, depth[i], i);
  }
};

// An accepted try became V: every particle one level shallower (twice as far along what is left
// of its way to T as the try that just worked); *deep counts those not yet at their target.
template <class R>
struct Shallower {
  Points<R> valid;
  const R* target;
  R* pos;
  std::uint32_t* depth;
  unsigned* deep;

  FF_HD void operator()(std::size_t i) const {
    if (depth[i] == 0) return;
    depth[i] -= 1;
    place_at_depth(valid, target, pos, depth[i], i);
    if (depth[i]) count_one(deep);
  }
};

}  // namespace ff::delaunay
