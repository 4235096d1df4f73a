#include "core/run/cuda/graph.h"

#include <cstring>

#include "core/backend/cuda/check.h"

namespace ff {

DeviceStepParams::DeviceStepParams() {
  FF_CUDA_CHECK(cudaMalloc(&device_, sizeof(StepParams)), "allocating device step parameters");
}

DeviceStepParams::~DeviceStepParams() { cudaFree(device_); }

namespace {
bool same(const StepParams& a, const StepParams& b) {
  return a.step == b.step && a.attempt == b.attempt && a.dt == b.dt && a.time == b.time;
}
}  // namespace

void DeviceStepParams::set(const StepParams& p, cudaStream_t stream) {
  if (known_ && same(p, expected_)) return;
  expected_ = p;
  known_ = true;
  // From pageable memory: the runtime stages the bytes before returning, so `expected_` may
  // change right away; the copy itself is ordered on `stream`.
  FF_CUDA_CHECK(cudaMemcpyAsync(device_, &expected_, sizeof(StepParams), cudaMemcpyHostToDevice, stream),
                "uploading step parameters");
}

void DeviceStepParams::advance(cudaStream_t stream) {
  launch_advance_step(device_, stream);
  advanced_by_graph();
}

void DeviceStepParams::advanced_by_graph() {
  expected_.step += 1;
  expected_.time += expected_.dt;
  expected_.attempt = 0;
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
