#include "stages/observe/progress/stage.h"

#include <cmath>
#include <unistd.h>


namespace ff::observe {

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--:--";
  const auto s = std::uint64_t(std::llround(seconds));
  char buf[64];
  std::snprintf(buf, sizeof buf, "%llu:%02llu:%02llu", (unsigned long long)(s / 3600),
                (unsigned long long)(s / 60 % 60), (unsigned long long)(s % 60));
  return buf;
}

std::string format_progress(const ProgressLine& p) {
  char head[96];
  if (p.steps > 0)
    std::snprintf(head, sizeof head, "step %llu/%llu (%.1f%%)", (unsigned long long)p.step,
                  (unsigned long long)p.steps, 100.0 * double(p.step) / double(p.steps));
  else
    std::snprintf(head, sizeof head, "step %llu", (unsigned long long)p.step);
  const double left = p.steps > p.step ? double(p.steps - p.step) : 0.0;
  const std::string eta = p.rate > 0 ? format_duration(left / p.rate) : format_duration(-1);
  char rest[160];
  std::snprintf(rest, sizeof rest, "  t %.6g  Δt %.3g  %.4g steps/s  ETA %s  rollbacks %llu", p.time, p.dt, p.rate,
                eta.c_str(), (unsigned long long)p.rollbacks);
  std::string line = std::string(head) + rest;
  if (p.dt_limits) line += "  Δt limited " + std::to_string(p.dt_limits);
  return line;
}

Progress::Progress(ProgressParams p, RunInfo info, std::FILE* out)
    : p_(p), info_(std::move(info)), out_(out ? out : info_.messages), tty_(isatty(fileno(out_)) != 0) {}

Outcome Progress::run(StepContext& ctx) {
  const Clock::time_point now = Clock::now();
  if (!started_) {
    started_ = true;
    start_ = last_print_ = now;
    first_step_ = ctx.host_params.step;
  }
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const bool first_interval = !rate_restarted_ && ctx.host_params.step > first_step_;
  last_.step = ctx.host_params.step;  // observers see the accepted state: steps done
  last_.steps = info_.steps;
  last_.time = ctx.host_params.time;
  last_.dt = ctx.stats.dt;
  last_.rollbacks = ctx.stats.rollbacks;
  last_.dt_limits = ctx.stats.dt_limits;
  last_.rate = elapsed > 0 ? double(last_.step - first_step_) / elapsed : 0.0;
  if (first_interval) {
    // The run's first step does its one-off work (the triangulation's CGAL build, the first
    // Verlet list, a CUDA graph's capture), which at 10^6 particles can outlast a thousand later
    // steps: this report gives no rate, and the rate from here on leaves that interval out, so
    // the ETA is never hours off.
    last_.rate = 0.0;
    rate_restarted_ = true;
    start_ = now;
    first_step_ = last_.step;
  }

  const double since_print = std::chrono::duration<double>(now - last_print_).count();
  if (tty_) {
    if (line_open_ && since_print < 0.1) return Outcome::ok();
    std::fprintf(out_, "\r%s\x1b[K", format_progress(last_).c_str());
    line_open_ = true;
  } else {
    if (since_print < p_.interval) return Outcome::ok();
    std::fprintf(out_, "%s\n", format_progress(last_).c_str());
  }
  std::fflush(out_);
  last_print_ = now;
  return Outcome::ok();
}

void Progress::finish(State&, bool) {
  // The `pipeline` command prints the run's summary; here only the terminal line is ended.
  if (line_open_) std::fputc('\n', out_);
  line_open_ = false;
  std::fflush(out_);
}

}  // namespace ff::observe
