// voronoi.mirror's per-element work (spec D2 W2): the doubled point set, the validity test of
// the stage's own triangulation of it, and Lawson's marking. FF_HD only; nvcc-clean. The flips
// themselves are delaunay/common/flip.h's, the cells voronoi/geometry/kernel.h's.
#pragma once
#include <cmath>
#include <cstdint>

#include "core/base/hd.h"
#include "core/physics/box.h"
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

// The stage's triangulation is valid at the current points when every triangle closes under
// minimum image and is surely counter-clockwise, and the triangles cover the box once. These two
// terms are summed over the half-edges, each triangle counted at its canonical (lowest)
// half-edge: the number of bad triangles, and the areas in fixed point (units of the box area /
// 2^kAreaBits). With every triangle positive the areas sum to d times the box area, d the
// number of times the triangles wrap the torus; d = 1 is a triangulation.
inline constexpr int kAreaBits = 50;
template <class R>
struct TriangleTerms {
  delaunay::Mesh mesh;
  delaunay::Points<R> pts;
  double scale;  // 2^kAreaBits / box area
  FF_HD bool bad(std::size_t i, delaunay::V2& ab, delaunay::V2& ac) const {
    const int h = int(i), hn = mesh.next(h);
    const int a = mesh.origin(h), b = mesh.origin(hn), c = mesh.origin(mesh.next(hn));
    ab = pts.rel(a, b);
    ac = pts.rel(a, c);
    return !delaunay::closes(ab, ac, pts.box) || !(delaunay::orient_surely({0, 0}, ab, ac) > 0);
  }
};
template <class R>
struct BadTriangle {
  TriangleTerms<R> t;
  FF_HD bool operator()(std::size_t i) const {
    if (!t.mesh.canonical(int(i))) return false;
    delaunay::V2 ab, ac;
    return t.bad(i, ab, ac);
  }
};
template <class R>
struct TriangleArea {
  TriangleTerms<R> t;
  FF_HD std::uint64_t operator()(std::size_t i) const {
    if (!t.mesh.canonical(int(i))) return 0;
    delaunay::V2 ab, ac;
    t.bad(i, ab, ac);
    return std::uint64_t(std::int64_t(std::rint(0.5 * delaunay::cross(ab, ac) * t.scale)));
  }
};

// One Lawson round's marks, over every edge: mark[e] = 1 when e is not locally Delaunay
// (delaunay.lawson's test, wants_flip, at the same tolerance) and its flip is possible. Returns
// 1 for a mark and 2^32 for an edge whose flip would create an edge longer than half the box
// (not marked; the stage stops with an error), so one integer sum counts both.
inline constexpr int kTooLongShift = 32;
template <class R>
struct MarkLawson {
  delaunay::Mesh mesh;
  delaunay::Points<R> pts;
  double tol;
  std::uint8_t* mark;  // 3 x 2N
  FF_HD std::uint64_t operator()(std::size_t i) const {
    const int e = int(i);
    const delaunay::QuadVertices q = delaunay::quad_vertices(mesh, e);
    const delaunay::V2 ab = pts.rel(q.a, q.b), ac = pts.rel(q.a, q.c), ad = pts.rel(q.a, q.d);
    std::uint64_t r = 0;
    if (delaunay::wants_flip(ab, ac, ad, tol)) r = delaunay::is_min_image(ad - ac, pts.box) ? 1 : std::uint64_t(1) << kTooLongShift;
    mark[e] = r == 1 ? 1 : 0;
    return r;
  }
};

}  // namespace ff::voronoi
