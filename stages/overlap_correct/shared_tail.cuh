// overlap_correct's tail in shared memory: where a small run alone on the GPU (a cluster team, n
// ≤ shared_tail_capacity) reaches its tail (an iteration that moved at most kClusterTailMoved
// particles), block 0 copies the positions, the neighbour lists and the claimed candidates into
// its shared memory and runs the remaining iterations there, with __syncthreads as the only
// barrier, then stores the positions back. Included by correct_kernel.cuh, whose kernel calls it.
//
// Why (bench/experiments/README.md, "The tail in shared memory", session 30): a tail iteration
// of block 0 is a chain of dependent loads and barriers, not work: 7-8 k cycles at 2^10-2^11 for
// 6-60 candidates (clock64, block 0), of which the L2 round trips (the candidate, its list, its
// neighbours' positions, the seeds and moves the apply reloads, the claims' global atomics) are
// ~3 k. From shared memory the same iterations take 4.7-5 k. The large iterations before the tail
// stay on the cluster's 16 SMs: in one block they took up to twice as long (a one-block kernel for
// the whole step tied the cluster at 2^10 and lost 24 % at 2^11).
//
// The same iterations as the global-memory tail (candidates claimed with word atomics on the
// marks, counted in shared memory), so the same bits: pushes are summed in fixed point
// (kernel.h) whoever gathers what. Image counts (walls) stay in global memory, which
// __syncthreads orders within the block as it does shared memory. The host sets
// Args::shared_tail only where one launch runs the whole step (max_iterations below
// kDeviceBatch): correct_kernel's batches carry their marks to the next launch in global memory,
// and this tail does not.
#pragma once
#include <cuda_runtime.h>

#include <cstdint>

#include "stages/overlap_correct/neighbor_lists.cuh"
#include "stages/overlap_correct/work_lists.cuh"

namespace ff::overlap {

namespace {

// The tail's shared-memory state of n particles, laid out from `base` (16-byte aligned).
template <class R>
struct TailState {
  double2* disp;         // n: where the iteration's moved particles go, in the order of seed
  R* pos;                // 2n: the current positions (the apply writes them)
  int* nb;               // kCached·n: each particle's listed neighbours (iteration 0's lists)
  int* seed;             // n: the touched particles, v if it moved, ~v if not
  int* cand;             // n: the iteration's candidates
  char2* crossed;        // n: the moved particles' box crossings
  std::uint8_t* degree;  // n: how many listed (kWalk: walk the fan)
  std::uint8_t* marks;   // n, rounded up to 16: claimed candidates of the next iteration

  static constexpr std::size_t bytes_per_particle() {
    return sizeof(double2) + 2 * sizeof(R) + kCached * sizeof(int) + 2 * sizeof(int) + sizeof(char2) + 2;
  }
  static constexpr std::size_t bytes(std::size_t n) { return n * bytes_per_particle() + 8 * 16; }  // + rounding

  __device__ TailState(unsigned char* base, int n) {
    auto take = [&](std::size_t b) {
      unsigned char* p = base;
      base += (b + 15) / 16 * 16;
      return p;
    };
    disp = reinterpret_cast<double2*>(take(sizeof(double2) * n));
    pos = reinterpret_cast<R*>(take(2 * sizeof(R) * n));
    nb = reinterpret_cast<int*>(take(sizeof(int) * kCached * n));
    seed = reinterpret_cast<int*>(take(sizeof(int) * n));
    cand = reinterpret_cast<int*>(take(sizeof(int) * n));
    crossed = reinterpret_cast<char2*>(take(sizeof(char2) * n));
    degree = take(n);
    marks = take(n);
  }
};

// Block 0's iterations j0, j0 + 1, ... in shared memory (s_dyn: TailState<R>::bytes(n)), from the
// count0 candidates the cluster's last check claimed in a.cand (their global marks are cleared
// here). keep_row(j, sums) is correct_kernel's. Returns the gathers run (the launch's end row).
// Every thread of block 0 calls it; not inlined, so the cluster's kernel keeps its registers.
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

  for (int v = int(threadIdx.x); v < n; v += Threads) {
    double x, y;
    load_xy(a.p.pos, v, x, y);
    store_xy(s.pos, v, x, y);
    const int4* from = reinterpret_cast<const int4*>(a.nb + std::size_t(kCached) * v);
    int4* to = reinterpret_cast<int4*>(s.nb + std::size_t(kCached) * v);
    to[0] = __ldcg(from);
    to[1] = __ldcg(from + 1);
    s.degree[v] = a.degree[v];
  }
  for (int w = int(threadIdx.x); w < (n + 15) / 16 * 4; w += Threads) reinterpret_cast<unsigned*>(s.marks)[w] = 0;
  for (int i = int(threadIdx.x); i < count0; i += Threads) {
    const int v = __ldcg(a.cand + i);
    s.cand[i] = v;
    a.marks[v] = 0;
  }
  if (threadIdx.x < 2) s_seeds[threadIdx.x] = s_claims[threadIdx.x] = 0;
  if (threadIdx.x < 2 * kReported) s_sum[threadIdx.x / kReported][threadIdx.x % kReported] = 0;
  __syncthreads();

