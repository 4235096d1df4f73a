// Streams, events and device rollback flags for one run's step graph (CUDA runs only).
//
// Stream assignment: a stage inherits the stream of its first predecessor unless another
// successor of that predecessor already took it; every other stage gets a new stream. So a
// chain runs on one stream with no events, and each branch of a fork gets its own.
// Joins: a stage waits (cudaStreamWaitEvent) on the events of predecessors that ran on other
// streams; at the end of an attempt the main stream waits on every stream. Nothing here
// blocks the host except read_rollback_flags() and synchronize().
#pragma once
#include <cuda_runtime.h>

#include <optional>
#include <vector>

#include "core/run/scheduler.h"
#include "core/run/step_graph.h"

namespace ff {

class StreamSet {
 public:
  // device_flags: some compute stage may request a rollback (flags are zeroed and read per step).
  StreamSet(const StepGraph& graph, bool device_flags);
  ~StreamSet();
  StreamSet(const StreamSet&) = delete;
  StreamSet& operator=(const StreamSet&) = delete;

  CUstream_st* main() const { return streams_.front(); }
  CUstream_st* stream(int node) const { return streams_[stream_of_[node]]; }
  DeviceRollbackFlag* rollback_flag(int node) const { return flags_ + node; }
  // The device word of the step's device decision (StepContext::gate), zeroed once.
  unsigned* gate() const { return gate_; }

  void begin_attempt();        // record the start event, zero the rollback flags
  void before(int node);       // make the node's stream wait for its predecessors
  void after(int node);        // record the node's event
  void join_all();             // main stream waits for all others
  // One device->host read of all flags (only if some stage may request a rollback).
  std::optional<RollbackRequest> read_rollback_flags(const StepGraph& graph, const std::vector<StageSlot>& slots);
  void synchronize();

 private:
  const StepGraph& graph_;
  bool device_flags_;
  std::vector<cudaStream_t> streams_;
  std::vector<int> stream_of_;
  std::vector<cudaEvent_t> events_;  // one per node
  cudaEvent_t start_ = nullptr;
  DeviceRollbackFlag* flags_ = nullptr;       // device, one per node
  DeviceRollbackFlag* host_flags_ = nullptr;  // pinned
  unsigned* gate_ = nullptr;                  // device
};

}  // namespace ff
