// overlap_correct for a small run alone on the GPU (n ≤ kDenseClusterMaxN, no walls, no touched
// field): the whole correction in shared memory (positions, the 3n edges as pairs of 16-bit ids,
// the listed edges' pushes), every iteration a dense edge pass, Carter's Algorithm 2 as the CPU's
// edge pass runs it (cpu.cpp): each edge tested on the current positions, each overlapping one
// pushing both ends; then each touched particle finishes its sum and moves (the kernel's
// comment). No fans, candidates or claims: there an iteration of the cluster team is a chain of
// dependent L2 loads and team barriers (bench/experiments/README.md, "What the small rows need"),
// here barriers around passes over shared memory.
//   - one block (n ≤ kDenseMaxN): the block holds everything; three block barriers an iteration.
//   - a cluster of up to kDenseMaxBlocks blocks (n ≤ kDenseClusterMaxN; sm_90's distributed shared
//     memory): block r holds particles [r·P, (r+1)·P) (P = 2^shift, dense_shift) and the edges
//     [3r·P, 3(r+1)·P), whose ends are mostly its own particles (Hilbert order; edges are numbered
//     near their particles). An end held by another block is read from that block's shared
//     memory; a push is linked into its end's list in the end's block, and walked from there. One
//     block barrier and two cluster barriers an iteration; every block's counters go to block 0
//     once a launch.
// Against the team and the grid (bench/README.md, "Session 41" and "Session 42"): bench-abp +21 %
// at 1 024 particles (one block), +7 % at 1 280, +25 % at 2 048, +36 % at 4 096, +37 % at 8 192
// and 16 384 (clusters). Session 44's branch-free reach tests with their offsets listed: +9 % at
// 1 024, +4.6 % at 2 048, +2.2 % at 4 096, +4 % at 16 384; then the counters reduced once a
// launch: +4 / +12 / +16 / +11 %.
// What did not pay (64-bit shared atomics, a block sum in every thread, testing only the moved
// particles' edges; in a cluster, positions written to global memory once a launch, the barrier
// after the moves split around the next reach tests; each thread pushing its own edges without a
// listing; the late iterations in warp 0 alone, or skipping warps with no edge at a particle the
// last iteration touched) is in bench/experiments/README.md.
//
// The same bits as the other loops: the records are checked and the pushes made by kernel.h's
// Overlaps::edge_ends and edge_push (the CPU edge pass's own), summed in fixed point (any order),
// finished by from_sum and moved by moved_from; the counters are the CPU edge pass's (pairs and
// pairs beyond the tolerance each once, |d_v| of every touched particle, corrupt records and the
// permutation check of the next pointers in iteration 0), decided by keeps_going. Device code; included by
// cuda.cu after correct_parts.cuh, compiled with -fmad=false as the other kernels.
#pragma once
#include "stages/overlap_correct/correct_parts.cuh"

