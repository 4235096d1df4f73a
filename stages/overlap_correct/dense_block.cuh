// overlap_correct for a small run alone on the GPU (n ≤ kDenseMaxN, no walls, no touched field):
// one block keeps the whole correction in its shared memory (positions, the 3n edges as pairs of
// 16-bit ids, the listed edges' pushes) and runs every iteration as a dense edge pass, Carter's
// Algorithm 2 as the CPU's edge pass runs it (cpu.cpp): each edge tested on the current
// positions, each overlapping one pushing both ends; then each touched particle finishes its sum
// and moves (the kernel's comment). No fans, candidates or claims: there an iteration of the
// cluster team is a chain of dependent L2 loads and team barriers (bench/experiments/README.md,
// "What the small rows need"), here three block barriers around passes over shared memory.
// Against the team (bench/README.md, "Session 41"): bench-abp +21 % at 1 024 particles, +2-5 % at
// 1 280-1 792, the same at 2 048; what did not pay (64-bit shared atomics, a block sum in every
// thread, testing only the moved particles' edges) is in bench/experiments/README.md.
//
// The same bits as the other loops: the pushes are kernel.h's (Overlaps::edge's operations on
// the device, pair_term, fixed_push), summed in fixed point (any order), finished by from_sum and
// moved by moved_from; the counters are the CPU edge pass's (pairs and pairs beyond the
// tolerance each once, |d_v| of every touched particle, corrupt records and the permutation
// check of the next pointers in iteration 0), decided by keeps_going. Device code; included by
// cuda.cu after correct_parts.cuh, compiled with -fmad=false as the other kernels.
#pragma once
#include "stages/overlap_correct/correct_parts.cuh"

