// The time a thread spends blocked on a device: the CUDA backend's waits on a run's path (events,
// streams, the device; not those of set-up and teardown) are timed by a HostWait, into the
// waiting thread's own total. `pipeline
// bench` subtracts it from a pass's wall time to report the host's own time a step: its stages'
// host code, launches and records (bench/README.md, "Session 45": at 2^10 the host's own time is
// a step's bound once the device's is under it). Per thread: a team's ranks and an in-process
// sweep's runs each count their own. Plain C++ (nvcc includes it from .cu files).
#pragma once

namespace ff {

// Seconds the calling thread has spent in HostWait scopes so far.
double host_wait_seconds();

// Counts the time from its construction to its destruction as a wait of the calling thread:
// wrap one blocking call in it.
class HostWait {
 public:
  HostWait();
  ~HostWait();
  HostWait(const HostWait&) = delete;
  HostWait& operator=(const HostWait&) = delete;

 private:
  long long start_ns_;
};

}  // namespace ff
