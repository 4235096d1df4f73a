// overlap_correct's tail in shared memory: where a small run alone on the GPU (the cluster of 16,
// without walls, n particles that fit: team_shape.cuh's shared_tail_bytes) reaches its tail (the
// iterations after one that moved at most kClusterTailMoved particles), block 0 copies the
// positions, the neighbour lists and the claimed candidates into its shared memory and runs the
// remaining iterations there, with __syncthreads as the only barrier; each apply stores the moves
// in both copies, so nothing is copied back. Included by correct_kernel.cuh, whose kernel calls it;
// the parts it shares with that kernel are correct_parts.cuh's.
//
// Why (bench/experiments/README.md, "The tail in shared memory", session 30): a tail iteration
// of block 0 is a chain of dependent loads and barriers, not work: 7-8 k cycles at 2^10-2^11 for
// 6-60 candidates (clock64, block 0), of which the L2 round trips (the candidate, its list, its
// neighbours' positions, the seeds and moves the apply reloads, the claims' global atomics) are
// ~3 k. From shared memory the same iterations take 4.7-5 k. The large iterations before the tail
// stay on the cluster's 16 SMs: in one block they took up to twice as long (a one-block kernel for
// the whole step tied the cluster at 2^10 and lost 24 % at 2^11). Reading the state where each
// block of the cluster holds its tile (distributed shared memory) instead of copying it was
// slower (−1 … −8 %).
//
// The same iterations as the global-memory tail (candidates claimed with word atomics on the
// marks, counted in shared memory), so the same bits: pushes are summed in fixed point
// (kernel.h) whoever gathers what. The host launches the kernel that runs this tail (correct_kernel's
// SharedTail) only where one launch runs the whole step (max_iterations below kDeviceBatch):
// correct_kernel's batches carry their marks to the next launch in global memory, and this tail
// does not.
#pragma once
#include <cuda_runtime.h>

#include <cstdint>

#include "stages/overlap_correct/correct_parts.cuh"
#include "stages/overlap_correct/neighbor_lists.cuh"
#include "stages/overlap_correct/work_lists.cuh"

namespace ff::overlap {

namespace {

// The tail's shared-memory state of n particles (n < 65 536), laid out from `base` (16-byte
// aligned); ids are 16 bits and marks one bit, so that 4 096 particles fit in double.
template <class R>
struct TailState {
  double2* disp;         // n: where the iteration's moved particles go, in the order of seed
  R* pos;                // 2n: the current positions (the apply writes them)
  std::uint16_t* nb;     // kCached·n: each particle's listed neighbours (iteration 0's lists)
  unsigned* seed;        // n: the touched particles (Seed)
  std::uint16_t* cand;   // n: the iteration's candidates
  std::uint8_t* degree;  // n: how many listed (kWalk: walk the fan)
  MarkBits marks;        // n bits: claimed candidates of the next iteration

  static constexpr std::size_t bytes_per_particle() {
    return sizeof(double2) + 2 * sizeof(R) + kCached * sizeof(std::uint16_t) + sizeof(unsigned) + sizeof(std::uint16_t) + 1;
  }
  __host__ __device__ static constexpr std::size_t mark_words(std::size_t n) { return (n + 31) / 32; }
  static constexpr std::size_t bytes(std::size_t n) {
    return n * bytes_per_particle() + 4 * mark_words(n) + 7 * 16;  // + rounding
  }

