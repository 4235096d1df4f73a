// observe.msd: mean-squared displacement of the unwrapped positions (position + image·L) from
// those at the stage's first run, reported as the metric `msd` (observe.h5md writes it under
// /observables/<stage id>/msd). The sum is deterministic for any thread count.
#pragma once
#include <vector>

#include "core/stage.h"
#include "stages/observe/msd/cpu.h"

namespace ff::observe {

class Msd final : public Stage {
 public:
  std::vector<Access> accesses() const override {
    return {{fields::position, Where::host, Mode::read}, {fields::image, Where::host, Mode::read}};
  }

  Outcome run(StepContext& ctx) override {
    const State& s = ctx.state;
    if (reference_.empty()) unwrapped_positions(s, reference_);
    const double sum = s.n() ? sum_squared_displacement(s, reference_) : 0.0;
    ctx.metrics.set("msd", s.n() ? sum / double(s.n()) : 0.0);
    return Outcome::ok();
  }

 private:
  std::vector<double> reference_;  // unwrapped positions at the first run, n x dim
};

}  // namespace ff::observe
