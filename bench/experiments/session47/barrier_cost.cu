// Session 47: what the one-block dense correction's per-iteration floor is made of (call 3:
// ~4 300 cycles an iteration when almost nothing is left): a block barrier's cost by block size,
// with and without the votes (__syncthreads_or / _count), and the latency of one particle's
// move (kernel.h's finish and fixed_len, box.h's wrap: int64 → double, products, a square root,
// a rounding to int64, a floor) as one thread's dependent chain, alone and followed by a barrier.
// Cycles a round from block thread 0's clock64, 4 096 rounds after 64 of warm-up.
//   nvcc -O3 -arch=sm_90 -fmad=false barrier_cost.cu -o barrier_cost && ./barrier_cost
#include <cmath>
#include <cstdio>

constexpr int kRounds = 4096, kWarm = 64;

// mode 0: a shared load and store then __syncthreads; 1: __syncthreads_or; 2: __syncthreads_count;
// 3: thread 0 alone runs the move chain (no barrier); 4: thread 0 runs it, then every thread
// meets at __syncthreads; 5: every thread runs it, then __syncthreads; 6: as 4, thread 0 also
// storing its result to global memory before the barrier (the dense block's store_xy); 7: as 6,
// the store after the barrier.
__global__ void rounds(int mode, long long* out, double* sink, long long q0) {
  __shared__ int s[1024];
  s[threadIdx.x] = threadIdx.x;
  __syncthreads();
  long long q = q0 + threadIdx.x;
  double acc = 0;
  int x = threadIdx.x;
  long long t0 = 0;
  const double push_length = 0x1p-50, inv_unit = 1.0, cap = 0.25, inv_L = 1.0 / 37.0, L = 37.0;
  for (int r = 0; r < kRounds + kWarm; ++r) {
    if (r == kWarm) t0 = clock64();
    const bool chain = mode == 5 || ((mode == 3 || mode == 4 || mode >= 6) && threadIdx.x == 0);
    if (chain) {  // one particle's finish and move, each step depending on the last
      const double dx = double(q) * push_length, dy = double(q + 7) * push_length;
      const double len2 = dx * dx + dy * dy;
      const double len = len2 > cap * cap ? cap : std::sqrt(len2);
      const long long fixed = std::llround(len * inv_unit * 4294967296.0);
      double px = 3.0 + acc + dx;
      const double shift = std::floor(px * inv_L);
      px -= shift * L;
      acc = px * 1e-30;
      q += fixed + (long long)shift;
      if (mode == 6) sink[1 + (r & 63)] = px;
    }
    if (mode == 3) continue;
    x = s[(x * 7 + r) & 1023];
    s[threadIdx.x] = x + 1;
    if (mode == 1) {
      if (__syncthreads_or(x == -1)) x = 0;
    } else if (mode == 2) {
      x += __syncthreads_count(x == -1);
    } else {
      __syncthreads();
    }
    if (mode == 7 && threadIdx.x == 0) sink[1 + (r & 63)] = acc;
  }
  const long long t1 = clock64();
  if (threadIdx.x == 0) {
    out[0] = t1 - t0;
    sink[0] = acc + x + double(q);
  }
}

int main() {
  long long* out;
  double* sink;
  cudaMalloc(&out, sizeof(long long));
  cudaMalloc(&sink, 65 * sizeof(double));
  const char* names[] = {"load+store, __syncthreads", "load+store, __syncthreads_or", "load+store, __syncthreads_count",
                         "thread 0's move chain, no barrier", "thread 0's move chain, then __syncthreads",
                         "every thread's move chain, then __syncthreads", "thread 0's chain, a global store, __syncthreads",
                         "thread 0's chain, __syncthreads, a global store"};
  for (int mode = 0; mode < 8; ++mode)
    for (int threads : {128, 256, 512, 1024}) {
      long long best = -1;
      for (int rep = 0; rep < 5; ++rep) {
        rounds<<<1, threads>>>(mode, out, sink, 12345);
        long long c = 0;
        cudaMemcpy(&c, out, sizeof c, cudaMemcpyDeviceToHost);
        if (best < 0 || c < best) best = c;
      }
      std::printf("%-48s %5d threads: %7.1f cycles a round\n", names[mode], threads, double(best) / kRounds);
    }
  const cudaError_t e = cudaDeviceSynchronize();
  if (e != cudaSuccess) std::printf("error: %s\n", cudaGetErrorString(e));
  return 0;
}
