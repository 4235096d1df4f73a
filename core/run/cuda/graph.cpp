#include "core/run/cuda/graph.h"

#include <cstring>

#include "core/backend/cuda/check.h"

namespace ff {

DeviceStepParams::DeviceStepParams() {
  FF_CUDA_CHECK(cudaMalloc(&device_, sizeof(StepParams) * kAhead), "allocating device step parameters");
}

DeviceStepParams::~DeviceStepParams() { cudaFree(device_); }

namespace {
bool same(const StepParams& a, const StepParams& b) {
  return a.step == b.step && a.attempt == b.attempt && a.dt == b.dt && a.time == b.time;
}
}  // namespace

void DeviceStepParams::upload(const StepParams* from, int count, cudaStream_t stream) {
  // From pageable memory: the runtime stages the bytes before returning, so the slots may change
  // right away; the copy itself is ordered on `stream`, after the work that reads the old values.
  FF_CUDA_CHECK(cudaMemcpyAsync(device_, from, sizeof(StepParams) * std::size_t(count), cudaMemcpyHostToDevice, stream),
                "uploading step parameters");
}

void DeviceStepParams::set(const StepParams& p, cudaStream_t stream, bool ahead) {
  // Without `ahead` the block stays in slot 0: a captured graph holds its address.
  if (known_ && (ahead || slot_ == 0) && same(p, slots_[slot_])) return;
  if (ahead && slot_ + 1 < filled_ && same(p, slots_[slot_ + 1])) {
    ++slot_;
    return;
  }
  slot_ = 0;
  known_ = true;
  slots_[0] = p;
  filled_ = ahead ? kAhead : 0;
  for (int k = 1; k < filled_; ++k) {
    slots_[k] = slots_[k - 1];
    slots_[k].step += 1;
    slots_[k].attempt = 0;
    slots_[k].time += p.dt;
  }
  upload(slots_, ahead ? kAhead : 1, stream);
}

void DeviceStepParams::advance(cudaStream_t stream) {
  launch_advance_step(device(), stream);
  advanced_by_graph();
}

void DeviceStepParams::advanced_by_graph() {
  StepParams& e = slots_[slot_];
  e.step += 1;
  e.time += e.dt;
  e.attempt = 0;
  filled_ = 0;  // the slots after this one no longer follow it
}

CapturedStep::~CapturedStep() {
  if (exec_) cudaGraphExecDestroy(exec_);
  if (graph_) cudaGraphDestroy(graph_);
}

bool CapturedStep::capture(cudaStream_t stream, const std::function<void()>& enqueue, std::string& why) {
  // Relaxed: stages enqueue from oneTBB workers, not only from the capturing thread.
  FF_CUDA_CHECK(cudaStreamBeginCapture(stream, cudaStreamCaptureModeRelaxed), "starting a step capture");
  std::string failure;
  try {
    enqueue();
  } catch (const std::exception& e) {
    failure = e.what();
  }
  cudaGraph_t g = nullptr;
  const cudaError_t end = cudaStreamEndCapture(stream, &g);
  if (!failure.empty() || end != cudaSuccess) {
    cudaGetLastError();  // clear the capture's error state
    if (g) cudaGraphDestroy(g);
    why = !failure.empty() ? failure : std::string(cudaGetErrorString(end));
    return false;
  }
  graph_ = g;
  const cudaError_t inst = cudaGraphInstantiate(&exec_, graph_, 0);
  if (inst != cudaSuccess) {
    cudaGetLastError();
    why = cudaGetErrorString(inst);
    cudaGraphDestroy(graph_);
    graph_ = nullptr;
    exec_ = nullptr;
    return false;
  }
  return true;
}

void CapturedStep::launch(cudaStream_t stream) {
  FF_CUDA_CHECK(cudaGraphLaunch(exec_, stream), "launching the captured step");
}

}  // namespace ff