namespace ff::overlap {

namespace {

constexpr int kDenseThreads = 1024;
// The largest run one block takes (~100 bytes a particle in double, DenseLayout): above it a
// cluster of small shares is faster (bench-abp at 1 280: 17 800 steps/s on 5 blocks of 256, 16 700
// on one block), and up to 1 024 a thread tests 3 edges, not 6 (+1.7 % at 1 024).
constexpr std::size_t kDenseMaxN = 1024;
// A cluster's blocks hold 2^shift particles each, kDenseMinShift ≤ shift ≤ kDenseMaxShift, the
// least that covers the run with up to 16 blocks (sm_90's largest cluster, non-portable): shares
// of 256 beat 512 by 3-6 % at 1 280-4 096 particles, 512 beat 1 024 by 7-15 % at 1 536-8 192 (more
// threads on the same edges; "Session 42", calls 2-3). 2 048 a block would not fit beside the
// static arrays in double. List tokens are a block's rank and a 16-bit index; particle ids 16-bit.
constexpr int kDenseMaxBlocks = 16;
constexpr int kDenseMinShift = 8, kDenseMaxShift = 10;
constexpr std::size_t kDenseClusterMaxN = std::size_t(kDenseMaxBlocks) << kDenseMaxShift;
static_assert(kDenseClusterMaxN <= 0xFFFF && kDenseMaxN <= 0xFFFF, "particle ids in 16 bits (kCorruptEdge is the last)");
static_assert((6 << kDenseMaxShift) <= 0x10000, "a list token's index in 16 bits: 2 x the 3 edges of each particle held");
static_assert(kDenseMaxBlocks <= 32, "a warp's lanes reach every block (the stamps, the set-up sums)");
static_assert(kDenseMaxN <= std::size_t(kDenseThreads) && (1 << kDenseMaxShift) <= kDenseThreads,
              "a block holds at most a particle a thread (the set-up's loads)");
constexpr std::uint16_t kCorruptEdge = 0xFFFF;
constexpr std::uint32_t kNoToken = 0xFFFFFFFFu;
constexpr std::uint16_t kNoLink = 0xFFFF;
// Edges a thread tests: 3 of each particle a block holds.
constexpr int kDenseRounds =
    int((3 * std::max(kDenseMaxN, std::size_t(1) << kDenseMaxShift) + kDenseThreads - 1) / kDenseThreads);
// The rounds of edges a thread of dense_kernel<R, Shift> tests: every block of a cluster holds
// 2^Shift particles; one block (Shift 0) up to kDenseMaxN, and masks the rounds a smaller run
// does not fill.
template <int Shift>
constexpr int kDenseRoundsOf =
    Shift == 0 ? kDenseRounds : int((3 * (std::size_t(1) << Shift) + kDenseThreads - 1) / kDenseThreads);

// log2 of the particles each block of a cluster holds for a run of n (kDenseMaxN < n ≤
// kDenseClusterMaxN): the least share that covers it with kDenseMaxBlocks blocks (dense_kernel's
// Shift); the cluster's blocks are ceil(n / 2^shift).
inline int dense_shift(std::size_t n) {
  int s = kDenseMinShift;
  while ((std::size_t(kDenseMaxBlocks) << s) < n) ++s;
  return s;
}

// The dynamic shared memory of a block holding m particles, each part 16-byte aligned: positions
// (R x 2), the edges' ends (2 x 3m u16), an iteration's listed edges (3m u32: both ends' ids) and
// their minimum-image offsets (3m x 2 double), their pushes (3m x 2 int64), the links of each listed
// pair's two ends (2 x 3m: u16, in a cluster u32 tokens) and each particle's first link (m u32).
template <class R, bool Cluster = false>
struct DenseLayout {
  std::size_t pos = 0, ea, eb, list, offset, push, link, head, bytes;
  __host__ __device__ static std::size_t up(std::size_t b) { return (b + 15) / 16 * 16; }
  __host__ __device__ explicit DenseLayout(std::size_t m) {
    const std::size_t e = 3 * m;
    ea = pos + up(2 * m * sizeof(R));
    eb = ea + up(2 * e);
    list = eb + up(2 * e);
    offset = list + up(4 * e);
    push = offset + up(16 * e);
    link = push + up(16 * e);
    head = link + up((Cluster ? 4 : 2) * 2 * e);
    bytes = head + up(4 * m);
  }
};

// The block's sums by warps: warp w's sum of each thread's x goes to slot[w] (a plain store: a
// 64-bit atomic add on shared memory is a compare-and-swap spin loop on sm_90, and 32 warps on
// one word serialise on it); after a barrier, warp 0 adds the 32 slots (block_total, in every
// lane of warp 0). The decisions need only whether a count is zero: __syncthreads_or.
constexpr int kDenseWarps = kDenseThreads / 32;
static_assert(kDenseWarps == 32, "block_total: a lane a warp");
__device__ __forceinline__ void warp_slot(u64* slot, u64 x) {
  const u64 s = warp_sum(x);
  if ((threadIdx.x & 31) == 0) slot[threadIdx.x >> 5] = s;
}
__device__ __forceinline__ u64 block_total(const u64* slot) { return warp_sum(slot[threadIdx.x & 31]); }

// sm_90's distributed shared memory, as the dense cluster uses it: loads, stores and an exchange
// at an address in another block's shared memory (correct_parts.cuh's in_block).
// Each is volatile with a memory clobber: none may move across the cluster barriers.
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
#define FF_DSMEM(...) __VA_ARGS__
#else
#define FF_DSMEM(...) __trap()  // never launched: the host launches clusters only on devices that have them
#endif
template <class R>
__device__ __forceinline__ void load_xy_at(unsigned at, double& x, double& y) {
  if constexpr (sizeof(R) == 8) {
    FF_DSMEM(asm volatile("ld.shared::cluster.v2.f64 {%0, %1}, [%2];" : "=d"(x), "=d"(y) : "r"(at) : "memory"));
  } else {
    float fx = 0, fy = 0;
    FF_DSMEM(asm volatile("ld.shared::cluster.v2.f32 {%0, %1}, [%2];" : "=f"(fx), "=f"(fy) : "r"(at) : "memory"));
    x = double(fx);
    y = double(fy);
  }
}
__device__ __forceinline__ longlong2 load_push_at(unsigned at) {
  long long px = 0, py = 0;
  FF_DSMEM(asm volatile("ld.shared::cluster.v2.s64 {%0, %1}, [%2];" : "=l"(px), "=l"(py) : "r"(at) : "memory"));
  return make_longlong2(px, py);
}
__device__ __forceinline__ unsigned load_u32_at(unsigned at) {
  unsigned v = 0;
  FF_DSMEM(asm volatile("ld.shared::cluster.u32 %0, [%1];" : "=r"(v) : "r"(at) : "memory"));
  return v;
}
__device__ __forceinline__ unsigned exchange_at(unsigned at, unsigned v) {
  unsigned old = 0;
  FF_DSMEM(asm volatile("atom.shared::cluster.exch.b32 %0, [%1], %2;" : "=r"(old) : "r"(at), "r"(v) : "memory"));
  return old;
}
__device__ __forceinline__ void store_u64_at(unsigned at, u64 v) {
  FF_DSMEM(asm volatile("st.shared::cluster.u64 [%0], %1;" ::"r"(at), "l"(v) : "memory"));
}
#undef FF_DSMEM

// An iteration: (1) every thread tests its edges by the reach test (r² < the largest diameter²)
// and lists those within reach with the offsets it computed, a warp's at once; (2) each listed
// edge gets its push (Overlaps::edge_push, from the listed offset: the push does not read the
// positions again, which was the head of its chain of dependent loads) and is linked into both
// ends' lists of pushes (one exchange of a 32-bit head each: no 64-bit atomics, which sm_90's
// shared memory runs as spin loops); (3) each touched particle sums its pushes in fixed point
// (any order: the same integer), is finished (from_sum) and moved, written through to global
// memory. One block: a block barrier after each. A cluster: a block barrier after (1), a
// cluster barrier after (2) and (3); a warp with a pair beyond the tolerance stamps every block's
// s_bad_at with k + 1, so every thread reads keeps_going's answer in its own block. The pairs and
// the correction are summed by each thread and reduced once a launch (end_launch), not each
// iteration: that reduction was a warp's tenth of an iteration's instructions, and warp 0's row
// sums stood between every iteration's barriers.
// Shift: 0 for one block, else log2 of the particles a cluster's block holds (a constant: the
// owner of a particle is a shift of its id).
template <class R, int Shift>
__global__ void __launch_bounds__(kDenseThreads, 1) dense_kernel(Args<R, false> a) {
  constexpr bool Cluster = Shift > 0;
  extern __shared__ __align__(16) unsigned char s_mem[];
  // By iteration parity (j & 1): s_listed[p ^ 1] is zeroed by iteration j between its second and
  // third barriers, after every thread read j − 1's.
  __shared__ int s_listed[2];               // edges listed by the reach test
  __shared__ u64 s_launch[2][kDenseWarps];  // by warp: the launch's pairs and correction (end_launch)
  __shared__ u64 s_bad[kDenseWarps];        // by warp: the pairs beyond the tolerance (bad_count)
  __shared__ u64 s_load[3][kDenseWarps];    // by warp: corrupt records, the next pointers' mixes, their expected sum
  __shared__ u64 s_broken[2];               // kBroken of the first iteration, and of the others
  __shared__ u64 s_rows[kRowsHeld][kTouched];  // warp 0: the rows of the iterations not yet in result
  // A cluster's: every block's three setup sums (s_load's, in every block); in block 0, each
  // block's warps' pairs and correction of the launch ([0], [1]: end_launch) and count of pairs
  // beyond the tolerance where the loop gives up ([2]: bad_count); the last k + 1 with a pair
  // beyond the tolerance anywhere (a stamp: never reset).
  __shared__ u64 s_setup[Cluster ? kDenseMaxBlocks : 1][3];
  __shared__ u64 s_part[Cluster ? 3 : 1][Cluster ? kDenseMaxBlocks : 1][Cluster ? kDenseWarps : 1];
  __shared__ long long s_bad_at;

  const int n = int(a.p.n);
  const int tid = int(threadIdx.x), lane = tid & 31, warp = tid >> 5;
  // This block's share: particles [v0, v1), edges [e0, e1) (one block: all of them).
  const unsigned rank = Cluster ? cg::this_cluster().block_rank() : 0u;
  const int blocks = Cluster ? int(gridDim.x) : 1;
  constexpr int shift = Shift;
  constexpr int kRounds = kDenseRoundsOf<Shift>;
  const int v0 = Cluster ? int(rank) << shift : 0;
  const int v1 = Cluster ? min(n, v0 + (1 << shift)) : n;
  const int e0 = 3 * v0, e1 = 3 * v1;
  const DenseLayout<R, Cluster> at(Cluster ? std::size_t(1) << shift : std::size_t(a.p.n));
  R* s_pos = reinterpret_cast<R*>(s_mem + at.pos);
  std::uint16_t* s_ea = reinterpret_cast<std::uint16_t*>(s_mem + at.ea);
  std::uint16_t* s_eb = reinterpret_cast<std::uint16_t*>(s_mem + at.eb);
  std::uint32_t* s_list = reinterpret_cast<std::uint32_t*>(s_mem + at.list);
  double2* s_offset = reinterpret_cast<double2*>(s_mem + at.offset);
  longlong2* s_push = reinterpret_cast<longlong2*>(s_mem + at.push);
  std::uint16_t* s_link = reinterpret_cast<std::uint16_t*>(s_mem + at.link);  // one block
  std::uint32_t* s_token = reinterpret_cast<std::uint32_t*>(s_mem + at.link);  // a cluster
  std::uint32_t* s_head = reinterpret_cast<std::uint32_t*>(s_mem + at.head);
  const Overlaps<R, false>& ov = a.ov;
  // Particle v's position, from the block that holds it.
  auto position = [&](int v, double& x, double& y) {
    if constexpr (Cluster) {
      const unsigned owner = unsigned(v) >> shift;
      const int i = v - (int(owner) << shift);
      if (owner == rank)
        load_xy(s_pos, i, x, y);
      else
        load_xy_at<R>(in_block(s_pos + 2 * i, owner), x, y);
    } else {
      load_xy(s_pos, v, x, y);
    }
  };
  // The reach tests' positions. In a cluster whose threads test three rounds, a load without a
  // branch on the owner (through distributed shared memory also for this block) keeps the three
  // tests straight-line, so they overlap (bench-abp +1.5 % at 16 384); with fewer rounds the local
  // load is the cheaper (−0.7 % at 8 192: bench/README.md, "Session 44").
  auto position_in_test = [&](int v, double& x, double& y) {
    if constexpr (Cluster && kRounds >= 3) {
      const unsigned owner = unsigned(v) >> shift;
      load_xy_at<R>(in_block(s_pos + 2 * (v - (int(owner) << shift)), owner), x, y);
    } else {
      position(v, x, y);
    }
  };

  wait_for_previous_kernel();  // launched programmatically, as the teams (cuda.cu)
  // Every global load of the set-up at once: a thread's particle and its edges' records in one
  // round trip to L2 instead of one each (a block holds at most a particle a thread). One block
  // issues them before the gate is read (a closed gate's launch writes nothing, so what it read
  // does not matter); a cluster after it, where issuing them before the gate measured slower
  // (bench/experiments/README.md, sessions 44 and 47).
  const int v = v0 + tid;
  double x0 = 0, y0 = 0;
  int ra[kRounds], rna[kRounds], rb[kRounds], rnb[kRounds];
  auto load_setup = [&] {
    if (v < v1) load_xy(a.p.pos, v, x0, y0);
#pragma unroll
    for (int r = 0; r < kRounds; ++r) {
      const int e = e0 + r * kDenseThreads + tid;
      ra[r] = rna[r] = rb[r] = rnb[r] = 0;
      if (e < e1) load_edge(ov.he, std::size_t(e), ra[r], rna[r], rb[r], rnb[r]);
    }
  };
  if constexpr (!Cluster) load_setup();
  if (gate_closed(a.p)) {  // (Problem::gate)
    if (rank == 0) report_closed_gate(a.result);
    return;
  }
  if constexpr (Cluster) load_setup();
  if (tid < 2) s_listed[tid] = 0;
  if (Cluster && tid == 0) s_bad_at = 0;
  if (v < v1) {
    s_pos[2 * (v - v0)] = R(x0);  // exact: widened from R
    s_pos[2 * (v - v0) + 1] = R(y0);
    s_head[v - v0] = kNoToken;
  }
  // The edges' ends, checked as the CPU's edge pass checks them (Overlaps::edge_ends_checked, what
  // its edge_ends does after the load): a corrupt
  // record is counted and never read again; in a step's first launch the next pointers too.
  const bool check = a.k0 == 0;
  u64 corrupt = 0, expected = 0;
  std::uint64_t mixes = 0;
#pragma unroll
  for (int r = 0; r < kRounds; ++r) {
    const int e = e0 + r * kDenseThreads + tid;
    if (e >= e1) continue;
    if (!ov.edge_ends_checked(ra[r], rna[r], rb[r], rnb[r], check, mixes)) {
      s_ea[e - e0] = kCorruptEdge;
      ++corrupt;
      continue;
    }
    s_ea[e - e0] = std::uint16_t(ra[r]);
    s_eb[e - e0] = std::uint16_t(rb[r]);
  }
  if (check)
    for (int h = 2 * e0 + tid; h < 2 * e1; h += kDenseThreads) expected += mix(std::uint64_t(h));
  warp_slot(s_load[0], corrupt);
  warp_slot(s_load[1], mixes);
  warp_slot(s_load[2], expected);
  __syncthreads();
  if constexpr (Cluster) {  // this block's sums into every block's s_setup, then the cluster's
    if (tid < 32) {
      const u64 c = block_total(s_load[0]), h = block_total(s_load[1]), x = block_total(s_load[2]);
      if (lane < blocks) {
        store_u64_at(in_block(&s_setup[rank][0], unsigned(lane)), c);
        store_u64_at(in_block(&s_setup[rank][1], unsigned(lane)), h);
        store_u64_at(in_block(&s_setup[rank][2], unsigned(lane)), x);
      }
    }
    cg::this_cluster().sync();  // also: every block's positions and heads in place
    if (tid < 32) {
      const u64 c = warp_sum(lane < blocks ? s_setup[lane][0] : 0);
      const u64 h = warp_sum(lane < blocks ? s_setup[lane][1] : 0), x = warp_sum(lane < blocks ? s_setup[lane][2] : 0);
      if (tid == 0) s_broken[0] = c + (check && h != x ? 1 : 0);
      if (tid == 0) s_broken[1] = c;
    }
  } else if (tid < 32) {  // warp 0: the broken count, for every thread
    const u64 c = block_total(s_load[0]);
    const u64 h = block_total(s_load[1]), x = block_total(s_load[2]);
    if (tid == 0) s_broken[0] = c + (check && h != x ? 1 : 0);
    if (tid == 0) s_broken[1] = c;
  }
  __syncthreads();
  const u64 broken_first = s_broken[0], broken_later = s_broken[1];
  const int rounds = (e1 - e0 + kDenseThreads - 1) / kDenseThreads;  // the same in every thread

  // The launch's pairs (of the iterations that went on) and correction, this thread's share.
  u64 pairs_total = 0, correction_total = 0;
  // The count of pairs beyond the tolerance in an iteration, where the loop gives up (the block's
  // or the cluster's threads all call it; in warp 0 of block 0).
  auto bad_count = [&](u64 bad) {
    u64 c = 0;
    if constexpr (Cluster) {
      const u64 wb = warp_sum(bad);
      if (lane == 0) store_u64_at(in_block(&s_part[2][rank][warp], 0u), wb);
      cg::this_cluster().sync();
      if (rank == 0 && tid < 32) {
        for (int b = 0; b < blocks; ++b) c += s_part[2][b][lane];
        c = warp_sum(c);
      }
    } else {
      warp_slot(s_bad, bad);
      __syncthreads();
      if (tid < 32) c = block_total(s_bad);
    }
    return c;
  };
  // The launch's end after `rows` iterations: the pairs and the correction summed over the
  // threads into row 0 (read_back adds the rows' counts), the last held rows and the count of
  // rows to result.
  auto end_launch = [&](int rows) {
    u64 tp = 0, tc = 0;
    if constexpr (Cluster) {
      const u64 wp = warp_sum(pairs_total), wc = warp_sum(correction_total);
      if (lane == 0) {
        store_u64_at(in_block(&s_part[0][rank][warp], 0u), wp);
        store_u64_at(in_block(&s_part[1][rank][warp], 0u), wc);
      }
      cg::this_cluster().sync();
      if (rank == 0 && tid < 32) {
        for (int b = 0; b < blocks; ++b) {
          tp += s_part[0][b][lane];
          tc += s_part[1][b][lane];
        }
        tp = warp_sum(tp);
        tc = warp_sum(tc);
      }
    } else {
      warp_slot(s_launch[0], pairs_total);
      warp_slot(s_launch[1], correction_total);
      __syncthreads();
      if (tid < 32) {
        tp = block_total(s_launch[0]);
        tc = block_total(s_launch[1]);
      }
    }
    if (rank != 0 || tid >= 32) return;
    if (tid < kTouched && rows % kRowsHeld != 0) store_held_rows<kTouched>(a.result, s_rows, rows);
    __syncwarp();
    if (tid == 0) {
      a.result[kPairs] = tp;
      a.result[kCorrection] = tc;
      a.result[std::size_t(kDeviceBatch) * kCounters] = u64(rows);
    }
  };
  for (int j = 0; j < kDeviceBatch; ++j) {
    const long long k = a.k0 + j;
    const int p = j & 1;
    // (1) The reach test, every edge, then the listing of those within reach. A thread's edges
    // are tested without branches (an edge it does not hold, or a corrupt one, reads the block's
    // last edge and its first particle and is masked out), so their chains of shared loads and
    // double operations overlap; a warp lists its edges of all rounds with one atomic add.
    bool near[kRounds];
    double rx[kRounds], ry[kRounds];
    unsigned ends[kRounds];
#pragma unroll
    for (int r = 0; r < kRounds; ++r) {
      const int e = e0 + r * kDenseThreads + tid;
      const int i = min(e, e1 - 1) - e0;
      const int ia = s_ea[i], ib = s_eb[i];
      const bool held = r < rounds && e < e1 && ia != kCorruptEdge;
      double xa, ya, xb, yb;
      position_in_test(held ? ia : v0, xa, ya);
      position_in_test(held ? ib : v0, xb, yb);
      rx[r] = ov.min_image(xb - xa, 0);
      ry[r] = ov.min_image(yb - ya, 1);
      ends[r] = unsigned(ia) | unsigned(ib) << 16;
      near[r] = held && rx[r] * rx[r] + ry[r] * ry[r] < ov.reach2;
    }
    unsigned listed_by_round[kRounds];
    int warp_listed = 0;
#pragma unroll
    for (int r = 0; r < kRounds; ++r) {
      listed_by_round[r] = __ballot_sync(0xffffffffu, near[r]);
      warp_listed += __popc(listed_by_round[r]);
    }
    if (warp_listed != 0) {
      int base = 0;
      if (lane == 0) base = atomicAdd(&s_listed[p], warp_listed);
      base = __shfl_sync(0xffffffffu, base, 0);
      const unsigned below = (1u << lane) - 1u;
#pragma unroll
      for (int r = 0; r < kRounds; ++r) {
        const unsigned m = listed_by_round[r];
        if (near[r]) {
          const int at_list = base + __popc(m & below);
          s_list[at_list] = ends[r];
          s_offset[at_list] = make_double2(rx[r], ry[r]);
        }
        base += __popc(m);
      }
    }
    __syncthreads();
    // (2) The listed edges' pushes, from the ends and offsets (1) listed.
    const int listed = s_listed[p];
    u64 bad = 0, pairs = 0;
    for (int i = tid; i < listed; i += kDenseThreads) {
      const unsigned ab = s_list[i];
      const double2 off = s_offset[i];
      const int ia = int(ab & 0xFFFFu), ib = int(ab >> 16);
      const double rx = off.x, ry = off.y;
      std::int64_t qx, qy;
      PairOverlap o;
      if (ov.edge_push(ia, ib, rx, ry, qx, qy, o) == kEdgeApart) continue;
      s_push[i] = make_longlong2(qx, qy);  // on a; on b −q
      if constexpr (Cluster) {  // tokens: the rank of this block, 2i + the end
        const std::uint32_t token = (rank << 16) | std::uint32_t(2 * i);
        const unsigned oa = unsigned(ia) >> shift, ob = unsigned(ib) >> shift;
        s_token[2 * i] = exchange_at(in_block(&s_head[ia - (int(oa) << shift)], oa), token);
        s_token[2 * i + 1] = exchange_at(in_block(&s_head[ib - (int(ob) << shift)], ob), token | 1u);
      } else {
        s_link[2 * i] = std::uint16_t(atomicExch(&s_head[ia], std::uint32_t(2 * i)));
        s_link[2 * i + 1] = std::uint16_t(atomicExch(&s_head[ib], std::uint32_t(2 * i + 1)));
      }
      if (counted(o)) {
        ++pairs;
        if (o == kBeyond) ++bad;
      }
    }
    // Every push linked; keeps_going's answer, the same in every thread. The pairs and the
    // correction are not reduced here but summed by each thread over the iterations that go on
    // and reduced once, when the launch ends (end_launch); an iteration's row has kBad 1 when it
    // found a pair beyond the tolerance (the count itself only where the loop gives up, for its
    // message) and kPairs and kCorrection 0.
    bool any_bad;
    if constexpr (Cluster) {
      if (__any_sync(0xffffffffu, bad != 0) && lane < blocks) store_u64_at(in_block(&s_bad_at, unsigned(lane)), u64(k + 1));
      cg::this_cluster().sync();
      any_bad = s_bad_at == k + 1;
    } else {
      any_bad = __syncthreads_or(bad != 0);
    }
    const u64 broken = j == 0 ? broken_first : broken_later;
    const bool go = broken == 0 && any_bad && k < a.max_iterations;
    u64 row_bad = any_bad ? 1 : 0;
    if (any_bad && broken == 0 && !go) row_bad = bad_count(bad);  // max_iterations: read_back gives up
    // Warp 0 (of block 0) holds the row in shared memory and stores a run of kRowsHeld rows to
    // result (pinned host memory) at once, as the team kernel does: not a store over the bus each
    // iteration in the warp the next barrier waits for.
    if (rank == 0 && tid < kTouched) {
      s_rows[j % kRowsHeld][tid] = tid == kBad ? row_bad : tid == kBroken ? broken : 0;
      if ((j + 1) % kRowsHeld == 0) store_held_rows<kTouched>(a.result, s_rows, j + 1);
    }
    if (!go) {  // (a cluster: no block reads another's shared memory after end_launch's barrier)
      end_launch(j + 1);
      return;
    }
    pairs_total += pairs;
    if (tid == 0) s_listed[p ^ 1] = 0;
    // (3) The moves: each touched particle's pushes summed, finished (capped) and applied.
    u64 corr = 0;
    for (int v = v0 + tid; v < v1; v += kDenseThreads) {
      std::uint32_t t = s_head[v - v0];
      if (t == kNoToken) continue;
      s_head[v - v0] = kNoToken;
      std::int64_t qx = 0, qy = 0;
      while (true) {
        longlong2 q;
        std::uint32_t next;
        if constexpr (Cluster) {  // the push and the next token, in the block that listed the edge
          const unsigned owner = t >> 16, i = t & 0xFFFFu;
          if (owner == rank) {
            q = s_push[i >> 1];
            next = s_token[i];
          } else {
            q = load_push_at(in_block(&s_push[i >> 1], owner));
            next = load_u32_at(in_block(&s_token[i], owner));
          }
        } else {
          q = s_push[t >> 1];
          next = s_link[t];
        }
        if (t & 1) {
          qx -= q.x;
          qy -= q.y;
        } else {
          qx += q.x;
          qy += q.y;
        }
        if (next == (Cluster ? kNoToken : kNoLink)) break;
        t = next;
      }
      const VertexPush q = ov.from_sum(v, qx, qy);
      corr += ov.fixed_len(q.len);
      if (q.dx == 0 && q.dy == 0) continue;
      const double d[2] = {q.dx, q.dy};
      R x[2];
      int crossed[2];
      moved_from<2>(s_pos + 2 * (v - v0), a.p.box, d, x, crossed);
      s_pos[2 * (v - v0)] = x[0];
      s_pos[2 * (v - v0) + 1] = x[1];
      store_xy(a.p.pos, v, double(x[0]), double(x[1]));
      if (crossed[0]) a.p.image[2 * v] += crossed[0];
      if (crossed[1]) a.p.image[2 * v + 1] += crossed[1];
    }
    correction_total += corr;
    if constexpr (Cluster)
      cg::this_cluster().sync();  // every move in place
    else
      __syncthreads();  // every move in place
  }
  end_launch(kDeviceBatch);
  static_assert(kDeviceBatch % kRowsHeld == 0, "the last run of held rows is full");
}

}  // namespace

}  // namespace ff::overlap
