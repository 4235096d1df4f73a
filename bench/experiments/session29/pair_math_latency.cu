// Latency of one neighbour's pair math in the correction's gather (kernel.h: min_image, pair_term,
// fixed_push), as a dependent chain in one thread: each round's result feeds the next round's
// neighbour position through an integer mask that is zero at run time, so rounds cannot overlap.
// Session 28's clocks put this link of a tail gather at ~1 050 cycles. Variants:
//   plumbing   the feedback alone (subtract from the others)
//   current    kernel.h as it is: box.min_image (rint) on the device, two divisions r/len
//   near       the host's min_image branch on the device too (|d| <= L/4: d + 0), bit-identical
//   onediv     k = delta/len once, t = k*r (different bits from current)
//   near1div   near and onediv together
//   nodiv      no division at all (t = delta*r; not a candidate, shows what the division costs)
//   nosqrt     no sqrt either (len = r2; not a candidate)
// Build: nvcc -O3 -arch=sm_90 -std=c++17 -fmad=false -I. bench/experiments/session29/pair_math_latency.cu
#include <cstdint>
#include <cstdio>

#include "stages/overlap_correct/kernel.h"

using namespace ff;
using namespace ff::overlap;

struct In {
  double xv, yv, xu, yu, sv, factor, inv_unit;
  PeriodicBox<double> box;
  long long mask;
};

__device__ __forceinline__ double near_image(const PeriodicBox<double>& b, double d, int k) {
  if (fabs(d) <= 0.25 * b.L[k]) return d + 0.0;
  return b.min_image(d, k);
}

template <int V>
__device__ __forceinline__ std::int64_t round_once(const In& in, double xu, double yu) {
  const double dx = xu - in.xv, dy = yu - in.yv;
  if (V == 0) return __double_as_longlong(dx) ^ __double_as_longlong(dy);
  const double rx = (V == 2 || V == 4) ? near_image(in.box, dx, 0) : in.box.min_image(dx, 0);
  const double ry = (V == 2 || V == 4) ? near_image(in.box, dy, 1) : in.box.min_image(dy, 1);
  double tx = 0, ty = 0;
  if (V == 1 || V == 2) {
    pair_term(rx, ry, in.sv, in.sv, in.factor, 0, 1, tx, ty);
  } else {
    const double s = in.sv;
    const double r2 = rx * rx + ry * ry;
    if (r2 < s * s) {
      const double len = V == 6 ? r2 : sqrt(r2);
      const double delta = in.factor * (s - len);
      if (V == 3 || V == 4) {
        const double k = delta / len;
        tx = k * rx;
        ty = k * ry;
      } else {
        tx = delta * rx;
        ty = delta * ry;
      }
    }
  }
  return fixed_push(tx, in.inv_unit) + fixed_push(ty, in.inv_unit);
}

template <int V>
__global__ void chain(In in, int rounds, long long* cycles, std::int64_t* sink) {
  std::int64_t q = 0;
  const long long t0 = clock64();
  for (int r = 0; r < rounds; ++r) {
    const double xu = __longlong_as_double(__double_as_longlong(in.xu) + (q & in.mask));
    q += round_once<V>(in, xu, in.yu);
  }
  const long long t1 = clock64();
  if (threadIdx.x == 0) {
    *cycles = t1 - t0;
    *sink = q;
  }
}

template <int V>
double run(const In& in, int rounds, long long* d_cycles, std::int64_t* d_sink) {
  chain<V><<<1, 32>>>(in, rounds, d_cycles, d_sink);  // warm-up
  long long best = -1;
  for (int k = 0; k < 5; ++k) {
    chain<V><<<1, 32>>>(in, rounds, d_cycles, d_sink);
    long long c;
    cudaMemcpy(&c, d_cycles, sizeof c, cudaMemcpyDeviceToHost);
    if (best < 0 || c < best) best = c;
  }
  return double(best) / rounds;
}

int main() {
  In in{};
  in.xv = 10.25;
  in.yv = 7.5;
  in.xu = 10.25 + 0.93;  // an overlapping pair at diameter 1
  in.yu = 7.5 + 0.21;
  in.sv = 1.0;
  in.factor = 1.0;
  in.inv_unit = 1.0;
  const double L[3] = {64, 64, 0};
  in.box = PeriodicBox<double>::make(L);
  in.mask = 0;
  long long* d_cycles;
  std::int64_t* d_sink;
  cudaMalloc(&d_cycles, sizeof(long long));
  cudaMalloc(&d_sink, sizeof(std::int64_t));
  const int rounds = 4096;
  const double p = run<0>(in, rounds, d_cycles, d_sink);
  const char* names[] = {"plumbing", "current", "near", "onediv", "near1div", "nodiv", "nosqrt"};
  double c[7];
  c[0] = p;
  c[1] = run<1>(in, rounds, d_cycles, d_sink);
  c[2] = run<2>(in, rounds, d_cycles, d_sink);
  c[3] = run<3>(in, rounds, d_cycles, d_sink);
  c[4] = run<4>(in, rounds, d_cycles, d_sink);
  c[5] = run<5>(in, rounds, d_cycles, d_sink);
  c[6] = run<6>(in, rounds, d_cycles, d_sink);
  for (int v = 0; v < 7; ++v) printf("PMATH %-9s %7.1f cycles a round, %7.1f over plumbing\n", names[v], c[v], c[v] - p);
  return cudaGetLastError() == cudaSuccess ? 0 : 1;
}
