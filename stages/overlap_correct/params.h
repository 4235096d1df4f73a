// The parameters of both overlap corrections, overlap_correct (on the Delaunay triangulation,
// stage.h) and overlap_correct.verlet (on the Verlet list, verlet/stage.h): the same push rule,
// so the same keys mean the same thing in either.
#pragma once
#include <algorithm>
#include <cfloat>
#include <cmath>
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

// The smallest and largest particle diameter, read from the host copy, and the diameter field's
// version when read: both corrections re-read them only when something wrote the field since.
struct DiameterRange {
  double min = 1, max = 1;
  std::uint64_t version = 0;

  template <class R>
  void measure(State& s, CUstream_st* stream) {
    Field& d = s.field(fields::diameter);
    d.acquire(Where::host, Mode::read, stream);
    const R* x = d.host<R>();
    max = 0;
    min = HUGE_VAL;
    for (std::size_t i = 0; i < s.n(); ++i) {
      min = std::min(min, double(x[i]));
      max = std::max(max, double(x[i]));
    }
    version = d.version();
  }
  bool stale(State& s) const { return s.field(fields::diameter).version() != version; }
};

}  // namespace ff::overlap
