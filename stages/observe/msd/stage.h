// observe.msd: mean-squared displacement of the unwrapped positions (position + image·L) from
// those at the stage's first run, reported as the metric `msd` (observe.h5md writes it under
// /observables/<stage id>/msd). The sum is deterministic for any thread count.
#pragma once
#include <vector>

#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "core/stage/state.h"

namespace ff::observe {

// Unwrapped positions (position + image·L) of every particle, n x dim doubles (cpu.cpp).
void unwrapped_positions(const State& s, std::vector<double>& out);
// Σ_i |unwrapped_i - reference_i|², summed in a fixed order: the same bits for any thread count.
double sum_squared_displacement(const State& s, const std::vector<double>& reference);

class Msd final : public Stage {
 public:
  static StageDecl declaration() {
    return {"observe.msd", "mean-squared displacement of unwrapped positions since the first run (metric `msd`)",
            {}, {2, 3}, true};
  }

  Msd() = default;
  // Host accesses: on the CUDA backend the core brings the fields to the host.
  Msd(const ParamValues&, const RunInfo&) {}

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

  // The reference positions: a continued run measures from the same start.
  void save_state(StageState& out) override { out.put("reference", reference_); }
  void restore_state(const StageState& saved, State&) override {
    if (saved.has("reference")) reference_ = saved.get_vector<double>("reference");
  }

 private:
  std::vector<double> reference_;  // unwrapped positions at the first run, n x dim
};

}  // namespace ff::observe

FLIPFLOW_HOST_STAGE(ff::observe::Msd)
