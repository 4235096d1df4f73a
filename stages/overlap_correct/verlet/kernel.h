// overlap_correct.verlet per-particle math, for both backends: one iteration is a gather over
// every particle (Gather, the backend's sum: it returns the pair counts) and then, unless it
// converged, an apply (Apply, the backend's sum: it returns |d_v| in fixed point).
//
// Particle v's gather reads its own row of neighbors.list (a full list: the pair (v, u) is in
// both rows) and sums the push of each listed u closer than σ_vu with ../kernel.h's rule
// (pair_term_d, fixed_push, finish_d): the pushes and sums of overlap_correct's walks around the
// Delaunay fans. So for the same set of overlapping pairs the two variants give the same
// displacements, bit for bit; a pair beyond σ_vu adds nothing, so the list's extra pairs (up to
// cutoff + skin) change nothing either. Every displacement of an iteration is computed from the
// positions before it (Jacobi), as in the Delaunay variant, then applied.
// Walls (../kernel.h's wall_term) are a term of v's own sum, and along the wall axis a pair's
// offset is the plain difference (no pair across a wall), as in the Delaunay variant: the same
// bits again.
// nvcc-clean.
#pragma once
#include <cstdint>

#include "core/base/hd.h"
#include "core/physics/box.h"
#include "stages/overlap_correct/kernel.h"

namespace ff::overlap {

// A gather's return value: pairs in the low 32 bits, pairs beyond the tolerance above them (the
// stage checks that a step's pairs fit 32 bits: at most N·capacity/2).
inline constexpr int kBadShift = 32;

// Walls: the wall code compiled in (walls: x | y | z); Mark: the touched field written (mark:
// true). Without them the gather is the code it was before they existed (the stage picks the
// variant from its parameters).
template <class R, int D, bool Walls = false, bool Mark = false>
struct Gather : PushRule {
  const R* pos;                  // N x D
  const R* diameter;             // N
  const std::uint32_t* list;     // N x capacity, rows in ascending index order
  const std::uint32_t* count;    // N
  std::uint32_t capacity;
  double* disp;                  // N x (D + 1): v's capped displacement and its length
  const std::int32_t* image = nullptr;  // N x D, read with walls
  std::uint8_t* touched = nullptr;      // the touched field (Mark)
  bool first = false;                   // the step's first gather: it writes every touched entry
  // Global ids in a decomposed team (core/run/domain.h): a pair's direction when its particles
  // coincide, and which of its two rows counts it, go by id as they go by index alone. Null: index.
  const std::uint32_t* id = nullptr;

  FF_HD double diameter_of(std::size_t v) const { return uniform > 0 ? uniform : double(diameter[v]); }

  FF_HD std::uint64_t operator()(std::size_t i) const {
    const int v = int(id ? id[i] : i);
    double xv[D];
    for (int k = 0; k < D; ++k) xv[k] = double(pos[D * i + k]);
    const double sv = diameter_of(i);
    std::int64_t q[D];
    for (int k = 0; k < D; ++k) q[k] = 0;
    std::uint64_t pairs = 0, bad = 0;
    bool any = false;  // some pair or wall overlaps v
    const std::uint32_t m = count[i] < capacity ? count[i] : capacity;
    const std::uint32_t* row = list + i * capacity;
    for (std::uint32_t j = 0; j < m; ++j) {
      const std::uint32_t u = row[j];
      double r[D], t[D];
      for (int k = 0; k < D; ++k) {
        const double dk = double(pos[D * std::size_t(u) + k]) - xv[k];
        r[k] = Walls && k == wall_axis ? dk + 0.0 : box.min_image(dk, k);
      }
      const int w = int(id ? id[u] : u);
      const PairOverlap o = pair_term_d<D>(r, sv, diameter_of(u), factor, tol, v, w, t);
      if (o == kApart) continue;
      any = true;
      for (int k = 0; k < D; ++k) q[k] -= fixed_push(t[k], inv_unit);
      if (v < w && counted(o)) {
        ++pairs;
        if (o == kBeyond) ++bad;
      }
    }
    if constexpr (Walls) {
      double push;
      const PairOverlap o =
          wall_term(xv[wall_axis], image[D * i + wall_axis], box.L[wall_axis], sv, factor, tol, push);
      if (o != kApart) {
        any = true;
        q[wall_axis] += fixed_push(push, inv_unit);
        ++pairs;
        if (o == kBeyond) ++bad;
      }
    }
    if constexpr (Mark) {
      if (first || any) touched[i] = std::uint8_t(any);
    }
    double* d = disp + (D + 1) * i;
    d[D] = finish_d<D>(q, sv, cap, push_length, d);
    return pairs | (bad << kBadShift);
  }
};

template <class R, int D>
struct Apply {
  R* pos;
  std::int32_t* image;
  PeriodicBox<R> box;
  const double* disp;  // Gather's
  double inv_unit;

  FF_HD std::uint64_t operator()(std::size_t i) const {
    const double* d = disp + (D + 1) * i;
    apply_d<D>(pos, image, box, i, d);  // zero components leave their coordinate alone
    return fixed_len(d[D], inv_unit);
  }
};

// The touched field's count (mark: true), after the step's last gather.
struct CountTouched {
  const std::uint8_t* touched;
  FF_HD std::uint64_t operator()(std::size_t i) const { return touched[i]; }
};

}  // namespace ff::overlap
