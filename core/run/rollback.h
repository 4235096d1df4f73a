// Rollback: a snapshot of what the step writes, and the Δt policy.
//
// Before each step the core snapshots every field the compute stages write (only when some
// stage may request a rollback). A rollback restores the snapshot bit for bit, halves Δt and
// re-runs the step with attempt + 1 (fresh random numbers). After `grow_after` accepted steps
// in a row Δt doubles back toward its configured value. Below dt_min the run stops. A stage may
// also limit a step's Δt (Outcome::limit_dt): DtController below.
#pragma once
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "core/stage/state.h"

namespace ff {

// dst gets src's contents on side `where` (resized to match if needed). Host: memcpy;
// device: an asynchronous device-to-device copy on `stream`.
void copy_field_contents(Field& dst, Field& src, Where where, CUstream_st* stream);

class Snapshot {
 public:
  // `fields` are copied before every step (take); `on_demand` ones only when a stage announces
  // a write (take_before_write), at most once per step. Each copy is kept on the side where the
  // field is current.
  explicit Snapshot(std::vector<std::string> fields, std::vector<std::string> on_demand = {});
  // Before a step: copy the every-step fields; forget the last step's on-demand copies.
  void take(State& state, CUstream_st* stream);
  // Copy `field` now if it is an on-demand field not yet copied in this step; else nothing.
  // Thread-safe (stages on different branches may call it concurrently).
  void take_before_write(State& state, const std::string& field, CUstream_st* stream);
  // For an on-demand field that the caller is about to overwrite completely, without reading
  // it: instead of a copy, the snapshot takes the field's storage and gives it its own (whose
  // contents are stale), at no cost; the field counts as written on the side where it was
  // current. Once per step, like take_before_write (after either, the other does nothing).
  // Returns the copy holding the field's contents before the swap; null when it swapped nothing.
  Field* take_before_overwrite(State& state, const std::string& field);
  // What `field` held when take() ran (the start of the step), if a stage of this step has
  // written it since: the snapshot's copy. Null when the snapshot holds no copy of it for this
  // step (the field was not written before the caller, or is not one the snapshot covers).
  Field* contents_at_start(const std::string& field);
  // Every-step fields and the on-demand fields copied (or taken) in this step.
  void restore(State& state, CUstream_st* stream);
  std::vector<std::string> fields() const;            // every step
  std::vector<std::string> on_demand_fields() const;  // when announced

 private:
  struct Entry {
    std::string name;
    bool on_demand = false;
    bool taken = false;    // this step (on-demand entries)
    bool swapped = false;  // taken by take_before_overwrite: restore swaps back
    Where side = Where::host;
    std::unique_ptr<Field> copy;
  };
  void copy_in(State& state, Entry& e, CUstream_st* stream);
  std::vector<Entry> entries_;
  std::mutex mutex_;
};

// The whole state as bytes (every field's host copy, the clock and the box), taken before a step
// when RunOptions::check_rollbacks is on, to prove that a rollback restored everything, not
// only what the core planned to snapshot: a stage that writes a field without declaring it, or
// declares a write step_local / on_demand and breaks the promise, shows up here by name.
class StateImage {
 public:
  // Copies every field but those in `skip` (brings device data to the host: slow, a check).
  void take(State& state, const std::vector<std::string>& skip);
  // "" when `state` equals the image bit for bit; else what differs (field, element, values).
  std::string differences(State& state) const;

 private:
  struct FieldBytes {
    std::string name;
    DType dtype;
    int components;
    std::vector<unsigned char> bytes;
  };
  std::vector<FieldBytes> fields_;
  std::uint64_t step_ = 0;
  double time_ = 0;
  double box_[3] = {0, 0, 0};
};

// The Δt of each attempt. Two things set it:
//  - the rollback policy: `current` starts at run.dt, halves on a rollback and doubles back
//    toward run.dt after `grow_after` accepted steps in a row (the streak);
//  - a limit a stage reported (Outcome::limit_dt): the step runs at the largest
//    current/2^k <= limit, so Δt stays run.dt/2^k (step counts and `every` keep their meaning).
//    The limit a step reported is the first guess for the next step: Δt regrows as soon as, and
//    only as far as, the reported limit allows.
// Everything a checkpoint must store to continue bit for bit: current(), streak(), limit().
class DtController {
 public:
  DtController(double dt, double dt_min, std::uint64_t grow_after)
      : nominal_(dt), min_(dt_min), grow_after_(grow_after), current_(dt) {}
  // The Δt of the next attempt: current() reduced by powers of two to within limit().
  double dt() const;
  double nominal() const { return nominal_; }
  double min() const { return min_; }
  // The rollback policy's Δt, before any limit.
  double current() const { return current_; }
  // The limit in force (infinity: none).
  double limit() const { return limit_; }
  // Halve Δt for a retry; false when the halved Δt would be below dt_min (give up).
  bool halve();
  // A stage limited this attempt's Δt to dt_max: the retry runs at dt() <= dt_max. False when
  // that is below dt_min (give up).
  bool limit_to(double dt_max);
  // An accepted step taken at Δt = dt_taken that reported `limit` (infinity: none): keep the
  // limit as the next step's first guess, and count the step toward regrowth unless it needed a
  // rollback (halve() reset the streak then) or was limited below the policy's Δt (it proves
  // nothing about that Δt: the streak stays as it was).
  void accepted(double dt_taken, double limit = kNoLimit, bool rolled_back = false);
  // A step that needed a rollback resets the streak.
  void rolled_back() { streak_ = 0; }
  // Restore after a checkpoint/restart.
  void set(double current, std::uint64_t streak, double limit = kNoLimit) {
    current_ = current;
    streak_ = streak;
    limit_ = limit;
  }
  std::uint64_t streak() const { return streak_; }
  static constexpr double kNoLimit = std::numeric_limits<double>::infinity();

 private:
  double nominal_, min_;
  std::uint64_t grow_after_;
  double current_;
  std::uint64_t streak_ = 0;
  double limit_ = kNoLimit;
};

}  // namespace ff
