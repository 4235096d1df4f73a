// brownian.integrate: free overdamped Brownian motion (no forces), 2D and 3D.
#pragma once
#include <cmath>

#include "core/error.h"
#include "core/exec.h"
#include "core/params.h"
#include "core/stage.h"
#include "plugins/brownian/integrate/kernel.h"

namespace ff::brownian {

struct IntegrateParams {
  double D = 1.0;  // translational diffusion coefficient

  static std::vector<ParamSpec> schema() {
    return {ParamSpec::real("D", 1.0, "translational diffusion coefficient (σ²/τ)").at_least(0)};
  }
  static IntegrateParams from(const ParamValues& v) { return IntegrateParams{v.real("D")}; }
};

// The element loops for each (precision, dimension), chosen by backend in plugin.cpp.
template <class R>
struct IntegrateLoops {
  ElementLoop<BrownianStep<R, 2>> loop2;
  ElementLoop<BrownianStep<R, 3>> loop3;
};

template <class R>
class Integrate final : public Stage {
 public:
  Integrate(IntegrateParams p, Where where, IntegrateLoops<R> loops) : p_(p), where_(where), loops_(loops) {}

  std::vector<Access> accesses() const override {
    return {{fields::position, where_, Mode::readwrite}, {fields::image, where_, Mode::readwrite}};
  }

  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    Field& pos = s.field(fields::position);
    Field& img = s.field(fields::image);
    const bool dev = where_ == Where::device;
    const auto box = PeriodicBox<R>::make(s.box.L);
    R* x = dev ? pos.device<R>() : pos.host<R>();
    std::int32_t* im = dev ? img.device<std::int32_t>() : img.host<std::int32_t>();
    if (s.dim() == 2)
      loops_.loop2(s.n(), BrownianStep<R, 2>{x, im, box, 2 * p_.D, ctx.rng, ctx.params}, ctx.stream);
    else
      loops_.loop3(s.n(), BrownianStep<R, 3>{x, im, box, 2 * p_.D, ctx.rng, ctx.params}, ctx.stream);
    return Outcome::ok();
  }

  // Per-step values come from ctx.params, so a CUDA run can replay this stage from a graph.
  bool graph_capturable() const override { return true; }

 private:
  IntegrateParams p_;
  Where where_;
  IntegrateLoops<R> loops_;
};

}  // namespace ff::brownian
