// The parameters of both overlap corrections, overlap_correct (on the Delaunay triangulation,
// stage.h) and overlap_correct.verlet (on the Verlet list, verlet/stage.h): the same push rule,
// so the same keys mean the same thing in either.
#pragma once
#include <algorithm>
#include <cfloat>
#include <cstdint>
#include <string>

#include "core/stage/state.h"

namespace ff::overlap {

struct Params {
  std::string mode = "reflect";
  double cap = 0.25;
  double tolerance = 1e-6;
  std::int64_t max_iterations = 1000;

  template <class P>
  void describe(P& p) {
    p(mode, "mode",
      "reflect: each particle of an overlapping pair moves by δ = σ_ij − r (the pair bounces off contact, r' = 2σ_ij "
      "− r; the paper's choice); contact: each moves by δ/2 (r' = σ_ij)")
        .one_of({"reflect", "contact"});
    p(cap, "cap",
      "largest displacement of a particle per iteration, as a fraction of its diameter (the paper's σ/4)")
        .above(0);
    p(tolerance, "tolerance",
      "converged when no pair overlaps by more than tolerance·σ_ij; in float runs it is raised to the position "
      "resolution, 4·ε·L_max/σ_min")
        .above(0)
        .at_most(0.5);
    p(max_iterations, "max_iterations", "iterations before the run stops with an error").at_least(1);
  }
};

// The tolerance a run uses: `tolerance`, raised in float runs to the position resolution
// 4·ε·L_max/σ_min (dmin: the smallest diameter), below which a float position cannot resolve
// an overlap.
inline double tolerance_for(const Params& p, const State& s, double dmin) {
  double tol = p.tolerance;
  if (s.precision() == Precision::f32) {
    double lmax = 0;
    for (int k = 0; k < s.dim(); ++k) lmax = std::max(lmax, s.box.L[k]);
    tol = std::max(tol, 4.0 * double(FLT_EPSILON) * lmax / dmin);
  }
  return tol;
}

}  // namespace ff::overlap
