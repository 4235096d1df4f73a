#include "core/backend/cuda/check.h"
#include "core/run/cuda/graph.h"

namespace ff {

__global__ void advance_step_kernel(StepParams* p) {
  p->step += 1;
  p->time += p->dt;
  p->attempt = 0;
}

void launch_advance_step(StepParams* params, cudaStream_t stream) {
  advance_step_kernel<<<1, 1, 0, stream>>>(params);
  FF_CUDA_CHECK_LAUNCH("advancing the device step parameters");
}

}  // namespace ff