  // Positions back to global memory where the tail ends; returns the gathers run.
  auto done = [&](int end) {
    for (int v = int(threadIdx.x); v < n; v += Threads) {
      double x, y;
      load_xy(s.pos, v, x, y);
      store_xy(a.p.pos, v, x, y);
    }
    return end;
  };
  for (int j = j0; j < kDeviceBatch; ++j) {
    const int p = j & 1, p_next = p ^ 1;
    const int count = j == j0 ? count0 : s_claims[p];
    if (threadIdx.x == 0) s_seeds[p_next] = s_claims[p_next] = 0;
    if (threadIdx.x < kReported) s_sum[p_next][threadIdx.x] = 0;

    u64 c[kReported] = {};
    auto take = [&](int v, const VertexPush& q) {
      count_gather<Mark>(c, ov, q, a.p.touched, v, false);
      if (q.touched) {
        const bool moves = q.dx != 0 || q.dy != 0;
        const int m = atomicAdd(&s_seeds[p], 1);
        s.seed[m] = moves ? v : ~v;
        if (moves) {  // where v goes, from where the gather read it: the apply only stores it
          const double d[2] = {q.dx, q.dy};
          const R x0[2] = {R(q.x), R(q.y)};  // exact: load_xy widened them from R
          R x[2];
          int cr[2];
          moved_from<2>(x0, a.p.box, d, x, cr);
          s.disp[m] = make_double2(double(x[0]), double(x[1]));
          s.crossed[m] = make_char2(char(cr[0]), char(cr[1]));
        }
      }
    };
    if (count > kGroupBelow<Threads>) {  // one thread per particle
      for (int i = int(threadIdx.x); i < count; i += Threads) {
        const int v = s.cand[i];
        atomicAnd(mark_word(s.marks, v), ~mark_bit(v));  // its claim: cleared for the next check
        int ids[kCached], d;
        const bool listed = neighbor_ids(ov, v, false, s.nb, s.degree, nullptr, ids, d);
        take(v, listed ? gather_ids(ov, v, ids, d) : ov.gather(v));
      }
    } else {  // one lane group per particle
      const int l = int(threadIdx.x) % kGroup;
      for (int base = 0; base < count; base += kGroups) {
        const int i = base + int(threadIdx.x) / kGroup;
        const bool has = i < count;
        const int v = has ? s.cand[i] : 0;
        if (has && l == 0) atomicAnd(mark_word(s.marks, v), ~mark_bit(v));
        const VertexPush q = group_gather(ov, v, has, l, s.nb, s.degree);
        if (has && l == 0) take(v, q);
      }
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
    if (!keeps_going(tot, a.k0 + j, a.max_iterations)) return done(j + 1);

    const int ns = s_seeds[p];
    for (int i = int(threadIdx.x); i < ns; i += Threads) {
      const int v = s.seed[i];
      if (v >= 0) {
        const double2 x = s.disp[i];
        const char2 cr = s.crossed[i];
        store_xy(s.pos, v, x.x, x.y);
        if (cr.x) a.p.image[2 * v] += cr.x;
        if (cr.y) a.p.image[2 * v + 1] += cr.y;
      }
    }
    __syncthreads();

    // The check at the new positions: claims the next iteration's candidates.
    auto claim = [&](int u) {
      if (claim_mark(s.marks, u)) s.cand[atomicAdd(&s_claims[p_next], 1)] = u;
    };
    if (ns > kGroupBelow<Threads>) {
      for (int i = int(threadIdx.x); i < ns; i += Threads) {
        const int v = s.seed[i];
        if (v < 0)
          claim(~v);
        else
          claim_checked(ov, v, s.nb, s.degree, s.marks, s.cand, &s_claims[p_next], claim);
      }
    } else {
      const int l = int(threadIdx.x) % kGroup;
      for (int base = 0; base < ns; base += kGroups) {
        const int i = base + int(threadIdx.x) / kGroup;
        const int v = i < ns ? s.seed[i] : ~0;
        if (i < ns && v < 0 && l == 0) claim(~v);
        if (group_check(ov, v, i < ns && v >= 0, l, s.nb, s.degree, claim) && l == 0) claim(v);
      }
    }
    __syncthreads();
  }
  return done(kDeviceBatch);  // (not reached: the host sets shared_tail only where keeps_going stops first)
}

}  // namespace

}  // namespace ff::overlap
