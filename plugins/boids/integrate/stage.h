// boids.integrate: moves every boid at constant speed v0 along its heading and turns the heading by
// the steering of a boids.forces stage before it (kernel.h): the continuous-time flow (default), or
// the authors' discrete map (`update: discrete`). Writes position, image and boids.heading in place.
// 2D, CPU and CUDA, float and double. Boids are points: nothing keeps them apart but separation.
#pragma once
#include <string>

#include "core/backend/exec.h"
#include "core/base/error.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "plugins/boids/heading.h"
#include "plugins/boids/integrate/kernel.h"

namespace ff::boids {

struct IntegrateParams {
  double v0 = 0.06;  // the authors' MAX_VEL: 0.06 per step of their map
  double tau = 1.0;
  std::string update = "continuous";

  template <class P>
  void describe(P& p) {
    p(v0, "v0", "speed (box lengths per τ) of every boid along its heading").at_least(0);
    p(tau, "tau",
      "τ_b: the heading turns at the rate (u × F)/τ_b (continuous update; with Δt = τ_b one step is close to the "
      "authors' map)")
        .above(0);
    p(update, "update",
      "continuous: du/dt = P_⊥(u) F/τ_b, one explicit step per Δt (rollbacks halve it); discrete: the authors' map "
      "u ← (u + F)/|u + F| once per run.dt (refuses a Δt other than run.dt)")
        .one_of({"continuous", "discrete"});
  }
};

template <class R>
class BoidsIntegrate final : public Stage {
 public:
  static StageDecl declaration() {
    return {"boids.integrate",
            "boids: x += v0 Δt u, u turned by the steering F of boids.forces (continuous flow, or the authors' "
            "discrete map)",
            schema_of<IntegrateParams>(), {2}, false};
  }

  template <class Exec>
  BoidsIntegrate(const ParamValues& v, const RunInfo& info, Exec)
      : p_(params_from<IntegrateParams>(v)), seed_(info.seed), run_dt_(info.dt), where_(Exec::where),
        continuous_(&Exec::template for_each<BoidsStep<R, false>>),
        discrete_(&Exec::template for_each<BoidsStep<R, true>>) {}

  std::vector<Access> accesses() const override {
    return {{kSteering, where_, Mode::read},
            {fields::position, where_, Mode::readwrite},
            {fields::image, where_, Mode::readwrite},
            {kHeading, where_, Mode::readwrite}};
  }

  void configure(State& s) override {
    if (!s.has_field(kSteering))
      throw InputError("boids.integrate: needs a boids.forces stage earlier in the step list (add `- {stage: "
                       "boids.forces}` before it; it writes the steering this stage turns the headings by)");
    ensure_heading<R>(s, seed_, "boids.integrate");
  }

  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    const bool discrete = p_.update == "discrete";
    // The map is one step of the authors' model per run.dt; a shorter Δt (after a rollback) would
    // apply a whole turn in part of the time. run.dt = 0: no run around the stage (a test) to compare with.
    if (discrete && run_dt_ > 0 && ctx.host_params.dt != run_dt_)
      throw RunError("boids.integrate: `update: discrete` applies the authors' map once per run.dt = " +
                     std::to_string(run_dt_) + ", but step " + std::to_string(ctx.host_params.step) +
                     " runs with Δt = " + std::to_string(ctx.host_params.dt) +
                     " (a rollback halved it); use `update: continuous`, whose step follows any Δt");
    auto fill = [&](auto f) {
      f.steering = s.field(kSteering).data<R>(where_);
      f.position = s.field(fields::position).data<R>(where_);
      f.image = s.field(fields::image).data<std::int32_t>(where_);
      f.heading = s.field(kHeading).data<R>(where_);
      f.box = PeriodicBox<R>::make(s.box.L);
      f.v0 = p_.v0;
      f.inv_tau = 1.0 / p_.tau;
      f.params = ctx.params;
      return f;
    };
    if (discrete) discrete_(s.n(), fill(BoidsStep<R, true>{}), ctx.stream);
    else continuous_(s.n(), fill(BoidsStep<R, false>{}), ctx.stream);
    return Outcome::ok();
  }

  // Its kernel takes Δt from ctx.params; the discrete check reads host values that a captured
  // step cannot change (the core captures no run that may roll back).
  Scheduling scheduling() const override {
    Scheduling sc;
    sc.graph_capturable = true;
    sc.reads_step_params = true;
    return sc;
  }

 private:
  IntegrateParams p_;
  std::uint64_t seed_;
  double run_dt_;
  Where where_;
  ElementLoop<BoidsStep<R, false>> continuous_;
  ElementLoop<BoidsStep<R, true>> discrete_;
};

}  // namespace ff::boids

FLIPFLOW_STAGE(ff::boids::BoidsIntegrate)