  __device__ TailState(unsigned char* base, int n) {
    auto take = [&](std::size_t b) {
      unsigned char* p = base;
      base += (b + 15) / 16 * 16;
      return p;
    };
    disp = reinterpret_cast<double2*>(take(sizeof(double2) * n));
    pos = reinterpret_cast<R*>(take(2 * sizeof(R) * n));
    nb = reinterpret_cast<std::uint16_t*>(take(sizeof(std::uint16_t) * kCached * n));
    seed = reinterpret_cast<unsigned*>(take(sizeof(unsigned) * n));
    cand = reinterpret_cast<std::uint16_t*>(take(sizeof(std::uint16_t) * n));
    degree = take(n);
    marks.words = reinterpret_cast<unsigned*>(take(4 * mark_words(n)));
  }
};

// A seed entry: particle v (16 bits), whether it moved, and its box crossings (-1, 0, 1 each axis).
struct Seed {
  __device__ static unsigned make(int v, bool moved, int cx, int cy) {
    return unsigned(v) | unsigned(moved) << 16 | unsigned(cx + 1) << 17 | unsigned(cy + 1) << 19;
  }
  __device__ static int particle(unsigned e) { return int(e & 0xffffu); }
  __device__ static bool moved(unsigned e) { return (e >> 16) & 1u; }
  __device__ static int cross_x(unsigned e) { return int((e >> 17) & 3u) - 1; }
  __device__ static int cross_y(unsigned e) { return int((e >> 19) & 3u) - 1; }
};

// Block 0's iterations j0, j0 + 1, ... in shared memory (s_dyn: TailState<R>::bytes(n)), from the
// count0 candidates the cluster's last check claimed in a.cand (their global marks are cleared
// here). keep_row(j, sums) is correct_kernel's. Returns the gathers run (the launch's end row).
// Every thread of block 0 calls it. Inlined: called through the ABI (__noinline__) it and its
// kernel spilled 72-300 bytes (ptxas, sm_90); inlined into its own kernel instantiation
// (SharedTail) neither spills, and the other kernels keep their code.
template <class R, int Threads, bool Walls, bool Mark, class Args, class KeepRow>
__device__ __forceinline__ int shared_tail(const Args& a, int j0, int count0, unsigned char* s_dyn, KeepRow&& keep_row) {
  constexpr int kReported = Sums<Mark>::kReported;
  constexpr int kGroups = Threads / kGroup;
  __shared__ int s_seeds[2], s_claims[2];  // by iteration parity, as the global tail's
  __shared__ u64 s_sum[2][kReported];

  const int n = int(a.p.n);
  const TailState<R> s(s_dyn, n);
  Overlaps<R, Walls> ov = a.ov;
  ov.pos = s.pos;
  const int lane = threadIdx.x & 31;
  const int l = int(threadIdx.x) % kGroup;  // the thread's lane in its group

  for (int v = int(threadIdx.x); v < n; v += Threads) {
    double x, y;
    load_xy(a.p.pos, v, x, y);
    store_xy(s.pos, v, x, y);
    const int4* from = reinterpret_cast<const int4*>(a.nb + std::size_t(kCached) * v);
    const int4 lo = __ldcg(from), hi = __ldcg(from + 1);
    auto two = [](int first, int second) { return (unsigned(first) & 0xffffu) | unsigned(second) << 16; };
    *reinterpret_cast<uint4*>(s.nb + std::size_t(kCached) * v) =
        make_uint4(two(lo.x, lo.y), two(lo.z, lo.w), two(hi.x, hi.y), two(hi.z, hi.w));
    s.degree[v] = a.degree[v];
  }
  for (int w = int(threadIdx.x); w < int(TailState<R>::mark_words(n)); w += Threads) s.marks.words[w] = 0;
  for (int i = int(threadIdx.x); i < count0; i += Threads) {
    const int v = __ldcg(a.cand + i);
    s.cand[i] = std::uint16_t(v);
    a.marks[v] = 0;
  }
  if (threadIdx.x < 2) s_seeds[threadIdx.x] = s_claims[threadIdx.x] = 0;
  if (threadIdx.x < 2 * kReported) s_sum[threadIdx.x / kReported][threadIdx.x % kReported] = 0;
  __syncthreads();

  for (int j = j0; j < kDeviceBatch; ++j) {
    const int p = j & 1, p_next = p ^ 1;
    const int count = j == j0 ? count0 : s_claims[p];
    if (threadIdx.x == 0) s_seeds[p_next] = s_claims[p_next] = 0;
    if (threadIdx.x < kReported) s_sum[p_next][threadIdx.x] = 0;

    u64 c[kReported] = {};
    // What a gather found (take_gather): the touched particle, its move and crossings packed in
    // seed, where a moving one goes in disp.
    auto take = [&](int v, const VertexPush& q) {
      take_gather<Mark>(c, ov, a.p.box, q, a.p.touched, v, false, &s_seeds[p],
                        [&](int m, bool moves, const R* x, const int* cr) {
                          if (moves) s.disp[m] = make_double2(double(x[0]), double(x[1]));
                          s.seed[m] = Seed::make(v, moves, cr[0], cr[1]);
                        });
    };
    // Every gather by a lane group (one neighbour a lane), whatever the count: from shared memory
    // a group's parallel pair math beats one thread a particle at every count (bench/experiments/
    // README.md, "The tail in shared memory": −3 … −15 % with threads below 128 candidates, +0.6 …
    // +1.2 % with groups above).
    for (int base = 0; base < count; base += kGroups) {
      const int i = base + int(threadIdx.x) / kGroup;
      const bool has = i < count;
      const int v = has ? s.cand[i] : 0;
      if (has && l == 0) atomicAnd(mark_word(s.marks, v), ~mark_bit(s.marks, v));
      const VertexPush q = group_gather(ov, v, has, l, s.nb, s.degree);
      if (has && l == 0) take(v, q);
    }
#pragma unroll
    for (int q = 0; q < kReported; ++q) {
      const u64 sum = warp_sum(c[q]);
      if (lane == 0 && sum) atomicAdd(&s_sum[p][q], sum);
    }
    __syncthreads();
    keep_row(j, s_sum[p]);
    std::uint64_t tot[kReported];
#pragma unroll
    for (int q = 0; q < kReported; ++q) tot[q] = s_sum[p][q];
    if (!keeps_going(tot, a.k0 + j, a.max_iterations)) return j + 1;

    const int ns = s_seeds[p];
    for (int i = int(threadIdx.x); i < ns; i += Threads) {
      const unsigned e = s.seed[i];
      if (Seed::moved(e)) {
        const int v = Seed::particle(e);
        const double2 x = s.disp[i];
        store_xy(s.pos, v, x.x, x.y);
        store_xy(a.p.pos, v, x.x, x.y);  // (written through: nothing to copy back at the end)
        if (const int cx = Seed::cross_x(e)) a.p.image[2 * v] += cx;
        if (const int cy = Seed::cross_y(e)) a.p.image[2 * v + 1] += cy;
      }
    }
    __syncthreads();

    // The check at the new positions: claims the next iteration's candidates.
    auto claim = [&](int u) {
      if (claim_mark(s.marks, u)) s.cand[atomicAdd(&s_claims[p_next], 1)] = std::uint16_t(u);
    };
    for (int base = 0; base < ns; base += kGroups) {  // (lane groups, as the gathers)
      const int i = base + int(threadIdx.x) / kGroup;
      const unsigned e = i < ns ? s.seed[i] : 0u;
      const int v = Seed::particle(e);
      const bool moved = i < ns && Seed::moved(e);
      if (i < ns && !moved && l == 0) claim(v);
      if (group_check(ov, v, moved, l, s.nb, s.degree, claim) && l == 0) claim(v);
    }
    __syncthreads();
  }
  return kDeviceBatch;  // (not reached: the host sets shared_tail only where keeps_going stops first)
}

}  // namespace

}  // namespace ff::overlap
