#include "stages/observe/msd/stage.h"

#include <cstdio>
#include <string>

#include "core/base/error.h"

namespace ff::observe {

void Msd::take_reference(const State& s) {
  unwrapped_positions(s, reference_);
  taken_ = true;
}

void Msd::take_reference_outside_a_step(State& s) {
  // On CUDA the fields may already live on the device (a stage configured before this one may
  // have used them there); acquiring with no stream waits for the device and copies them back.
  s.field(fields::position).acquire(Where::host, Mode::read);
  s.field(fields::image).acquire(Where::host, Mode::read);
  take_reference(s);
}

void Msd::configure(State& s) {
  // Not an error: a short trial run (--set run.steps=100) of a long run's pipeline is common.
  if (info_.steps > 0 && std::uint64_t(p_.from_step) > info_.steps)
    std::fprintf(info_.messages,
                 "flipflow: warning: observe.msd: from_step = %lld is after the run's last step (%llu): msd stays "
                 "NaN in this run (lower from_step, or lengthen run.steps)\n",
                 static_cast<long long>(p_.from_step), static_cast<unsigned long long>(info_.steps));
  if (p_.from_step > 0) return;
  // The initial state, before any step: a log schedule's first call may be many steps later.
  take_reference_outside_a_step(s);
}

Outcome Msd::run(StepContext& ctx) {
  const State& s = ctx.state;
  if (!taken_ && ctx.host_params.step >= std::uint64_t(p_.from_step)) take_reference(s);
  if (!taken_) {
    ctx.metrics.set("msd", nan_);
    return Outcome::ok();
  }
  const double sum = s.n() ? sum_squared_displacement(s, reference_) : 0.0;
  ctx.metrics.set("msd", s.n() ? sum / double(s.n()) : 0.0);
  return Outcome::ok();
}

void Msd::save_state(StageState& out) {
  out.put("reference", reference_);
  out.put("reference_taken", std::uint8_t(taken_ ? 1 : 0));
}

void Msd::restore_state(const StageState& saved, State& s) {
  if (!saved.has("reference")) return;  // not in the checkpoint's pipeline: configure's reference stands
  reference_ = saved.get_vector<double>("reference");
  if (saved.has("reference_taken")) {
    taken_ = saved.get<std::uint8_t>("reference_taken") != 0;
  } else {
    // A checkpoint of the code before from_step: the reference was taken at the stage's first
    // call, so an empty one means no call yet.
    taken_ = !reference_.empty();
    if (!taken_ && p_.from_step == 0) {
      if (s.step == 0) {
        take_reference_outside_a_step(s);  // the checkpoint's state is the initial one
      } else {
        std::fprintf(info_.messages,
                     "flipflow: warning: observe.msd: the checkpoint (written before from_step existed, at step "
                     "%llu, before this stage's first call) has no step-0 positions: msd is measured from this "
                     "stage's next call\n",
                     static_cast<unsigned long long>(s.step));
      }
    }
  }
  const std::size_t expected = s.n() * std::size_t(s.dim());
  if (taken_ && reference_.size() != expected)
    throw InputError("observe.msd: the checkpoint's reference has " + std::to_string(reference_.size()) +
                     " coordinates, the state " + std::to_string(expected));
  if (!taken_) reference_.clear();
}

}  // namespace ff::observe
