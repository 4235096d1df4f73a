// The parameters of both overlap corrections, overlap_correct (on the Delaunay triangulation,
// stage.h) and overlap_correct.verlet (on the Verlet list, verlet/stage.h): the same push rule,
// so the same keys mean the same thing in either.
#pragma once
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <string>

#include "core/base/error.h"
#include "core/stage/state.h"
#include "stages/overlap_correct/kernel.h"

namespace ff::overlap {

struct Params {
  std::string mode = "reflect";
  double cap = 0.25;
  double tolerance = 1e-6;
  std::int64_t max_iterations = 1000;
  std::string walls = "none";
  bool mark = false;

  template <class P>
  void describe(P& p) {
    p(mode, "mode",
      "reflect: each particle of an overlapping pair moves by δ = σ_ij − r (the pair bounces off contact, r' = 2σ_ij "
      "− r; the paper's choice); contact: each moves by δ/2 (r' = σ_ij), for passive or dilute systems: in dense "
      "active clusters it needs many iterations and can stop at max_iterations (abp.yaml: 117 a step against "
      "reflect's 7.7; φ = 0.6, Dr = 0.01: stopped at t = 23), and a lower run.dt adds more steps than it saves "
      "iterations. Use reflect for active dense systems (docs/model-notes.md#g4)")
        .one_of({"reflect", "contact"});
    p(cap, "cap",
      "largest displacement of a particle per iteration, as a fraction of its own diameter (the paper's σ/4)")
        .above(0);
    p(tolerance, "tolerance",
      "converged when no pair overlaps by more than tolerance·σ_ij; in float runs it is raised to the position "
      "resolution, 4·ε·L_max/σ_min")
        .above(0)
        .at_most(0.5);
    p(max_iterations, "max_iterations", "iterations before the run stops with an error").at_least(1);
    p(walls, "walls",
      "hard planar walls at 0 and L along this axis (none: periodic in every direction): a particle closer than "
      "σ_i/2 to a wall is pushed back by the rule of `mode` for the pair it makes with its mirror image (reflect: "
      "about the contact plane), within the same iterations; the axis stays periodic for the bookkeeping, but no "
      "pair interacts across it and its image counts stay 0")
        .one_of({"none", "x", "y", "z"});
    p(mark, "mark",
      "write the field overlap_correct.touched (u8: 1 for every particle that overlapped a neighbour or a wall in "
      "any iteration of the step) and the metrics touched and touched_fraction (Carter et al. 2017, Fig. 13)");
  }
};

// The field `mark: true` writes (both corrections).
inline constexpr const char* touched_field = "overlap_correct.touched";

// The axis `walls` names (-1: none).
inline int wall_axis_of(const std::string& walls) {
  return walls == "x" ? 0 : walls == "y" ? 1 : walls == "z" ? 2 : -1;
}

// With walls: the axis must exist, be at least two largest diameters long, and every particle must start
// between the walls as far as the image counts tell (image 0 along the axis: the correction reflects a particle
// that an integrator carried through a wall back by its unwrapped coordinate, which needs the count to start at
// 0). `who`: the stage's name for the errors (InputError).
inline void check_walls(State& s, int axis, double dmax, const char* who) {
  if (axis < 0) return;
  const char* name[3] = {"x", "y", "z"};
  if (axis >= s.dim())
    throw InputError(std::string(who) + ": walls: " + name[axis] + " needs a 3D system (system.dimensions is " +
         std::to_string(s.dim()) + "): use walls: x or y");
  if (!(s.box.L[axis] >= 2 * dmax))
    throw InputError(std::string(who) + ": walls: " + name[axis] + ": the box is " + std::to_string(s.box.L[axis]) +
         " long between the walls, less than two of the largest diameter (" + std::to_string(dmax) +
         "): make the box longer along " + name[axis]);
  Field& img = s.field(fields::image);
  img.acquire(Where::host, Mode::read);
  const std::int32_t* m = img.host<std::int32_t>();
  for (std::size_t i = 0; i < s.n(); ++i)
    if (m[std::size_t(s.dim()) * i + std::size_t(axis)] != 0)
      throw InputError(std::string(who) + ": walls: " + name[axis] + ": particle " + std::to_string(i) + " has image count " +
           std::to_string(m[std::size_t(s.dim()) * i + std::size_t(axis)]) + " along " + name[axis] +
           ", but with walls every particle lies between them (count 0); start from a state without box "
           "crossings along " + name[axis]);
}

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

// What the error of a step that ends with pairs still overlapping after max_iterations advises
// (both corrections): the levers a user has, and for mode: contact the one that usually matters.
inline std::string unconverged_advice(const Params& p) {
  std::string a =
      "Lower run.dt (smaller moves make fewer, shallower overlaps), raise max_iterations, or lower the packing "
      "fraction";
  if (p.mode == "contact")
    a += "; mode: contact needs ~15 times the iterations of mode: reflect in dense or active systems "
         "(docs/model-notes.md#g4): reflect is the one for them";
  return a;
}

// The push rule of this step's gathers, the same for both corrections: tol from tolerance_for,
// unit the largest diameter at configure, diam the diameters now, wall_axis from wall_axis_of.
inline PushRule push_rule(const Params& p, const State& s, double tol, double unit, const DiameterRange& diam,
                          int wall_axis) {
  return PushRule::make(PeriodicBox<double>::make(s.box.L), p.mode == "contact" ? 0.5 : 1.0, p.cap, tol, 1.0 / unit,
                        diam.min == diam.max ? diam.max : 0.0,  // all diameters equal: none is read
                        wall_axis);
}

}  // namespace ff::overlap
