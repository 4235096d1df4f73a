// Latency of the double-precision operations on the correction's per-particle chain (session 50):
// one thread, a chain of dependent operations of each kind, clock64 around it; cycles per op.
// Build: nvcc -O3 -arch=sm_90 -fmad=false fp64_latency.cu -o fp64_latency
#include <cmath>
#include <cstdio>
#include <cstdint>

constexpr int kN = 4096;

__global__ void chains(double seed, long long* out, double* sink) {
  double x = seed;
  long long t0, t1;
  // DADD / DMUL
  t0 = clock64();
  for (int i = 0; i < kN; ++i) x = x * 1.0000001 + 1e-9;
  t1 = clock64(); out[0] = t1 - t0; sink[0] = x;
  // rint (FRND)
  x = seed; t0 = clock64();
  for (int i = 0; i < kN; ++i) x = rint(x) + 0.25;
  t1 = clock64(); out[1] = t1 - t0; sink[1] = x;
  // floor
  x = seed; t0 = clock64();
  for (int i = 0; i < kN; ++i) x = floor(x) + 0.75;
  t1 = clock64(); out[2] = t1 - t0; sink[2] = x;
  // sqrt
  x = seed; t0 = clock64();
  for (int i = 0; i < kN; ++i) x = sqrt(x) + 1.5;
  t1 = clock64(); out[3] = t1 - t0; sink[3] = x;
  // division
  x = seed; t0 = clock64();
  for (int i = 0; i < kN; ++i) x = 3.0 / x + 1.0;
  t1 = clock64(); out[4] = t1 - t0; sink[4] = x;
  // double -> int64 -> double (F2I.S64 + I2F.F64.S64)
  x = seed; t0 = clock64();
  for (int i = 0; i < kN; ++i) x = double((long long)(x)) + 1.25;
  t1 = clock64(); out[5] = t1 - t0; sink[5] = x;
  // __double2ll_rn -> double
  x = seed; t0 = clock64();
  for (int i = 0; i < kN; ++i) x = double(__double2ll_rn(x)) + 1.25;
  t1 = clock64(); out[6] = t1 - t0; sink[6] = x;
  // rint then int64 -> double
  x = seed; t0 = clock64();
  for (int i = 0; i < kN; ++i) x = double((long long)rint(x)) + 1.25;
  t1 = clock64(); out[7] = t1 - t0; sink[7] = x;
  // shared-memory load chain (int)
  __shared__ int s[1024];
  for (int i = 0; i < 1024; ++i) s[i] = (i * 7 + 1) & 1023;
  __syncthreads();
  int p = int(seed) & 1023;
  t0 = clock64();
  for (int i = 0; i < kN; ++i) p = s[p];
  t1 = clock64(); out[8] = t1 - t0; sink[8] = p;
}

int main() {
  long long* out; double* sink;
  cudaMallocManaged(&out, 16 * sizeof(long long));
  cudaMallocManaged(&sink, 16 * sizeof(double));
  for (int rep = 0; rep < 2; ++rep) {
    chains<<<1, 1>>>(3.0, out, sink);
    cudaDeviceSynchronize();
  }
  const char* names[] = {"dmul+dadd (2 ops)", "rint+dadd", "floor+dadd", "sqrt+dadd", "div+dadd", "f2i.s64+i2f (+dadd)",
                         "double2ll_rn+i2f (+dadd)", "rint+f2i+i2f (+dadd)", "lds chain"};
  for (int i = 0; i < 9; ++i) std::printf("%-28s %.1f cycles per step\n", names[i], double(out[i]) / kN);
  return 0;
}
