// overlap_correct's wide kernels (the first iterations of a full grid's step, before the
// persistent kernel of correct_kernel.cuh takes over at Args::j0), included by cuda.cu after
// correct_kernel.cuh: one translation unit, compiled with -fmad=false as cuda.cu is
// (CMakeLists.txt). DeviceLoops::prepare decides when they run (a full grid).
#pragma once
#include "stages/overlap_correct/correct_kernel.cuh"

namespace ff::overlap {

namespace {

// The wide kernels: the first iterations of a grid's step (kWideIterations of them; iteration 0
// gathers every particle, most of the stage's work on a full grid) as three launches each
// (gather, apply, check), a thread per particle, with few registers and many warps on an SM. The
// cooperative kernel's registers hold it to one block of 512 an SM for its later iterations; one
// particle's gather is a chain of dependent loads (ncu: bench/README.md, session 18), so what
// hides its latency is how many chains are in flight. Kernel boundaries stand in for the grid barriers
// and order the memory the same way. Each is launched programmatically (pdl.cuh) and waits for the
// kernel before it before it reads anything, so the next one is scheduled while it runs.
//
// They write what the cooperative kernel's iterations write: the lists (nb, degree, fan) in
// iteration 0, the touched field, plain marks for the next iteration, and the iteration's sums in
// the slots (the same shards). What a gather found stays by particle (state, disp, crossed), not
// in a block's list: the apply and the check take each particle where it is. Every launch sums
// the slots of the iterations before it and does nothing after one that did not go on
// (keeps_going), so the host launches them all without waiting, and the cooperative kernel
// starts at j0 = kWideIterations (it reports the wide iterations' sums). The same particles are
// gathered with the same functions (kernel.h's fixed-point sums): the same bits, the same
// iteration counts (test_overlap_correct_cpu_cuda).
constexpr int kWideThreads = 256;
constexpr int kWideMinBlocks = 4;  // 64 registers a thread
constexpr int kWideIterations = 1;

// What particle v's gather found, by particle (Args::state).
enum WideState : std::uint8_t { kWideUntouched = 0, kWideStill = 1, kWideMoved = 2 };

// Whether iterations 0 .. j of the launch all went on (keeps_going on their summed slots).
// Every thread of the block must call it; the same answer in every block.
template <bool Mark, class R, bool Walls>
__device__ bool went_on(const Args<R, Walls>& a, int j, u64* s_tot) {
  constexpr int kReported = Sums<Mark>::kReported, kAll = Sums<Mark>::kAll;
  for (int i = 0; i <= j; ++i) {
    __syncthreads();  // (s_tot is written again)
    if (threadIdx.x < kAll) s_tot[threadIdx.x] = slot_total<kAll>(a.slots, i, int(threadIdx.x));
    __syncthreads();
    std::uint64_t tot[kReported];
#pragma unroll
    for (int q = 0; q < kReported; ++q) tot[q] = s_tot[q];
    if (!keeps_going(tot, a.k0 + i, a.max_iterations)) return false;
  }
  return true;
}

// Gather j of the launch: every particle (k = 0: from its kept fan or a walk, filling the lists)
// or the marked ones (clearing their marks), one thread each; sums into slot j.
template <class R, int Threads, int MinBlocks, bool Walls, bool Mark>
__global__ void __launch_bounds__(Threads, MinBlocks) wide_gather(Args<R, Walls> a, int j) {
  constexpr int kMovedSum = Sums<Mark>::kMoved, kAll = Sums<Mark>::kAll;
  constexpr int kWarps = Threads / 32;
  __shared__ u64 s_red[kAll][kWarps];
  __shared__ u64 s_tot[kAll];
  wait_for_previous_kernel();
  allow_next_kernel();
  if (j > 0 ? !went_on<Mark>(a, j - 1, s_tot) : gate_closed(a.p)) return;  // (then its slot stays zero: nothing went on)
  const Overlaps<R, Walls>& ov = a.ov;
  const long long k = a.k0 + j;
  const bool first = k == 0;
  const int v = int(blockIdx.x) * Threads + int(threadIdx.x);
  u64 c[kAll] = {};
  if (v < int(a.p.n)) {
    bool candidate = first;
    if (!first && a.marks[v]) {
      candidate = true;
      a.marks[v] = 0;
    }
    std::uint8_t st = kWideUntouched;
    if (candidate) {
      int ids[kCached], d;
      const VertexPush q =
          neighbor_ids(ov, v, first, a.nb, a.degree, a.fan, ids, d) ? gather_ids(ov, v, ids, d) : ov.gather(v);
      count_gather<Mark>(c, ov, q, a.p.touched, v, first);
      if (q.touched) {
        st = kWideStill;
        if (q.dx != 0 || q.dy != 0) {  // where v goes (as the cooperative kernel's take)
          const double dd[2] = {q.dx, q.dy};
          R x[2];
          int cr[2];
          moved_d<2>(a.p.pos, a.p.box, std::size_t(v), dd, x, cr);
          a.disp[v] = make_double2(double(x[0]), double(x[1]));
          a.crossed[v] = make_char2(char(cr[0]), char(cr[1]));
          st = kWideMoved;
          c[kMovedSum] = 1;
        }
      }
    }
    a.state[v] = st;
  }
  const u64 s = block_sum(c, s_red);
  if (threadIdx.x < kAll) {
    const int shard = int(blockIdx.x % kShards) * kShardStride;
    if (s) atomicAdd(a.slots + (std::size_t(j) * kAll + threadIdx.x) * kShards * kShardStride + shard, s);
  }
}

// Apply j: the particles gather j moved go where it computed (if it went on).
template <class R, int Threads, bool Walls, bool Mark>
__global__ void __launch_bounds__(Threads) wide_apply(Args<R, Walls> a, int j) {
  __shared__ u64 s_tot[Sums<Mark>::kAll];
  wait_for_previous_kernel();
  allow_next_kernel();
  if (!went_on<Mark>(a, j, s_tot)) return;
  const int v = int(blockIdx.x) * Threads + int(threadIdx.x);
  if (v >= int(a.p.n) || a.state[v] != kWideMoved) return;
  const double2 x = a.disp[v];
  const char2 c = a.crossed[v];
  store_xy(a.p.pos, v, x.x, x.y);
  if (c.x) a.p.image[2 * v] += c.x;
  if (c.y) a.p.image[2 * v + 1] += c.y;
}

// Check j (positions are the new ones now): plain marks for iteration j + 1, as the cooperative
// kernel's check (a touched particle that did not move; a moved one's overlapping neighbours and
// itself when any, or a wall).
template <class R, int Threads, int MinBlocks, bool Walls, bool Mark>
__global__ void __launch_bounds__(Threads, MinBlocks) wide_check(Args<R, Walls> a, int j) {
  __shared__ u64 s_tot[Sums<Mark>::kAll];
  wait_for_previous_kernel();
  allow_next_kernel();
  if (!went_on<Mark>(a, j, s_tot)) return;
  const int v = int(blockIdx.x) * Threads + int(threadIdx.x);
  if (v >= int(a.p.n)) return;
  const std::uint8_t st = a.state[v];
  std::uint8_t* marks = a.marks;
  if (st == kWideStill)
    marks[v] = 1;
  else if (st == kWideMoved && thread_check(a.ov, v, a.nb, a.degree, [&](int u) { marks[u] = 1; }))
    marks[v] = 1;
}

}  // namespace

}  // namespace ff::overlap
