// The host's side of the non-finite check the overdamped steps make on every particle (kernel.h:
// NonFiniteReport), shared by overdamped.integrate and abp.integrate. nvcc-clean.
//
// What it costs where nothing is wrong: nothing on the device besides the compare in the kernel
// (no fill, no copy, no atomic), and on the host one read of a word of host memory per step. The
// kernels publish a report by writing that word themselves (pinned memory on CUDA), so:
//  - on the CPU the loop has finished when run() looks, and the run stops at the step, before any
//    later stage sees the values;
//  - on CUDA run() only enqueues; the stage looks in after_step (after the whole step was
//    enqueued: the stages after it queue behind its kernel, nobody waits for it), also on steps
//    replayed from a CUDA graph (Stage::after_step: it reads ctx.params), and at the start of its next
//    run(). What it sees there is what the device has finished: where some stage of the step
//    waits for the device (the Delaunay stages read counters each step) that is this step; in a
//    captured run, whose host runs ahead, a few steps later, never more than 2 × kPace (a fence
//    every kPace steps that the host waits for kPace steps later, when the device is normally long
//    past it). The message names the step the device recorded, not the one the host was at.
//    Before a checkpoint is written (save_state) and at the end of a run the device is idle and
//    the check is exact: a checkpoint never holds a non-finite value.
// NonFiniteCheck holds those looks once, for both stages: each gives it the function that builds
// its own message and stops the run, and forwards run(), after_step, save_state and finish to it.
#pragma once
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>
#include <utility>

#include "core/backend/memory.h"
#include "core/stage/stage.h"
#include "stages/overdamped/integrate/kernel.h"

namespace ff::overdamped {

// What the kernels reported: how many particles, the lowest, and the step and attempt of the
// first report.
struct NonFiniteFound {
  unsigned count = 0;
  unsigned first = 0;
  std::uint64_t step = 0;
  std::uint32_t attempt = 0;

  // "step S" (", attempt A" when it was a retry of the step after a rollback).
  std::string where() const {
    return "step " + std::to_string(step) + (attempt ? " (attempt " + std::to_string(attempt) + ")" : "");
  }
};

// A value for a message: "nan" for every NaN (whatever its sign bit), "inf", "-inf", else %g.
inline std::string value_text(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

class NonFiniteCheck {
 public:
  // On CUDA, the fence that bounds how far behind the check may fall: recorded every kPace
  // accepted steps, waited for kPace steps later.
  static constexpr unsigned kPace = 128;

  // Stops the run with the stage's message for what the kernels found (it throws RunError; the
  // stream is the one to read fields back on, nullptr between steps).
  using Stop = std::function<void(State&, const NonFiniteFound&, CUstream_st*)>;

  // `last_step`: the run's steps (RunInfo::steps; its last step waits for the check).
  template <class Exec>
  NonFiniteCheck(Exec, std::uint64_t last_step, Stop stop)
      : ops_(&Exec::memory()),
        counters_(Exec::memory()),
        published_(Exec::memory()),
        fence_(ops_->fence_create()),
        where_(Exec::where),
        last_step_(last_step),
        stop_(std::move(stop)) {}
  ~NonFiniteCheck() { ops_->fence_destroy(fence_); }
  NonFiniteCheck(const NonFiniteCheck&) = delete;
  NonFiniteCheck& operator=(const NonFiniteCheck&) = delete;

  // The kernels' side. The counters get their start values once, in the stage's first step (on
  // CUDA a step that is never captured): a report stops the run, so nothing resets them.
  NonFiniteReport kernel_side(CUstream_st* s) {
    if (!armed_) {
      counters_.reset(std::array<int, 1>{kBadFirst}, s);
      published_.get(1);
      armed_ = true;
    }
    return {counters_.ptr(), published_.get(1)};
  }

  // The stage's looks: each calls `stop` where a kernel has reported.
  // What has reached host memory so far: at the start of run() (on CUDA an earlier step's report).
  void look(State& s, CUstream_st* stream) {
    if (reported()) stop_(s, read(stream), stream);
  }
  // At the end of run(): on the CPU the loop is done; on CUDA only where run() has waited for the
  // device anyway (`waited`), else after_step looks, once the step is enqueued.
  void after_loop(State& s, CUstream_st* stream, bool waited = false) {
    if (where_ == Where::host || waited) look(s, stream);
  }
  // Stage::after_step. CUDA: what the device has reported so far, without waiting (also on steps
  // replayed from a graph); every kPace steps a fence bounds how far behind that may be.
  void after_step(StepContext& ctx) {
    if (where_ != Where::device) return;
    pace(ctx.stream, ctx.host_params.step + 1 == last_step_);
    look(ctx.state, ctx.stream);
  }
  // Stage::save_state: between steps with the device idle, so a checkpoint never holds what the
  // check would stop.
  void save_state(State& s) { look(s, nullptr); }
  // Stage::finish: a completed run's last steps are checked too.
  void finish(State& s, bool completed) {
    if (completed) look(s, nullptr);
  }

 private:
  // Whether a kernel has reported (what has reached host memory so far; never waits).
  bool reported() {
    return armed_ && *static_cast<const volatile unsigned*>(published_.get(1)) != 0u;
  }

  // The report (waits for the stream; call once reported()).
  NonFiniteFound read(CUstream_st* s) {
    const std::array<unsigned, kNonFiniteSlots>& c = counters_.read(s);
    NonFiniteFound f;
    f.count = c[kBadCount];
    f.first = c[kBadFirst];
    f.step = std::uint64_t(c[kBadStepLow]) | std::uint64_t(c[kBadStepHigh]) << 32;
    f.attempt = c[kBadAttempt];
    return f;
  }

  // Once per accepted step on CUDA (after_step): every kPace steps, wait for the fence recorded
  // kPace steps before (the device is normally far past it) and record a new one on `s`.
  // `last`: the run's last step: wait for this one (nothing is queued after it anyway).
  void pace(CUstream_st* s, bool last) {
    if (++steps_ < kPace && !last) return;
    steps_ = 0;
    if (fence_pending_ && !last) ops_->fence_wait(fence_);
    ops_->fence_record(fence_, s);
    fence_pending_ = true;
    if (last) ops_->fence_wait(fence_);
  }

  const MemoryOps* ops_;
  Counters<kNonFiniteSlots> counters_;
  HostScratch<unsigned> published_;
  void* fence_;
  Where where_;              // the stage's backend: host (CPU) or device (CUDA)
  std::uint64_t last_step_;  // the run's steps (its last step waits for the check)
  Stop stop_;                // the stage's message and stop
  bool armed_ = false;
  bool fence_pending_ = false;
  unsigned steps_ = 0;
};

}  // namespace ff::overdamped
