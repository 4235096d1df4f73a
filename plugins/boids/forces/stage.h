// boids.forces: every boid's steering F_i (kernel.h) from the state at the start of the step, into
// `boids.steering`, which boids.integrate turns into a change of heading. Reads the neighbour list
// of a neighbors.verlet or neighbors.delaunay stage before it (stages/neighbors/list.h, whose
// cutoff must reach the view radius). 2D, CPU and CUDA, float and double.
#pragma once
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>

#include "core/backend/exec.h"
#include "core/base/error.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "plugins/boids/forces/kernel.h"
#include "plugins/boids/heading.h"
#include "stages/neighbors/list.h"

namespace ff::boids {

// Defaults: Porro et al.'s code (seed-gaps.md P2): view_distance 2, view_angle 2.08 rad (a blind
// sector of ≈ 122° behind), and its weights 0.59 × 0.01, 1.34 × 0.07, 1.87 × 0.03.
struct ForcesParams {
  double view_radius = 2.0;
  double view_angle = 2.08;
  double separation = 0.0059;
  double alignment = 0.0938;
  double cohesion = 0.0561;

  template <class P>
  void describe(P& p) {
    p(view_radius, "view_radius", "r_v (a length in the box's units, not scaled by σ): a boid sees others closer than this").above(0);
    p(view_angle, "view_angle",
      "θ_v (rad): a boid sees others within this angle of its heading (π: all around; the default leaves a blind "
      "sector of 2π − 2θ_v behind)")
        .above(0)
        .at_most(kPi);
    p(separation, "separation", "A: weight of −Σ d/|d| over the boids seen (steer away from each)").at_least(0);
    p(alignment, "alignment", "C: weight of the mean heading of the boids seen").at_least(0);
    p(cohesion, "cohesion", "B: weight of (centre of the boids seen) − x (steer towards them)").at_least(0);
  }
};

template <class R>
class BoidsForces final : public Stage {
 public:
  static StageDecl declaration() {
    return {"boids.forces",
            "boids' steering F = A·separation + C·alignment + B·cohesion over the boids seen (view radius and "
            "angle), from a neighbour list",
            schema_of<ForcesParams>(), {2}, false};
  }

  template <class Exec>
  BoidsForces(const ParamValues& v, const RunInfo& info, Exec)
      : p_(params_from<ForcesParams>(v)), seed_(info.seed), where_(Exec::where),
        loop_(&Exec::template for_each<Steering<R>>) {}

  std::vector<Access> accesses() const override {
    return {{fields::position, where_, Mode::read},
            {kHeading, where_, Mode::read},
            {neighbors::kList, where_, Mode::read},
            {neighbors::kCount, where_, Mode::read},
            {kSteering, where_, Mode::write}};
  }

  void configure(State& s) override {
    if (!s.has_field(neighbors::kList) || !s.has_field(neighbors::kCutoff))
      throw InputError("boids.forces: needs a neighbour list from a stage earlier in the step list (add `- {stage: "
                       "neighbors.verlet, cutoff: " + number(p_.view_radius) +
                       ", skin: 0.5}` before it, its cutoff at least `view_radius`)");
    Field& c = s.field(neighbors::kCutoff);
    c.acquire(Where::host, Mode::read);
    const double cutoff = double(c.host<R>()[0]);
    if (cutoff < double(R(p_.view_radius)))  // boids in view could be missing (compared in the run's precision)
      throw InputError("boids.forces: the neighbour list's cutoff " + number(cutoff) + " is shorter than `view_radius` " +
                       number(p_.view_radius) +
                       "; raise the list's cutoff (neighbors.verlet `cutoff`, neighbors.delaunay `radius`) to at least "
                       "it, or lower `view_radius`");
    ensure_heading<R>(s, seed_, "boids.forces");
    if (!s.has_field(kSteering)) s.add_particle_field(kSteering, s.real(), 2);
  }

  // Graph-capturable: one loop on the stream, nothing read back, no step-dependent values.
  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    Steering<R> f{s.field(fields::position).data<R>(where_),
                  s.field(kHeading).data<R>(where_),
                  s.field(kSteering).data<R>(where_),
                  {s.field(neighbors::kList).data<std::uint32_t>(where_),
                   s.field(neighbors::kCount).data<std::uint32_t>(where_), neighbors::list_capacity(s)},
                  PeriodicBox<R>::make(s.box.L),
                  R(p_.view_radius * p_.view_radius),
                  R(std::cos(p_.view_angle)),
                  p_.view_angle >= kPi,
                  R(p_.separation),
                  R(p_.alignment),
                  R(p_.cohesion)};
    loop_(s.n(), f, ctx.stream);
    return Outcome::ok();
  }

  Scheduling scheduling() const override {
    Scheduling sc;
    sc.graph_capturable = true;
    return sc;
  }

 private:
  static std::string number(double v) {
    std::ostringstream o;
    o << v;
    return o.str();
  }

  ForcesParams p_;
  std::uint64_t seed_;
  Where where_;
  ElementLoop<Steering<R>> loop_;
};

}  // namespace ff::boids

FLIPFLOW_STAGE(ff::boids::BoidsForces)
