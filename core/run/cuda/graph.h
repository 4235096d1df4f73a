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

  StepParams* device() const { return device_; }
  // Make the device block hold `p` for work enqueued after this on `stream` (no-op when the
  // device already will).
  void set(const StepParams& p, cudaStream_t stream);
  // Enqueue the advance kernel and remember what the device will hold afterwards.
  void advance(cudaStream_t stream);
  // Record that a replayed graph advanced the block.
  void advanced_by_graph();

 private:
  StepParams* device_ = nullptr;
  StepParams expected_{};  // what the device holds once enqueued work has run
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
