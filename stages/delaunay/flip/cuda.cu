// delaunay.flip's sub-step tries on the device (untangle.h, DeviceTries): one kernel launch runs
// the tries that untangle_step's loop would run one host round trip each. A cooperative kernel:
// thread 0 decides, from the counters as read_try reads them, what the host's loop would do next
// (another repair round, an accepted try, a failed one, or stop at a try's end the host acts on:
// at the targets, a rollback, a throw; tries.h, decide_next), then the whole grid runs that
// branch's passes (kernel.h's functors with the lengths, lists and generations read on the
// device; ListSpan: every element is taken whatever the grid), with grid.sync after the decision
// and after each pass where the host's loop had a launch boundary. The passes, their lists and
// their order are the host loop's, so the bits are too. (A CUDA graph with a while node and a
// switch of the branches did the same 0.3 ms a step slower at 2^18: bench/experiments/README.md,
// trydev.) Compiled with -fmad=false (the plugin's .cu).
#include <cooperative_groups.h>
#include <cuda_runtime.h>

#include <algorithm>

#include "core/backend/cuda/check.h"
#include "core/backend/cuda/loop.cuh"
#include "stages/delaunay/flip/tries.h"

namespace ff::delaunay {

namespace {

// What run() is given, into the device copies the kernel reads (stream-ordered before it).
template <class R>
__global__ void set_tries(TryArgs<R> a, TryState s, TryArgs<R>* to_a, TryState* to_s) {
  *to_a = a;
  *to_s = s;
}

// The tries: thread 0 decides, the grid waits for it and for each pass.
template <class R>
__global__ void tries_kernel(const TryArgs<R>* a, TryState* sp) {
  namespace cg = cooperative_groups;
  cg::grid_group grid = cg::this_grid();
  const std::size_t i = grid.thread_rank(), threads = grid.size();
  while (true) {
    if (i == 0) {
      TryState s = *sp;
      s.phase = decide_next(*a, s);
      *sp = s;
    }
    grid.sync();
    const unsigned phase = sp->phase;
    if (phase == kPhaseStop) return;
    for (int p = 0; p < kTryPasses; ++p)
      if (pass_runs(p, phase)) {
        run_pass<R>(p, *a, sp, i, threads);
        grid.sync();
      }
  }
}

// One block of kBlock a SM (a cooperative grid must be resident at once; the lists are small, and
// fewer blocks make grid.sync cheaper); where the kernel does not fit, the host's loop.
template <class R>
class CooperativeTries final : public DeviceTries<R> {
 public:
  ~CooperativeTries() override {
    if (args_) cudaFree(args_);
    if (state_) cudaFree(state_);
    if (landing_) cudaFreeHost(landing_);
    if (landing_counters_) cudaFreeHost(landing_counters_);
  }

  bool run(const TryArgs<R>& a, TryState& s, unsigned* counters, CUstream_st* st) override {
    if (!made_) {
      int device = 0, sms = 0, per_sm = 0;
      FF_CUDA_CHECK(cudaGetDevice(&device), "delaunay.flip: the device");
      FF_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device), "delaunay.flip: the device");
      FF_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, tries_kernel<R>, kBlock, 0),
                    "delaunay.flip: the sub-step tries' occupancy");
      grid_ = per_sm > 0 ? unsigned(sms) : 0u;
      FF_CUDA_ALLOC(args_, sizeof(TryArgs<R>), "delaunay.flip's sub-step tries");
      FF_CUDA_ALLOC(state_, sizeof(TryState), "delaunay.flip's sub-step tries");
      FF_CUDA_CHECK(cudaMallocHost(&landing_, sizeof(TryState)), "delaunay.flip: pinned memory");
      FF_CUDA_CHECK(cudaMallocHost(&landing_counters_, 2 * kSubstepCounters * sizeof(unsigned)),
                    "delaunay.flip: pinned memory");
      made_ = true;
    }
    if (grid_ == 0) return false;
    set_tries<R><<<1, 1, 0, st>>>(a, s, args_, state_);
    FF_CUDA_CHECK_LAUNCH("delaunay.flip: passing the sub-step tries their lists");
    void* params[] = {&args_, &state_};
    FF_CUDA_CHECK(cudaLaunchCooperativeKernel(reinterpret_cast<const void*>(tries_kernel<R>), dim3(grid_),
                                              dim3(kBlock), params, 0, st),
                  "delaunay.flip: launching the sub-step tries");
    FF_CUDA_CHECK(cudaMemcpyAsync(landing_, state_, sizeof(TryState), cudaMemcpyDeviceToHost, st),
                  "delaunay.flip: reading the sub-step tries' state");
    FF_CUDA_CHECK(cudaMemcpyAsync(landing_counters_, a.first_block, 2 * kSubstepCounters * sizeof(unsigned),
                                  cudaMemcpyDeviceToHost, st),
                  "delaunay.flip: reading the sub-step tries' counters");
    FF_CUDA_CHECK(cudaStreamSynchronize(st), "delaunay.flip: the sub-step tries");
    s = *landing_;
    std::copy(landing_counters_, landing_counters_ + 2 * kSubstepCounters, counters);
    return true;
  }

 private:
  static constexpr int kBlock = 256;
  bool made_ = false;
  unsigned grid_ = 0;
  TryArgs<R>* args_ = nullptr;  // device copies of what run() is given
  TryState* state_ = nullptr;
  TryState* landing_ = nullptr;  // pinned: what the tries end with
  unsigned* landing_counters_ = nullptr;
};

}  // namespace

template <class R>
std::unique_ptr<DeviceTries<R>> device_tries(const CudaExec&) {
  return std::make_unique<CooperativeTries<R>>();
}
template std::unique_ptr<DeviceTries<float>> device_tries<float>(const CudaExec&);
template std::unique_ptr<DeviceTries<double>> device_tries<double>(const CudaExec&);

}  // namespace ff::delaunay
