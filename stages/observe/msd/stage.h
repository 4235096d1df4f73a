// observe.msd: mean-squared displacement of the unwrapped positions (position + image·L) from a
// reference, reported as the metric `msd` (observe.h5md writes it under
// /observables/<stage id>/msd). The sum is deterministic for any thread count.
//
// The reference (the time origin) is the initial state, step 0, whatever the schedule: with
// `at: {log: {first: 10, ...}}` the value at step 10 is already the displacement from step 0.
// configure() takes it, so a stage that renumbers particles at configure (delaunay.sort, which
// asks to be listed first) must be listed before this one. With `from_step: k > 0` the reference
// is instead the state at the first call at or after step k (the next step of the schedule when
// it does not hit k), for a steady-state MSD after an equilibration; calls before it report NaN.
// The reference, and whether it was taken, go into checkpoints; a checkpoint of the code before
// from_step (only "reference", empty until the first call) still resumes.
#pragma once
#include <cstdint>
#include <limits>
#include <vector>

#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "core/stage/state.h"

namespace ff::observe {

struct MsdParams {
  std::int64_t from_step = 0;

  template <class P>
  void describe(P& p) {
    p(from_step, "from_step",
      "the time origin: 0 measures from the initial state (step 0) whatever the schedule; k > 0 from the state at "
      "the first call at or after step k (the next step of the schedule when it does not run at k), with msd = "
      "NaN before it")
        .at_least(0);
  }
};

// Unwrapped positions (position + image·L) of every particle, n x dim doubles (cpu.cpp).
void unwrapped_positions(const State& s, std::vector<double>& out);
// Σ_i |unwrapped_i - reference_i|², summed in a fixed order: the same bits for any thread count.
double sum_squared_displacement(const State& s, const std::vector<double>& reference);

class Msd final : public Stage {
 public:
  static StageDecl declaration() {
    return {"observe.msd",
            "mean-squared displacement of unwrapped positions since step 0 (or from_step) (metric `msd`, NaN "
            "before from_step)",
            schema_of<MsdParams>(), {2, 3}, true};
  }

  // from_step 0. Driven alone without configure() (tests), its first call takes the reference.
  Msd() = default;
  // Host accesses: on the CUDA backend the core brings the fields to the host.
  Msd(const ParamValues& v, const RunInfo& info) : Msd(params_from<MsdParams>(v), info) {}
  Msd(MsdParams p, RunInfo info) : p_(p), info_(std::move(info)) {}

  std::vector<Access> accesses() const override {
    return {{fields::position, Where::host, Mode::read}, {fields::image, Where::host, Mode::read}};
  }
  void configure(State& s) override;
  Outcome run(StepContext& ctx) override;

  // The reference positions and whether they were taken: a continued run measures from the same
  // origin, and one stopped before from_step still takes it at from_step.
  void save_state(StageState& out) override;
  void restore_state(const StageState& saved, State& s) override;

  bool has_reference() const { return taken_; }

 private:
  void take_reference(const State& s);
  // The same from configure or restore_state, where no step brought the fields to the host.
  void take_reference_outside_a_step(State& s);

  MsdParams p_;
  RunInfo info_;
  std::vector<double> reference_;  // unwrapped positions at the time origin, n x dim
  bool taken_ = false;
  static constexpr double nan_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace ff::observe

FLIPFLOW_HOST_STAGE(ff::observe::Msd)
