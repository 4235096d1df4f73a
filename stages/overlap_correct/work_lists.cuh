// overlap_correct's work lists on the device: a block's compaction of its tile's marks into its
// candidate list, and the word atomics that claim a mark for the tail's one global list (what
// each is for: correct_kernel.cuh's header, "Marks"). Include only from correct_parts.cuh.
#pragma once
#include <cuda_runtime.h>

#include <cstdint>

#include "stages/overlap_correct/neighbor_lists.cuh"

namespace ff::overlap {

namespace {

// Exclusive block-wide prefix sum of c; *total gets the sum. Every thread must call it.
template <int Threads>
__device__ int block_scan(int c, int* total, int* s_warp) {
  constexpr int kWarps = Threads / 32;
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  int x = c;
#pragma unroll
  for (int o = 1; o < 32; o <<= 1) {
    const int y = __shfl_up_sync(0xffffffffu, x, o);
    if (lane >= o) x += y;
  }
  if (lane == 31) s_warp[warp] = x;
  __syncthreads();
  int before = 0, sum = 0;
#pragma unroll
  for (int w = 0; w < kWarps; ++w) {
    const int t = s_warp[w];
    if (w < warp) before += t;
    sum += t;
  }
  __syncthreads();
  *total = sum;
  return before + x - c;
}

// The marked particles of [t0, t0 + tile) into cand, in index order; clears those marks.
template <int Threads>
__device__ int compact(std::uint8_t* marks, int t0, int tile, int* cand, int* s_warp) {
  int count = 0;
  for (int base = 0; base < tile; base += 16 * Threads) {
    const int off = base + 16 * int(threadIdx.x);
    uint4 w = make_uint4(0, 0, 0, 0);
    auto* p = reinterpret_cast<uint4*>(marks + t0 + off);
    if (off < tile) w = __ldcg(p);
    const int c = __popc(w.x) + __popc(w.y) + __popc(w.z) + __popc(w.w);  // bytes are 0 or 1
    int total;
    int at = count + block_scan<Threads>(c, &total, s_warp);
    if (c) {
      const unsigned words[4] = {w.x, w.y, w.z, w.w};
#pragma unroll
      for (int q = 0; q < 4; ++q)
#pragma unroll
        for (int b = 0; b < 4; ++b)
          if ((words[q] >> (8 * b)) & 0xffu) cand[at++] = t0 + off + 4 * q + b;
      *p = make_uint4(0, 0, 0, 0);
    }
    count += total;
  }
  return count;
}

// Particle u's mark (one byte of `marks`) as a bit of the 32-bit word that holds it, for the
// word atomics that claim and clear marks.
__device__ unsigned* mark_word(std::uint8_t* marks, int u) { return reinterpret_cast<unsigned*>(marks) + (u >> 2); }
__device__ unsigned mark_bit(const std::uint8_t*, int u) { return 1u << (8 * (u & 3)); }
// Marks of one bit a particle (shared_tail.cuh, whose shared memory is short of room): the same
// claims.
struct MarkBits {
  unsigned* words;
};
__device__ unsigned* mark_word(MarkBits marks, int u) { return marks.words + (u >> 5); }
__device__ unsigned mark_bit(MarkBits, int u) { return 1u << (u & 31); }

// Whether this thread claimed u's mark: a word atomic, true for the first to set it.
template <class Marks>
__device__ bool claim_mark(Marks marks, int u) {
  const unsigned bit = mark_bit(marks, u);
  return !(atomicOr(mark_word(marks, u), bit) & bit);
}

// Marks u as a candidate of the next iteration: a plain store, or (claim) a word atomic whose
// first taker lists u in cand.
__device__ void mark(std::uint8_t* marks, int u, bool claim, int* cand, unsigned long long* claims) {
  if (!claim) {
    marks[u] = 1;
    return;
  }
  if (claim_mark(marks, u)) cand[atomicAdd(claims, 1ull)] = int(u);
}

// The tail's check of moved particle v by one thread (block 0 alone; claim_one(u): claim_mark
// and, if new, list u at block 0's shared counter): thread_check's tests (check_listed), then
// every claim's word atomic at once (and v's own when any neighbour overlaps or a wall), then the
// lists: one round trip to L2 for the particle, where thread_check with claim_one waits for one a
// neighbour in turn. The same marks; a fan that did not fit the list goes through thread_check's
// walk.
template <class R, bool W, class F>
__device__ void claim_checked(const Overlaps<R, W>& ov, int v, const int* nb, const std::uint8_t* degree,
                              std::uint8_t* marks, int* cand, int* s_claims, F&& claim_one) {
  const int d = degree[v];
  int ids[kCached];
  load_ids(nb, v, ids);
  if (d == kWalk) {
    if (ov.overlapping_neighbors(v, claim_one)) claim_one(v);
    return;
  }
  const CheckedList checked = check_listed(ov, v, ids, d);
  const unsigned near = checked.near;
  const bool self = checked.self;
  unsigned old[kCached + 1];
#pragma unroll
  for (int k = 0; k < kCached; ++k)
    if ((near >> k) & 1u) old[k] = atomicOr(mark_word(marks, ids[k]), mark_bit(marks, ids[k]));
  if (self) old[kCached] = atomicOr(mark_word(marks, v), mark_bit(marks, v));
#pragma unroll
  for (int k = 0; k < kCached; ++k)
    if (((near >> k) & 1u) && !(old[k] & mark_bit(marks, ids[k]))) cand[atomicAdd(s_claims, 1)] = ids[k];
  if (self && !(old[kCached] & mark_bit(marks, v))) cand[atomicAdd(s_claims, 1)] = v;
}

}  // namespace

}  // namespace ff::overlap
