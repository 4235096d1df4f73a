// overlap_correct's one-block kernel: for a small system (n ≤ block_capacity) alone on the GPU,
// one block of kBlockThreads runs every iteration of the step with the particles' positions,
// neighbour lists, candidates and moves in its shared memory, and __syncthreads as the only
// barrier. Included by cuda.cu after correct_kernel.cuh, whose helpers it uses.
//
// Why: at 2^10-2^11 a correction iteration is a chain of dependent loads and barriers, not
// work (bench/experiments/README.md, "The tail's independent groups" and "The pair math of a
// gather"): a tail iteration of block 0 took ~8.5 k cycles for 14-23 candidates, most of them
// L2 round trips (the candidate, its list, its neighbours' positions, the claims) and a team
// iteration twice that for its cluster barriers. Here each of those is a shared-memory load.
//
// The same iterations as correct_kernel's (every iteration is its tail's shape: candidates
// claimed with word atomics on the marks, counted in shared memory): iteration 0 gathers every
// particle, walking or checking its fan as neighbor_ids does (the lists in global memory are
// kept across steps for kept_fan, and copied to shared memory as they are made); later
// iterations gather the claimed candidates. Pushes are summed in fixed point (kernel.h), so the
// bits are the CPU's and the grid's whoever gathers what. Positions are copied in at the start
// and out at each exit; image counts (walls) stay in global memory, which __syncthreads orders
// within the block as it does shared memory.
//
// The host launches it only where one launch runs the whole step (max_iterations below
// kDeviceBatch: correct_kernel's batches carry their marks from one launch to the next in
// global memory, these do not).
#pragma once
#include "stages/overlap_correct/correct_kernel.cuh"

namespace ff::overlap {

namespace {

constexpr int kBlockThreads = 512;  // 128 registers a thread, as correct_kernel's blocks
constexpr std::size_t kBlockMaxN = 4096;  // (block_capacity caps it: ~2 900 in double on sm_90)

// The shared-memory state of n particles, laid out from `base` (16-byte aligned).
template <class R>
struct BlockState {
  R* pos;              // 2n: positions (the current ones; the apply writes them)
  int* nb;             // kCached·n: each particle's listed neighbours (neighbor_ids)
  double2* disp;       // n: where the iteration's moved particles go, in the order of seed
  int* seed;           // n: the touched particles, v if it moved, ~v if not
  int* cand;           // n: the iteration's candidates
  char2* crossed;      // n: the moved particles' box crossings
  std::uint8_t* degree;  // n: how many listed (kWalk: walk the fan)
  std::uint8_t* marks;   // n rounded up to 16: claimed candidates of the next iteration

  static constexpr std::size_t bytes_per_particle() {
    return 2 * sizeof(R) + kCached * sizeof(int) + sizeof(double2) + 2 * sizeof(int) + sizeof(char2) + 2;
  }
  static constexpr std::size_t bytes(std::size_t n) { return n * bytes_per_particle() + 8 * 16; }  // + rounding

