// phoretic.integrate: x += v Δt + sqrt(2DΔt) ξ with v from the `velocity` field (phoretic.forces).
#pragma once
#include <cmath>

#include "core/error.h"
#include "core/exec.h"
#include "core/params.h"
#include "core/stage.h"
#include "plugins/phoretic/forces/stage.h"
#include "plugins/phoretic/integrate/kernel.h"

namespace ff::phoretic {

struct IntegrateParams {
  double D = 0.01;

  static std::vector<ParamSpec> schema() {
    return {ParamSpec::real("D", 0.01, "translational diffusion coefficient (σ²/τ); Carter et al. use 0.01")
                .at_least(0)};
  }
  static IntegrateParams from(const ParamValues& v) { return {v.real("D")}; }
};

template <class R>
struct IntegrateLoops {
  ElementLoop<PhoreticStep<R, 2>> loop2;
  ElementLoop<PhoreticStep<R, 3>> loop3;
};

template <class R>
class Integrate final : public Stage {
 public:
  Integrate(IntegrateParams p, Where where, IntegrateLoops<R> loops) : p_(p), where_(where), loops_(loops) {}

  std::vector<Access> accesses() const override {
    return {{fields::position, where_, Mode::readwrite},
            {fields::image, where_, Mode::readwrite},
            {kVelocity, where_, Mode::read}};
  }

  void configure(State& s) override {
    if (!s.has_field(kVelocity))
      throw InputError("phoretic.integrate: no stage before it writes the `velocity` field; put phoretic.forces "
                       "(range: long or short) before phoretic.integrate");
  }

  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    const bool dev = where_ == Where::device;
    Field& pos = s.field(fields::position);
    Field& img = s.field(fields::image);
    Field& vel = s.field(kVelocity);
    R* x = dev ? pos.device<R>() : pos.host<R>();
    std::int32_t* im = dev ? img.device<std::int32_t>() : img.host<std::int32_t>();
    const R* v = dev ? vel.device<R>() : vel.host<R>();
    const auto box = PeriodicBox<R>::make(s.box.L);
    const R dt = R(ctx.dt);
    const R amp = R(std::sqrt(2.0 * p_.D * ctx.dt));
    if (s.dim() == 2)
      loops_.loop2(s.n(), PhoreticStep<R, 2>{x, im, v, box, dt, amp, ctx.rng, ctx.step, ctx.attempt}, ctx.stream);
    else
      loops_.loop3(s.n(), PhoreticStep<R, 3>{x, im, v, box, dt, amp, ctx.rng, ctx.step, ctx.attempt}, ctx.stream);
    return Outcome::ok();
  }

 private:
  IntegrateParams p_;
  Where where_;
  IntegrateLoops<R> loops_;
};

}  // namespace ff::phoretic
