// delaunay.flip's sub-step tries on the device (untangle.h, DeviceTries): one graph launch runs
// the tries that untangle_step's loop would run one host round trip each. Its loop node
// repeats a body that starts with a one-thread kernel deciding, from the counters as read_try
// reads them, what the host's loop would do next (another repair round, an accepted try, a
// failed one, or stop at a try's end the host acts on: at the targets, a rollback, a throw), then
// runs that branch's passes: kernel.h's, launched over a fixed grid with the lengths, lists and
// generations read on the device (ListSpan: every element is taken whatever the grid). The
// passes, their lists and their order are the host loop's, so the bits are too. Branches: a
// switch node where the driver has one (CUDA 12.8), else every pass in the body returning at
// once when its branch is not the one decided. Compiled with -fmad=false (the plugin's .cu).
#include <cuda_runtime.h>

#include <cstdio>

#include "core/backend/cuda/check.h"
#include "core/backend/cuda/loop.cuh"
#include "stages/delaunay/flip/tries.h"

namespace ff::delaunay {

namespace {

template <class R>
__global__ void decide_kernel(const TryArgs<R>* a, TryState* sp, cudaGraphConditionalHandle loop,
                              cudaGraphConditionalHandle branch, bool branches) {
  TryState s = *sp;
  s.phase = decide_next(*a, s);
  *sp = s;
  if (s.phase == kPhaseStop) cudaGraphSetConditional(loop, 0);
  if (branches) cudaGraphSetConditional(branch, s.phase);
}

template <class R, int Pass>
__global__ void pass_kernel(const TryArgs<R>* a, const TryState* s) {
  run_pass<R>(Pass, *a, s, std::size_t(blockIdx.x) * blockDim.x + threadIdx.x, std::size_t(gridDim.x) * blockDim.x);
}

template <class R>
__global__ void set_tries(TryArgs<R> a, TryState s, TryArgs<R>* to_a, TryState* to_s) {
  *to_a = a;
  *to_s = s;
}

// The graph: a loop node whose body decides, then runs the branch decided.
template <class R>
class GraphTries final : public DeviceTries<R> {
 public:
  ~GraphTries() override { release(); }

