// Session 45: what a launch costs the host on the GPU machine, next to host_waits' ~4 us for each
// of bench-abp's cudaLaunchKernelExC calls: an empty kernel launched with <<<>>>, with
// cudaLaunchKernelEx and the programmatic-serialization attribute (flipflow's launches), with a
// cluster of 2 blocks as well, and a captured graph of four such kernels by cudaGraphLaunch (what
// a step captured whole would cost the host). Medians of each call's own time, in us; the stream
// is synchronized every 64 calls so the launch queue never fills.
//   nvcc -O2 -arch=sm_90 launch_cost.cu -o launch_cost && ./launch_cost
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

__global__ void empty_kernel(int* p) {
  if (p && threadIdx.x == 1024) p[0] = 1;  // never: keeps the kernel from being empty of code
}

template <class F>
double median_us(cudaStream_t s, int calls, F launch) {
  std::vector<double> t;
  for (int i = 0; i < calls; ++i) {
    if (i % 64 == 0) cudaStreamSynchronize(s);
    const auto a = std::chrono::steady_clock::now();
    launch();
    const auto b = std::chrono::steady_clock::now();
    t.push_back(std::chrono::duration<double, std::micro>(b - a).count());
  }
  cudaStreamSynchronize(s);
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

int main() {
  cudaStream_t s;
  cudaStreamCreateWithFlags(&s, cudaStreamNonBlocking);
  int* p = nullptr;
  cudaMalloc(&p, 4);
  const int calls = 20000;
  empty_kernel<<<1, 32, 0, s>>>(p);
  cudaStreamSynchronize(s);

  const double plain = median_us(s, calls, [&] { empty_kernel<<<8, 256, 0, s>>>(p); });

  cudaLaunchAttribute pdl[1];
  pdl[0].id = cudaLaunchAttributeProgrammaticStreamSerialization;
  pdl[0].val.programmaticStreamSerializationAllowed = 1;
  cudaLaunchConfig_t cfg = {};
  cfg.gridDim = dim3(8);
  cfg.blockDim = dim3(256);
  cfg.stream = s;
  cfg.attrs = pdl;
  cfg.numAttrs = 1;
  const double ex_pdl = median_us(s, calls, [&] { cudaLaunchKernelEx(&cfg, empty_kernel, p); });

  cudaLaunchAttribute both[2];
  both[0] = pdl[0];
  both[1].id = cudaLaunchAttributeClusterDimension;
  both[1].val.clusterDim.x = 2;
  both[1].val.clusterDim.y = 1;
  both[1].val.clusterDim.z = 1;
  cudaLaunchConfig_t ccfg = cfg;
  ccfg.attrs = both;
  ccfg.numAttrs = 2;
  const double ex_cluster = median_us(s, calls, [&] { cudaLaunchKernelEx(&ccfg, empty_kernel, p); });

  cudaGraph_t g;
  cudaGraphExec_t ge;
  cudaStreamBeginCapture(s, cudaStreamCaptureModeThreadLocal);
  for (int k = 0; k < 4; ++k) cudaLaunchKernelEx(k == 3 ? &ccfg : &cfg, empty_kernel, p);
  cudaStreamEndCapture(s, &g);
  cudaGraphInstantiate(&ge, g, 0);
  const double graph4 = median_us(s, calls / 4, [&] { cudaGraphLaunch(ge, s); });

  const cudaError_t e = cudaGetLastError();
  std::printf("host time a call, median of %d (us): <<<>>> %.2f; cudaLaunchKernelEx + PDL %.2f; + cluster of 2 %.2f; "
              "cudaGraphLaunch of 4 kernels %.2f (%s)\n",
              calls, plain, ex_pdl, ex_cluster, graph4, cudaGetErrorString(e));
  return e == cudaSuccess ? 0 : 1;
}
