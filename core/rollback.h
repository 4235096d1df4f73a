// Rollback: a snapshot of what the step writes, and the Δt policy.
//
// Before each step the core snapshots every field the compute stages write (only when some
// stage may request a rollback). A rollback restores the snapshot bit for bit, halves Δt and
// re-runs the step with attempt + 1 (fresh random numbers). After `grow_after` accepted steps
// in a row Δt doubles back toward its configured value. Below dt_min the run stops.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/state.h"

namespace ff {

// dst gets src's contents on side `where` (resized to match if needed). Host: memcpy;
// device: an asynchronous device-to-device copy on `stream`.
void copy_field_contents(Field& dst, Field& src, Where where, CUstream_st* stream);

class Snapshot {
 public:
  // The fields to keep; each is copied from whichever side is current.
  explicit Snapshot(std::vector<std::string> fields) : names_(std::move(fields)) {}
  void take(State& state, CUstream_st* stream);
  void restore(State& state, CUstream_st* stream);
  const std::vector<std::string>& fields() const { return names_; }

 private:
  std::vector<std::string> names_;
  std::vector<std::unique_ptr<Field>> copies_;
  std::vector<Where> sides_;
};

class DtController {
 public:
  DtController(double dt, double dt_min, std::uint64_t grow_after)
      : nominal_(dt), min_(dt_min), grow_after_(grow_after), current_(dt) {}
  double dt() const { return current_; }
  double nominal() const { return nominal_; }
  double min() const { return min_; }
  // Halve Δt for a retry; false when the halved Δt would be below dt_min (give up).
  bool halve();
  // An accepted step: count it and regrow Δt after `grow_after` good steps in a row.
  void accepted();
  // A step that needed a rollback resets the streak.
  void rolled_back() { streak_ = 0; }
  // Restore after a checkpoint/restart.
  void set(double current, std::uint64_t streak) { current_ = current; streak_ = streak; }
  std::uint64_t streak() const { return streak_; }

 private:
  double nominal_, min_;
  std::uint64_t grow_after_;
  double current_;
  std::uint64_t streak_ = 0;
};

}  // namespace ff
