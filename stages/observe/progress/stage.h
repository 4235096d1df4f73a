// observe.progress: a progress report every time it runs (the pipeline's `every: k`): step,
// simulated time, Δt, steps/s and ETA (over the steps after its first interval, which holds the
// first step's one-off work: unknown, "--:--", until the report after it), rollbacks and (when a
// stage limits Δt) Δt limits. On a
// terminal one line updates in place (at most ten times a second); otherwise a plain line at
// most every `interval` seconds, so logs stay quiet. finish() ends the terminal line (the `pipeline` command prints the summary).
#pragma once
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>

#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"

namespace ff::observe {

struct ProgressParams {
  double interval = 10;  // seconds between lines when the output is not a terminal

  template <class P>
  void describe(P& p) {
    p(interval, "interval", "seconds between progress lines when the output is not a terminal").at_least(0);
  }
};

struct ProgressLine {
  std::uint64_t step = 0;   // steps done
  std::uint64_t steps = 0;  // steps the run will take
  double time = 0;          // simulated time
  double dt = 0;
  double rate = 0;          // steps per wall-clock second (0: not known yet)
  std::uint64_t rollbacks = 0;
  std::uint64_t dt_limits = 0;  // steps run again at a Δt a stage limited (shown when any)
};

// "step 1200/10000 (12.0%)  t 12  Δt 0.01  850 steps/s  ETA 0:00:10  rollbacks 3"
std::string format_progress(const ProgressLine& p);
// "1:02:03"; "--:--" when unknown (negative or not finite).
std::string format_duration(double seconds);

class Progress final : public Stage {
 public:
  static StageDecl declaration() {
    return {"observe.progress", "progress on the terminal (steps/s, ETA), a line every `interval` s in logs",
            schema_of<ProgressParams>(), {2, 3}, true};
  }

  // Host-only (reads no fields): the same on every backend. Lines go to the run's messages
  // (RunInfo::messages: stderr, or a run.log of an in-process sweep).
  Progress(const ParamValues& v, const RunInfo& info) : Progress(params_from<ProgressParams>(v), info) {}
  // `out` is where lines go (null: info.messages; tests pass a file).
  Progress(ProgressParams p, RunInfo info, std::FILE* out = nullptr);

  std::vector<Access> accesses() const override { return {}; }
  Outcome run(StepContext& ctx) override;
  void finish(State& state, bool completed) override;

 private:
  using Clock = std::chrono::steady_clock;
  ProgressParams p_;
  RunInfo info_;
  std::FILE* out_;
  bool tty_;
  bool started_ = false;
  bool line_open_ = false;  // a terminal line was printed without its newline
  bool rate_restarted_ = false;  // the rate's clock restarted after the first interval of steps
  std::uint64_t first_step_ = 0;
  Clock::time_point start_, last_print_;
  ProgressLine last_;
};

}  // namespace ff::observe

FLIPFLOW_HOST_STAGE(ff::observe::Progress)