  __device__ BlockState(unsigned char* base, int n) {
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

// One block of Threads runs the step's iterations; dynamic shared memory BlockState<R>::bytes(n).
template <class R, int Threads, bool Walls, bool Mark>
__global__ void __launch_bounds__(Threads, 1) block_kernel(Args<R, Walls> a) {
  constexpr int kReported = Sums<Mark>::kReported;
  constexpr int kGroups = Threads / kGroup;
  extern __shared__ __align__(16) unsigned char s_dyn[];
  __shared__ int s_seeds[2], s_moved[2], s_claims[2];  // by iteration parity, as the tail's
  __shared__ u64 s_sum[2][kReported];
  __shared__ u64 s_rows[kRowsHeld][kReported];

  const int n = int(a.p.n);
  const BlockState<R> s(s_dyn, n);
  Overlaps<R, Walls> ov = a.ov;  // positions from shared memory
  ov.pos = s.pos;
  const int lane = threadIdx.x & 31;

  auto store_rows = [&](int end) { store_held_rows<kReported>(a.result, s_rows, end); };
  auto keep_row = [&](int j, const u64* sums) {
    if (threadIdx.x >= kReported) return;
    s_rows[j % kRowsHeld][threadIdx.x] = sums[threadIdx.x];
    if ((j + 1) % kRowsHeld == 0) store_rows(j + 1);
  };
  // The launch's end: positions back to global memory, then the rows and the gather count.
  auto finish = [&](int end) {
    R* pos = a.p.pos;
    for (int v = int(threadIdx.x); v < n; v += Threads) {
      double x, y;
      load_xy(s.pos, v, x, y);
      store_xy(pos, v, x, y);
    }
    if (threadIdx.x >= kReported) return;
    if (end % kRowsHeld != 0) store_rows(end);
    if (threadIdx.x == 0) a.result[std::size_t(kDeviceBatch) * kCounters] = u64(end);
  };

  wait_for_previous_kernel();  // launched programmatically, as correct_kernel
  // The next cluster or grid launch's counters (correct_kernel's rule: each launch zeroes them).
  for (long long w = threadIdx.x; w < a.next_zero; w += Threads) a.next_slots[w] = 0;
  if (threadIdx.x == 0) a.next_slots[kSlotWords] = 0;
  if (gate_closed(a.p)) {
    if (threadIdx.x < kCounters) a.result[threadIdx.x] = 0;
    if (threadIdx.x == 0) a.result[std::size_t(kDeviceBatch) * kCounters] = 1;
    return;
  }
  for (int v = int(threadIdx.x); v < n; v += Threads) {
    double x, y;
    load_xy(a.p.pos, v, x, y);
    store_xy(s.pos, v, x, y);
  }
  for (int w = int(threadIdx.x); w < (n + 15) / 16 * 4; w += Threads) reinterpret_cast<unsigned*>(s.marks)[w] = 0;
  if (threadIdx.x < 2) s_seeds[threadIdx.x] = s_moved[threadIdx.x] = s_claims[threadIdx.x] = 0;
  if (threadIdx.x < 2 * kReported) s_sum[threadIdx.x / kReported][threadIdx.x % kReported] = 0;
  __syncthreads();

  for (int j = 0; j < kDeviceBatch; ++j) {
    const long long k = a.k0 + j;
    const int p = j & 1, p_next = p ^ 1;
    const bool first = j == 0;
    const int count = first ? n : s_claims[p];
    if (threadIdx.x == 0) s_seeds[p_next] = s_moved[p_next] = s_claims[p_next] = 0;
    if (threadIdx.x < kReported) s_sum[p_next][threadIdx.x] = 0;

    u64 c[kReported] = {};
    auto take = [&](int v, const VertexPush& q) {
      count_gather<Mark>(c, ov, q, a.p.touched, v, first);
      if (q.touched) {
        const bool moves = q.dx != 0 || q.dy != 0;
        const int m = atomicAdd(&s_seeds[p], 1);
        s.seed[m] = moves ? v : ~v;
        if (moves) {
          const double d[2] = {q.dx, q.dy};
          const R x0[2] = {R(q.x), R(q.y)};
          R x[2];
          int cr[2];
          moved_from<2>(x0, a.p.box, d, x, cr);
          s.disp[m] = make_double2(double(x[0]), double(x[1]));
          s.crossed[m] = make_char2(char(cr[0]), char(cr[1]));
        }
      }
    };
    if (first || count > kGroupBelow<Threads>) {  // one thread per particle
      for (int i = int(threadIdx.x); i < count; i += Threads) {
        const int v = first ? i : s.cand[i];
        int ids[kCached], d;
        bool listed;
        if (first) {
          listed = neighbor_ids(ov, v, true, a.nb, a.degree, a.fan, ids, d);
          s.degree[v] = listed ? std::uint8_t(d) : kWalk;
          if (listed) {
            int4* q = reinterpret_cast<int4*>(s.nb + std::size_t(kCached) * v);
            q[0] = make_int4(ids[0], ids[1], ids[2], ids[3]);
            q[1] = make_int4(ids[4], ids[5], ids[6], ids[7]);
          }
        } else {
          atomicAnd(mark_word(s.marks, v), ~mark_bit(v));  // its claim: cleared for the next check
          listed = neighbor_ids(ov, v, false, s.nb, s.degree, nullptr, ids, d);
        }
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
    const u64* sums = s_sum[p];
    keep_row(j, sums);
    std::uint64_t tot[kReported];
#pragma unroll
    for (int q = 0; q < kReported; ++q) tot[q] = sums[q];
    if (!keeps_going(tot, k, a.max_iterations)) {
      finish(j + 1);
      return;
    }

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
  finish(kDeviceBatch);  // (never reached: the host launches this kernel only where keeps_going stops it first)
}

// The most particles the one-block kernel holds on this device (its shared memory per block,
// opted in, less the kernel's static arrays); 0 where it cannot run.
template <class R, bool Walls, bool Mark>
std::size_t block_capacity() {
  int dev = 0, optin = 0;
  FF_CUDA_CHECK(cudaGetDevice(&dev), "overlap_correct: current device");
  FF_CUDA_CHECK(cudaDeviceGetAttribute(&optin, cudaDevAttrMaxSharedMemoryPerBlockOptin, dev),
                "overlap_correct: shared memory per block");
  cudaFuncAttributes f = {};
  FF_CUDA_CHECK(cudaFuncGetAttributes(&f, block_kernel<R, kBlockThreads, Walls, Mark>), "overlap_correct: block kernel");
  const std::size_t have = std::size_t(optin) > f.sharedSizeBytes ? std::size_t(optin) - f.sharedSizeBytes : 0;
  const std::size_t fixed = BlockState<R>::bytes(0);
  return have > fixed ? (have - fixed) / BlockState<R>::bytes_per_particle() : 0;
}

// The one-block kernel's launch for n particles, after the previous kernel programmatically.
template <class R, bool Walls, bool Mark>
void launch_block(void** args, std::size_t n, CUstream_st* s) {
  auto* f = block_kernel<R, kBlockThreads, Walls, Mark>;
  const std::size_t bytes = BlockState<R>::bytes(n);
  FF_CUDA_CHECK(cudaFuncSetAttribute(f, cudaFuncAttributeMaxDynamicSharedMemorySize, int(bytes)),
                "overlap_correct: the block kernel's shared memory");
  cudaLaunchAttribute attr[1];
  cudaLaunchConfig_t cfg = {};
  cfg.gridDim = dim3(1);
  cfg.blockDim = dim3(kBlockThreads);
  cfg.dynamicSmemBytes = bytes;
  cfg.stream = s;
  cfg.attrs = attr;
  cfg.numAttrs = programmatic_attr(attr, 0);
  FF_CUDA_CHECK(cudaLaunchKernelExC(&cfg, reinterpret_cast<void*>(f), args), "launching overlap_correct (one block)");
}

}  // namespace

}  // namespace ff::overlap
