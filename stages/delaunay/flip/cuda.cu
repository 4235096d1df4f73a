// delaunay.flip's sub-step tries on the device (untangle.h, DeviceTries): one kernel launch runs
// the tries that untangle_step's loop would run one host round trip each. A cooperative kernel:
// thread 0 decides, from the counters in place, what the loop does next (tries.h, decide_next,
// the host loop's own decision: another repair round, an accepted try, a failed one, or stop at
// a try's end the host acts on: at the targets, a rollback, a throw; the first decision is the
// host's, handed over with the state), then the whole grid runs that
// branch's passes (kernel.h's functors with the lengths, lists and generations read on the
// device; ListSpan: every element is taken whatever the grid), with grid.sync after the decision
// and after each pass where the host's loop had a launch boundary. The passes, their lists and
// their order are the host loop's, so the bits are too. (A CUDA graph with a while node and a
// switch of the branches did the same, slower: bench/experiments/README.md, trydev.) Compiled
// with -fmad=false (the plugin's .cu).
#include <cooperative_groups.h>
#include <cuda_runtime.h>

#include <algorithm>

#include "core/backend/cuda/check.h"
#include "core/backend/cuda/loop.cuh"
#include "core/backend/memory.h"
#include "stages/delaunay/flip/untangle.h"  // DeviceTries; flip/tries.h

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
  explicit CooperativeTries(CudaExec exec) : args_(exec), state_(exec), landing_(exec), landing_counters_(exec) {}

  bool run(const TryArgs<R>& a, TryState& s, unsigned* counters, CUstream_st* st) override {
    if (!made_) {
      int device = 0, sms = 0, per_sm = 0;
      FF_CUDA_CHECK(cudaGetDevice(&device), "delaunay.flip: the device");
      FF_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device), "delaunay.flip: the device");
      FF_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, tries_kernel<R>, kBlock, 0),
                    "delaunay.flip: the sub-step tries' occupancy");
      grid_ = per_sm > 0 ? unsigned(sms) : 0u;
      made_ = true;
    }
    if (grid_ == 0) return false;
    TryArgs<R>* args = args_.get(1);
    TryState* state = state_.get(1);
    TryState* landing = landing_.get(1);
    unsigned* landing_counters = landing_counters_.get(2 * kSubstepCounters);
    set_tries<R><<<1, 1, 0, st>>>(a, s, args, state);
    FF_CUDA_CHECK_LAUNCH("delaunay.flip: passing the sub-step tries their lists");
    void* params[] = {&args, &state};
    FF_CUDA_CHECK(cudaLaunchCooperativeKernel(reinterpret_cast<const void*>(tries_kernel<R>), dim3(grid_),
                                              dim3(kBlock), params, 0, st),
                  "delaunay.flip: launching the sub-step tries");
    FF_CUDA_CHECK(cudaMemcpyAsync(landing, state, sizeof(TryState), cudaMemcpyDeviceToHost, st),
                  "delaunay.flip: reading the sub-step tries' state");
    FF_CUDA_CHECK(cudaMemcpyAsync(landing_counters, a.first_block, 2 * kSubstepCounters * sizeof(unsigned),
                                  cudaMemcpyDeviceToHost, st),
                  "delaunay.flip: reading the sub-step tries' counters");
    FF_CUDA_CHECK(cudaStreamSynchronize(st), "delaunay.flip: the sub-step tries");
    s = *landing;
    std::copy(landing_counters, landing_counters + 2 * kSubstepCounters, counters);
    return true;
  }

 private:
  static constexpr int kBlock = 256;
  bool made_ = false;
  unsigned grid_ = 0;
  Scratch<TryArgs<R>> args_;  // device copies of what run() is given
  Scratch<TryState> state_;
  HostScratch<TryState> landing_;  // pinned: what the tries end with
  HostScratch<unsigned> landing_counters_;
};

}  // namespace

template <class R>
std::unique_ptr<DeviceTries<R>> device_tries(const CudaExec& exec) {
  return std::make_unique<CooperativeTries<R>>(exec);
}
template std::unique_ptr<DeviceTries<float>> device_tries<float>(const CudaExec&);
template std::unique_ptr<DeviceTries<double>> device_tries<double>(const CudaExec&);

}  // namespace ff::delaunay
