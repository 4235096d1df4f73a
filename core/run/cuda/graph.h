// The steady-state step as a CUDA graph: captured once from the stages' own launches, then
// replayed with one cudaGraphLaunch per step. Per-step values reach the kernels through a
// device StepParams block, which a kernel at the end of the graph advances (step + 1,
// time + Δt); the host rewrites it only when it knows better (a rollback, a new Δt).
#pragma once
#include <cuda_runtime.h>

#include <functional>
#include <string>

#include "core/stage/stage.h"

namespace ff {

// Device kernel: params->step += 1, params->time += params->dt, params->attempt = 0.
void launch_advance_step(StepParams* params, cudaStream_t stream);

class DeviceStepParams {
 public:
  DeviceStepParams();
  ~DeviceStepParams();
  DeviceStepParams(const DeviceStepParams&) = delete;
  DeviceStepParams& operator=(const DeviceStepParams&) = delete;

  // The block the work enqueued next reads (one of kAhead slots).
  StepParams* device() const { return device_ + slot_; }
  // Make device() hold `p` for work enqueued after this on `stream` (no upload when it already
  // will). `ahead`: no captured graph will advance the block before the next set(), so the
  // upload may also fill the following slots with the steps that come next if each is accepted
  // at the same Δt (step + k, attempt 0, time + Δt added k times, as Simulation::advance adds
  // it): while the prediction holds, a step only moves to the next slot. On a step of small
  // kernels the upload was one host call in eight on the critical path, between the last wait
  // of one step and the first launch of the next.
  void set(const StepParams& p, cudaStream_t stream, bool ahead = false);
  // Enqueue the advance kernel and remember what the device will hold afterwards.
  void advance(cudaStream_t stream);
  // Record that a replayed graph advanced the block.
  void advanced_by_graph();

  static constexpr int kAhead = 64;

 private:
  void upload(const StepParams* from, int count, cudaStream_t stream);

  StepParams* device_ = nullptr;  // kAhead slots
  StepParams slots_[kAhead] = {};  // what each slot holds once enqueued work has run
  int slot_ = 0;                   // device()'s
  int filled_ = 0;                 // slots [0, filled_) hold predicted steps (0: only slot_ is known)
  bool known_ = false;
};

class CapturedStep {
 public:
  CapturedStep() = default;
  ~CapturedStep();
  CapturedStep(const CapturedStep&) = delete;
  CapturedStep& operator=(const CapturedStep&) = delete;

  // Capture everything `enqueue` puts on `stream` (and streams it forks and joins). Returns
  // false with `why` if the stages did something a graph cannot hold; nothing is left captured.
  bool capture(cudaStream_t stream, const std::function<void()>& enqueue, std::string& why);
  bool ready() const { return exec_ != nullptr; }
  void launch(cudaStream_t stream);

 private:
  cudaGraph_t graph_ = nullptr;
  cudaGraphExec_t exec_ = nullptr;
};

}  // namespace ff