namespace ff::overlap {

namespace {

constexpr int kDenseThreads = 1024;
// The largest run it takes: where it stops beating the cluster team (the same at 2 048), within
// 16-bit ids and list entries and one block's shared memory (~100 bytes a particle in double:
// 200 KB at 2 048, DenseLayout).
constexpr std::size_t kDenseMaxN = 2048;
constexpr std::uint16_t kCorruptEdge = 0xFFFF;
constexpr std::uint32_t kNoToken = 0xFFFFFFFFu;
constexpr std::uint16_t kNoLink = 0xFFFF;
constexpr int kDenseRounds = int((3 * kDenseMaxN + kDenseThreads - 1) / kDenseThreads);  // edges a thread tests

// The dynamic shared memory of n particles, each part 16-byte aligned: positions (R x 2), the
// edges' ends (2 x 3n u16), an iteration's listed edges (3n u16), their pushes (3n x 2 int64),
// the links of each listed pair's two ends (2 x 3n u16) and each particle's first link (n u32).
template <class R>
struct DenseLayout {
  std::size_t pos = 0, ea, eb, list, push, link, head, bytes;
  __host__ __device__ static std::size_t up(std::size_t b) { return (b + 15) / 16 * 16; }
  __host__ __device__ explicit DenseLayout(std::size_t n) {
    const std::size_t e = 3 * n;
    ea = pos + up(2 * n * sizeof(R));
    eb = ea + up(2 * e);
    list = eb + up(2 * e);
    push = list + up(2 * e);
    link = push + up(16 * e);
    head = link + up(2 * 2 * e);
    bytes = head + up(4 * n);
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

// An iteration: (1) every thread tests its edges by the reach test (r² < the largest diameter²)
// and lists those within reach, a warp's at once; (2) each listed edge gets its push (pair_term,
// as Overlaps::edge on the device) and is linked into both ends' lists of pushes (one exchange
// of a 32-bit head each: no 64-bit atomics, which sm_90's shared memory runs as spin loops);
// (3) each touched particle sums its pushes in fixed point (any order: the same integer), is
// finished (from_sum) and moved, written through to global memory. A block barrier after each.
template <class R>
__global__ void __launch_bounds__(kDenseThreads, 1) dense_kernel(Args<R, false> a) {
  extern __shared__ __align__(16) unsigned char s_mem[];
  // By iteration parity (j & 1): an iteration's slots are read after the barrier that follows
  // their stores, and stored again two iterations later. s_listed[p ^ 1] is zeroed by iteration j
  // between its second and third barriers, after every thread read j − 1's.
  __shared__ u64 s_red[2][3][kDenseWarps];  // by warp: kBad, kPairs of the pushes, kCorrection of the moves
  __shared__ int s_listed[2];               // edges listed by the reach test
  __shared__ u64 s_load[3][kDenseWarps];    // by warp: corrupt records, the next pointers' mixes, their expected sum
  __shared__ u64 s_broken[2];               // kBroken of the first iteration, and of the others
  __shared__ u64 s_rows[kRowsHeld][kTouched];  // warp 0: the rows of the iterations not yet in result

  const int n = int(a.p.n), edges = 3 * n;
  const DenseLayout<R> at(std::size_t(a.p.n));
  R* s_pos = reinterpret_cast<R*>(s_mem + at.pos);
  std::uint16_t* s_ea = reinterpret_cast<std::uint16_t*>(s_mem + at.ea);
  std::uint16_t* s_eb = reinterpret_cast<std::uint16_t*>(s_mem + at.eb);
  std::uint16_t* s_list = reinterpret_cast<std::uint16_t*>(s_mem + at.list);
  longlong2* s_push = reinterpret_cast<longlong2*>(s_mem + at.push);
  std::uint16_t* s_link = reinterpret_cast<std::uint16_t*>(s_mem + at.link);
  std::uint32_t* s_head = reinterpret_cast<std::uint32_t*>(s_mem + at.head);
  const Overlaps<R, false>& ov = a.ov;
  const int tid = int(threadIdx.x), lane = tid & 31;

  wait_for_previous_kernel();  // launched programmatically, as the teams (cuda.cu)
  if (gate_closed(a.p)) {  // one gather that found nothing, and no move (Problem::gate)
    if (tid < kCounters) a.result[tid] = 0;
    if (tid == 0) a.result[std::size_t(kDeviceBatch) * kCounters] = 1;
    return;
  }
  if (tid < 2) s_listed[tid] = 0;
  for (int v = tid; v < n; v += kDenseThreads) {
    double x, y;
    load_xy(a.p.pos, v, x, y);
    s_pos[2 * v] = R(x);  // exact: widened from R
    s_pos[2 * v + 1] = R(y);
    s_head[v] = kNoToken;
  }
  // The edges' ends, checked as the CPU's edge pass checks them (Overlaps::edge): a corrupt
  // record is counted and never read again; in a step's first launch the next pointers too.
  const bool check = a.k0 == 0;
  u64 corrupt = 0, mixes = 0, expected = 0;
  for (int e = tid; e < edges; e += kDenseThreads) {
    int ia, na, ib, nb;
    load_edge(ov.he, std::size_t(e), ia, na, ib, nb);
    const bool ends = unsigned(ia) < unsigned(n) && unsigned(ib) < unsigned(n) && ia != ib;
    const bool nexts = !check || (unsigned(na) < 6u * unsigned(n) && unsigned(nb) < 6u * unsigned(n));
    if (!ends || !nexts) {
      s_ea[e] = kCorruptEdge;
      ++corrupt;
      continue;
    }
    s_ea[e] = std::uint16_t(ia);
    s_eb[e] = std::uint16_t(ib);
    if (check) mixes += mix(std::uint64_t(unsigned(na))) + mix(std::uint64_t(unsigned(nb)));
  }
  if (check)
    for (int h = tid; h < 2 * edges; h += kDenseThreads) expected += mix(std::uint64_t(h));
  warp_slot(s_load[0], corrupt);
  warp_slot(s_load[1], mixes);
  warp_slot(s_load[2], expected);
  __syncthreads();
  if (tid < 32) {  // warp 0: the broken count, for every thread
    const u64 c = block_total(s_load[0]);
    const u64 h = block_total(s_load[1]), x = block_total(s_load[2]);
    if (tid == 0) s_broken[0] = c + (check && h != x ? 1 : 0);
    if (tid == 0) s_broken[1] = c;
  }
  __syncthreads();
  const u64 broken_first = s_broken[0], broken_later = s_broken[1];
  const int rounds = (edges + kDenseThreads - 1) / kDenseThreads;  // the same in every thread

  for (int j = 0; j < kDeviceBatch; ++j) {
    const long long k = a.k0 + j;
    const int p = j & 1;
    // (1) The reach test, every edge: all of a thread's edges first (independent chains), then
    // their listing, a warp's at once.
    bool near[kDenseRounds];
#pragma unroll
    for (int r = 0; r < kDenseRounds; ++r) {
      const int e = r * kDenseThreads + tid;
      near[r] = false;
      if (r < rounds && e < edges) {
        const int ia = s_ea[e];
        if (ia != kCorruptEdge) {
          double xa, ya, xb, yb;
          load_xy(s_pos, ia, xa, ya);
          load_xy(s_pos, s_eb[e], xb, yb);
          const double rx = ov.min_image(xb - xa, 0), ry = ov.min_image(yb - ya, 1);
          near[r] = rx * rx + ry * ry < ov.reach2;
        }
      }
    }
#pragma unroll
    for (int r = 0; r < kDenseRounds; ++r) {
      if (r >= rounds) break;
      const unsigned m = __ballot_sync(0xffffffffu, near[r]);
      if (m) {
        int base = 0;
        if (lane == 0) base = atomicAdd(&s_listed[p], __popc(m));
        base = __shfl_sync(0xffffffffu, base, 0);
        if (near[r]) s_list[base + __popc(m & ((1u << lane) - 1u))] = std::uint16_t(r * kDenseThreads + tid);
      }
    }
    __syncthreads();
    // (2) The listed edges' pushes.
    const int listed = s_listed[p];
    u64 bad = 0, pairs = 0;
    for (int i = tid; i < listed; i += kDenseThreads) {
      const int e = s_list[i];
      const int ia = s_ea[e], ib = s_eb[e];
      double xa, ya, xb, yb;
      load_xy(s_pos, ia, xa, ya);
      load_xy(s_pos, ib, xb, yb);
      const double rx = ov.min_image(xb - xa, 0), ry = ov.min_image(yb - ya, 1);
      double tx, ty;
      const PairOverlap o = pair_term(rx, ry, ov.diameter_of(ia), ov.diameter_of(ib), ov.factor, ov.tol, ia, ib, tx, ty);
      if (o == kApart) continue;
      s_push[i] = make_longlong2(-ov.fixed_push(tx), -ov.fixed_push(ty));  // on a; on b −q
      s_link[2 * i] = std::uint16_t(atomicExch(&s_head[ia], std::uint32_t(2 * i)));
      s_link[2 * i + 1] = std::uint16_t(atomicExch(&s_head[ib], std::uint32_t(2 * i + 1)));
      if (counted(o)) {
        ++pairs;
        if (o == kBeyond) ++bad;
      }
    }
    warp_slot(s_red[p][0], bad);
    warp_slot(s_red[p][1], pairs);
    // Every push linked, the counters in; keeps_going's answer, the same in every thread.
    const bool any_bad = __syncthreads_or(bad != 0);
    const u64 broken = j == 0 ? broken_first : broken_later;
    const bool go = broken == 0 && any_bad && k < a.max_iterations;
    // The iteration's row of counters (warp 0), stored to result after the moves (or now).
    u64 row_bad = 0, row_pairs = 0;
    if (tid < 32) {
      row_bad = block_total(s_red[p][0]);
      row_pairs = block_total(s_red[p][1]);
    }
    // Warp 0 holds the row in shared memory and stores a run of kRowsHeld rows to result
    // (pinned host memory) at once, as the team kernel does: not a store over the bus each
    // iteration in the warp the next barrier waits for.
    auto keep_row = [&](u64 correction) {
      if (tid >= kTouched) return;
      s_rows[j % kRowsHeld][tid] = tid == kBad ? row_bad : tid == kPairs ? row_pairs : tid == kBroken ? broken : correction;
      if ((j + 1) % kRowsHeld == 0) store_held_rows<kTouched>(a.result, s_rows, j + 1);
    };
    if (!go) {
      keep_row(0);
      if (tid < kTouched && (j + 1) % kRowsHeld != 0) store_held_rows<kTouched>(a.result, s_rows, j + 1);
      if (tid == 0) a.result[std::size_t(kDeviceBatch) * kCounters] = u64(j + 1);
      return;
    }
    if (tid == 0) s_listed[p ^ 1] = 0;
    // (3) The moves: each touched particle's pushes summed, finished (capped) and applied.
    u64 corr = 0;
    for (int v = tid; v < n; v += kDenseThreads) {
      std::uint32_t t = s_head[v];
      if (t == kNoToken) continue;
      s_head[v] = kNoToken;
      std::int64_t qx = 0, qy = 0;
      while (true) {
        const longlong2 q = s_push[t >> 1];
        if (t & 1) {
          qx -= q.x;
          qy -= q.y;
        } else {
          qx += q.x;
          qy += q.y;
        }
        const std::uint16_t next = s_link[t];
        if (next == kNoLink) break;
        t = next;
      }
      const VertexPush q = ov.from_sum(v, qx, qy);
      corr += ov.fixed_len(q.len);
      if (q.dx == 0 && q.dy == 0) continue;
      const double d[2] = {q.dx, q.dy};
      R x[2];
      int crossed[2];
      moved_from<2>(s_pos + 2 * v, a.p.box, d, x, crossed);
      s_pos[2 * v] = x[0];
      s_pos[2 * v + 1] = x[1];
      store_xy(a.p.pos, v, double(x[0]), double(x[1]));
      if (crossed[0]) a.p.image[2 * v] += crossed[0];
      if (crossed[1]) a.p.image[2 * v + 1] += crossed[1];
    }
    warp_slot(s_red[p][2], corr);
    __syncthreads();  // every move in place, the correction summed
    if (tid < 32) {
      const u64 correction = block_total(s_red[p][2]);
      keep_row(correction);
    }
  }
  if (tid == 0) a.result[std::size_t(kDeviceBatch) * kCounters] = u64(kDeviceBatch);
  static_assert(kDeviceBatch % kRowsHeld == 0, "the last run of held rows is full");
}

}  // namespace

}  // namespace ff::overlap
