// Keeps the GPU's clock up while `pipeline bench` runs beside it: one block of 32 threads doing
// dependent FP32 work for SECONDS (argv[1], default 60) on one SM of 132, in kernels of ~10 ms.
// Session 35's question: does bench-abp's 200-steps-after-20 pass at small N run below the
// GPU's full clock (the GPU idles during each size's set-up)?
#include <chrono>
#include <cstdio>
#include <cstdlib>

__global__ void spin(float* out, int iters) {
  float x = threadIdx.x * 1e-3f;
  for (int i = 0; i < iters; ++i) x = x * 0.999999f + 1e-6f;
  if (x == -1.0f) out[threadIdx.x] = x;  // never: keeps the loop
}

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 60;
  float* out = nullptr;
  cudaMalloc(&out, 32 * sizeof(float));
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < seconds) {
    spin<<<1, 32>>>(out, 2000000);
    cudaDeviceSynchronize();
  }
  std::printf("spin: done after %.1f s\n", seconds);
  return 0;
}