  bool run(const TryArgs<R>& a, TryState& s, unsigned* counters, CUstream_st* st) override {
    if (!tried_) {
      tried_ = true;
      ready_ = make();
      if (!ready_)
        std::fprintf(stderr, "delaunay.flip: this device cannot loop the sub-step tries in a graph (%s); the host "
                             "drives them\n", why_.c_str());
    }
    if (!ready_) return false;
    set_tries<R><<<1, 1, 0, st>>>(a, s, args_, state_);
    FF_CUDA_CHECK_LAUNCH("delaunay.flip: passing the sub-step tries their lists");
    FF_CUDA_CHECK(cudaGraphLaunch(exec_, st), "delaunay.flip: launching the sub-step tries");
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
  bool check(cudaError_t e, const char* what) {
    if (e == cudaSuccess) return true;
    why_ = std::string(what) + ": " + cudaGetErrorString(e);
    (void)cudaGetLastError();
    return false;
  }

  // The passes of a branch, or (kPhaseStop + 1) every pass.
  template <int Pass = 0>
  void enqueue(unsigned phase, cudaStream_t cs) {
    if constexpr (Pass < kTryPasses) {
      if (phase > kPhaseStop || pass_runs(Pass, phase)) pass_kernel<R, Pass><<<grid_, kBlock, 0, cs>>>(args_, state_);
      enqueue<Pass + 1>(phase, cs);
    }
  }

  // Captures into `g` what `body` launches on the capture stream.
  template <class F>
  bool capture(cudaGraph_t g, const F& body) {
    if (!check(cudaStreamBeginCaptureToGraph(cs_, g, nullptr, nullptr, 0, cudaStreamCaptureModeThreadLocal),
               "capturing"))
      return false;
    body();
    const cudaError_t launched = cudaGetLastError();
    cudaGraph_t out = nullptr;
    const cudaError_t ended = cudaStreamEndCapture(cs_, &out);
    return check(launched, "capturing a pass") && check(ended, "ending a capture");
  }

  // The loop with a switch of the branches (`branches`), or with every pass in the body.
  bool build(bool branches) {
    if (!check(cudaGraphCreate(&graph_, 0), "a graph")) return false;
    cudaGraphConditionalHandle loop, branch{};
    if (!check(cudaGraphConditionalHandleCreate(&loop, graph_, 1, cudaGraphCondAssignDefault), "a loop handle"))
      return false;
    cudaGraphNodeParams wp{};
    wp.type = cudaGraphNodeTypeConditional;
    wp.conditional.handle = loop;
    wp.conditional.type = cudaGraphCondTypeWhile;
    wp.conditional.size = 1;
    cudaGraphNode_t node;
    if (!check(cudaGraphAddNode(&node, graph_, nullptr, nullptr, 0, &wp), "a loop node")) return false;
    cudaGraph_t body = wp.conditional.phGraph_out[0];
    if (branches && !check(cudaGraphConditionalHandleCreate(&branch, body, kPhaseStop, 0), "a switch handle"))
      return false;
    if (!capture(body, [&] {
          decide_kernel<R><<<1, 1, 0, cs_>>>(args_, state_, loop, branch, branches);
          if (!branches) enqueue(kPhaseStop + 1, cs_);
        }))
      return false;
    if (branches) {
      cudaGraphNode_t decided;
      std::size_t count = 1;
      if (!check(cudaGraphGetNodes(body, &decided, &count), "the deciding node")) return false;
      cudaGraphNodeParams sp{};
      sp.type = cudaGraphNodeTypeConditional;
      sp.conditional.handle = branch;
      sp.conditional.type = cudaGraphCondTypeSwitch;
      sp.conditional.size = 3;  // kPhaseRound, kPhaseAccept, kPhaseFail; kPhaseStop runs none
      cudaGraphNode_t sw;
      if (!check(cudaGraphAddNode(&sw, body, &decided, nullptr, 1, &sp), "a switch node")) return false;
      for (unsigned p = 0; p < 3; ++p)
        if (!capture(sp.conditional.phGraph_out[p], [&] { enqueue(p, cs_); })) return false;
    }
    return check(cudaGraphInstantiate(&exec_, graph_, 0), "instantiating");
  }

  bool make() {
    int device = 0, sms = 0;
    if (!check(cudaGetDevice(&device), "the device") ||
        !check(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device), "the device"))
      return false;
    grid_ = unsigned(2 * sms);
    if (!check(cudaMalloc(&args_, sizeof(TryArgs<R>)), "memory") || !check(cudaMalloc(&state_, sizeof(TryState)), "memory") ||
        !check(cudaMallocHost(&landing_, sizeof(TryState)), "memory") ||
        !check(cudaMallocHost(&landing_counters_, 2 * kSubstepCounters * sizeof(unsigned)), "memory") ||
        !check(cudaStreamCreateWithFlags(&cs_, cudaStreamNonBlocking), "a stream"))
      return false;
    if (build(true)) return true;
    const std::string first = why_;
    drop_graph();
    if (build(false)) {
      std::fprintf(stderr, "delaunay.flip: no switch node for the sub-step tries' branches here (%s): every pass "
                           "runs in each try, returning at once outside its branch\n", first.c_str());
      return true;
    }
    why_ = first + "; " + why_;
    return false;
  }

  void drop_graph() {
    if (exec_) cudaGraphExecDestroy(exec_);
    if (graph_) cudaGraphDestroy(graph_);
    exec_ = nullptr;
    graph_ = nullptr;
  }
  void release() {
    drop_graph();
    if (cs_) cudaStreamDestroy(cs_);
    if (args_) cudaFree(args_);
    if (state_) cudaFree(state_);
    if (landing_) cudaFreeHost(landing_);
    if (landing_counters_) cudaFreeHost(landing_counters_);
  }

  static constexpr int kBlock = 256;
  bool tried_ = false, ready_ = false;
  std::string why_;
  unsigned grid_ = 0;
  cudaStream_t cs_ = nullptr;
  cudaGraph_t graph_ = nullptr;
  cudaGraphExec_t exec_ = nullptr;
  TryArgs<R>* args_ = nullptr;  // device copies of what run() is given
  TryState* state_ = nullptr;
  TryState* landing_ = nullptr;  // pinned: what the tries end with
  unsigned* landing_counters_ = nullptr;
};

}  // namespace

template <class R>
std::unique_ptr<DeviceTries<R>> device_tries(const CudaExec&) {
  return std::make_unique<GraphTries<R>>();
}
template std::unique_ptr<DeviceTries<float>> device_tries<float>(const CudaExec&);
template std::unique_ptr<DeviceTries<double>> device_tries<double>(const CudaExec&);

}  // namespace ff::delaunay
