// overlap_correct's CUDA kernels (the persistent iteration kernel; its launch shapes: team_shape.cuh),
// included by cuda.cu, the host launch code, only: one translation unit, compiled with
// -fmad=false as cuda.cu is (CMakeLists.txt). What the kernel does and why:
//
// CUDA loop of overlap_correct: one persistent cooperative kernel per step runs the whole
// iteration (gather, grid barrier, decide, apply, grid barrier, check, ...) on the device and
// reports every gather's counters with one read-back. Compiled with -fmad=false
// (CMakeLists.txt): without contracted multiply-adds the per-particle math (kernel.h) rounds
// exactly as on the CPU, so both backends produce the same bits in double.
//
// Work lists (the CPU's rule, cpu.cpp). Block b owns the particles [b·T, (b+1)·T). Iteration 0
// gathers all of them. Each gather lists, block-private, the particles it touched (an
// overlapping edge): those that moved, with their displacements, and those that did not (d = 0).
// Once the moves are in (see Barriers below), the check marks the candidates of iteration k + 1:
//   - each touched particle that did not move;
//   - both ends of each edge of a moved particle that overlaps at the new positions (tested
//     with r² < σ²·(1 + 1e-9), a superset of the gather's own test r² < σ², whose r² is the same
//     bits from either end, so rounding can only add particles), and a moved particle that
//     overlaps a wall (walls: kernel.h's wall_term, a term of the particle's own gather).
// An edge that overlaps at k + 1 either has a moved end (then the check of that end marks both)
// or had both ends fixed, so it overlapped at k already, both ends were touched, and an end
// that did not move is marked as such (an end that moved was checked). So every particle left
// out would have gathered d = 0 and no pairs: the result is the same as gathering everyone, the
// CPU loop's result (kernel.h: pushes are summed in 64-bit fixed point, so the CPU's edge passes
// and these walks give the same bits). The rule before (every neighbour of a moved particle)
// gathered 2.3x as many in iteration 1 at 2^20 (988k against 429k; bench/overlap_correct-PERF.md);
// the check walks each moved particle once, as the flagging did.
//
// Barriers. Below the wide path (Args::next set) the gathers also write each moved particle's new
// position to a second array, next, and iteration 0 copies every other particle's, so next holds
// the positions after the iteration's moves from the barrier after the gathers on. The check
// reads them there while each block applies its own moves to pos, which nothing reads before the
// barrier after the check: a team iteration meets at two team barriers (gathers | check), and
// with walls a block waits for its own apply (image counts) before its check. On the wide path
// (2^17 and up) the apply has its own grid barrier: a second array costs L2 room there
// (bench/experiments/README.md, "fused25" and session 26). The tail (block 0 alone) keeps its
// counters in two copies by iteration parity and sums them with shared atomics, so a tail
// iteration has two block barriers.
//
// Marks are one byte per particle. While many particles move, they are plain stores, and after a
// grid barrier each block compacts the marks of its tile (in index order, clearing them). Once an
// iteration moves at most kTailMoved particles (a run alone's cluster: kClusterTailMoved), the
// remaining iterations run in block 0 alone with __syncthreads only (an iteration of a few
// hundred particles is faster in one block, whose time is then the chains of dependent loads of
// its walks, than on the grid with its barriers): the
// check of that iteration (all blocks, then one last grid barrier) and each one after claims a
// mark with a word atomic and lists the particle that claimed it first in one global list, which
// block 0 gathers (clearing each mark) without scanning every tile. The first check counts the
// list's entries with a global atomic; the tail's own checks count them in block 0's shared
// memory, and a thread issues the mark atomics of all it marks for one moved particle before it
// waits for any (claim_checked): a tail iteration is a chain of dependent steps, and a global
// atomic whose answer a thread waits for is a round trip to L2 in it. Block 0's lists then span
// the whole arrays (grid·tile ≥ N entries; a particle is listed once an iteration).
// A run alone's cluster of 16 without walls whose particles fit block 0's shared memory runs the
// tail there instead (shared_tail.cuh: positions, lists, candidates and moves copied in when the
// tail starts, the same iterations; the SharedTail instantiation of the kernel).
// The same particles are gathered either way; only who gathers them differs. Iteration 0 copies
// each particle's neighbours to a list that the later gathers and checks read instead of walking
// the fan again (kCached below), and keeps the list from the step before where the fan did not
// change (kept_fan: checked with independent loads instead of walked as a chain): one thread per
// particle, its neighbours' positions loaded kInFlight at a time, or, when a block has at most
// kGroupBelow particles to do (the late iterations), a group of 8 lanes per particle, one
// neighbour each. A gather also computes where each particle it moves goes (kernel.h's moved_from,
// with the position it just loaded), so the apply only stores positions. (Tried and not in,
// being slower: edge passes, the check fused with the next gather, teams of blocks for the late
// iterations: bench/experiments/README.md, bench/overlap_correct-PERF.md.)
//
// On a full grid (more particles than the cooperative grid's threads: DeviceLoops::prepare) the
// first kWideIterations iterations (iteration 0: every particle a candidate, its fans walked or
// checked, the bulk of the time at 2^20) run before the cooperative kernel, as ordinary launches
// with few registers and more warps on an SM (wide_kernels.cuh); the
// cooperative kernel then starts at the next iteration (Args::j0). Otherwise, and in a cluster,
// the one kernel runs every iteration itself.
//
// Counters: per-thread sums, a block reduction, then one integer atomic per block into one of
// kShards copies of each counter (spreading same-address atomics); after the barrier every
// block sums the shards and takes the same decision (keeps_going). Integer sums do not depend
// on the order, so neither does anything else.
//
// Small systems (team_for): the same kernel runs in a thread-block cluster instead of the grid
// (n ≤ kClusterMaxN; cluster.sync, and each block reads the others' block sums from their shared
// memory instead of the sharded atomics). Who gathers a particle changes, not what it gathers, so
// the bits and the iteration counts are the grid's (test_overlap_correct_cpu_cuda: CPU == CUDA on both
// sides of the thresholds).
#pragma once
#include "stages/overlap_correct/correct_parts.cuh"
#include "stages/overlap_correct/shared_tail.cuh"

namespace ff::overlap {

namespace {

// Walls: the wall code compiled in (walls: x | y); Mark: the touched field written (mark: true);
// Team: who runs the iterations (team_sync); Threads: the block size; SharedTail: block 0 runs the
// tail in its shared memory (shared_tail.cuh: a run alone's cluster without walls, launched with
// TailState<R>::bytes(n) of dynamic shared memory where one launch runs the whole step), a kernel
// of its own so that the others keep their code.
template <class R, int Threads, int MinBlocks, int Team, bool Walls, bool Mark, bool SharedTail = false>
__global__ void __launch_bounds__(Threads, MinBlocks) correct_kernel(Args<R, Walls> a) {
  static_assert(!SharedTail || (Team == kClusterTailTeam && !Walls), "a shared-memory tail: the cluster of 16, no walls");
  constexpr int kReported = Sums<Mark>::kReported, kMoved = Sums<Mark>::kMoved, kAll = Sums<Mark>::kAll;
  constexpr int kWarps = Threads / 32, kGroups = Threads / kGroup;
  // A cluster's blocks sum the counters from each other's shared memory (s_part) instead of
  // global atomics and loads: no round trip to L2 between the barrier and the decision.
  constexpr bool kCluster = Team != kGrid;
  __shared__ u64 s_part[kAll];  // (kCluster) this block's sums of the iteration
  __shared__ int s_warp[kWarps];
  // Counters by iteration parity (j & 1): iteration j zeroes those of j + 1 (last read in j − 1,
  // before the barrier that ended it), so no barrier is spent on resetting them.
  __shared__ int s_seeds[2], s_moved[2];
  __shared__ int s_claims[2];  // the tail's own checks: entries of cand claimed for iteration j
  __shared__ u64 s_sum[2][kReported];  // the tail's sums: shared atomics, one barrier
  __shared__ u64 s_red[kReported][kWarps];
  __shared__ u64 s_tot[kAll];
  __shared__ u64 s_rows[kRowsHeld][kReported];  // block 0: the sums of the iterations not yet in result
  // A team block's candidates when its tile fits (a.tile ≤ Threads): the compaction hands them to
  // the gathers here, not through cand in global memory and back from L2. Not with walls: ptxas
  // would spill in some of their kernels.
  __shared__ int s_cand[Threads];

  const Overlaps<R, Walls>& ov = a.ov;
  const int n = int(a.p.n);
  const int t0 = int(blockIdx.x) * a.tile;
  const int t1 = min(n, t0 + a.tile);
  const std::size_t mine = std::size_t(blockIdx.x) * a.tile;  // 0 for block 0: its tail lists span all
  int* cand = a.cand + mine;
  int* seed = a.seed + mine;
  double2* disp = a.disp + mine;
  char2* crossed = a.crossed + mine;
  const int lane = threadIdx.x & 31;
  const int shard = int(blockIdx.x % kShards) * kShardStride;
  const bool cand_shared = !Walls && a.tile <= Threads;  // a team iteration's candidates in s_cand
  bool tail = false;        // block 0 alone runs the iterations
  bool tail_first = false;  // the tail's first iteration: its candidates were claimed by every block
  // Block 0's thread q < kReported stores column q of the held rows [from, end) to result (each
  // thread reads only the column it wrote: no barrier). keep_row holds iteration j's sums (storing
  // a full run), end_rows stores the rest and the gather count where the launch ends.
  auto store_rows = [&](int end) { store_held_rows<kReported>(a.result, s_rows, end); };
  auto keep_row = [&](int j, const u64* sums) {
    if (blockIdx.x != 0 || threadIdx.x >= kReported) return;
    s_rows[j % kRowsHeld][threadIdx.x] = sums[threadIdx.x];
    if ((j + 1) % kRowsHeld == 0) store_rows(j + 1);
  };
  auto end_rows = [&](int end) {
    if (blockIdx.x != 0 || threadIdx.x >= kReported) return;
    if (end % kRowsHeld != 0) store_rows(end);
    if (threadIdx.x == 0) a.result[std::size_t(kDeviceBatch) * kCounters] = u64(end);
  };
  wait_for_previous_kernel();  // the launch is programmatic (team_shape.cuh's *_config_after_previous)
  // The next launch's counters, zeroed here instead of by a memset before it (a host call on
  // the step's critical path, between Lawson's wait and this launch). No one reads them now.
  for (long long w = blockIdx.x * Threads + threadIdx.x; w < a.next_zero; w += (long long)gridDim.x * Threads)
    a.next_slots[w] = 0;
  if (blockIdx.x == 0 && threadIdx.x == 0) a.next_slots[kSlotWords] = 0;  // the claims count
  // A closed gate (Problem::gate): one gather that found nothing, and no move.
  if (gate_closed(a.p)) {
    if (blockIdx.x == 0) report_closed_gate(a.result);
    return;
  }

  // The batch's iterations before j0 ran in the wide kernels (run_wide): their sums are in the
  // slots. Block 0 reports them, and every block stops where one of them did not go on (then its
  // marks are clear: the wide check ran only after iterations that went on).
  for (int j = 0; j < a.j0; ++j) {
    if (threadIdx.x < kAll) s_tot[threadIdx.x] = slot_total<kAll>(a.slots, j, int(threadIdx.x));
    __syncthreads();
    keep_row(j, s_tot);
    std::uint64_t tot[kReported];
#pragma unroll
    for (int q = 0; q < kReported; ++q) tot[q] = s_tot[q];
    __syncthreads();  // (s_tot is written again)
    if (!keeps_going(tot, a.k0 + j, a.max_iterations)) {
      end_rows(j + 1);
      return;
    }
  }

  if (threadIdx.x < 2) s_seeds[threadIdx.x] = s_moved[threadIdx.x] = s_claims[threadIdx.x] = 0;
  if (threadIdx.x < 2 * kReported) s_sum[threadIdx.x / kReported][threadIdx.x % kReported] = 0;
  __syncthreads();
  for (int j = a.j0; j < kDeviceBatch; ++j) {
    const long long k = a.k0 + j;
    const int p = j & 1, p_next = p ^ 1;
    // Iteration 0 (every particle a candidate) runs here in a cluster and on a grid that is not
    // full; on a full grid it ran in the wide kernels (j0 ≥ 1 whenever k0 = 0: DeviceLoops::prepare).
    const bool first = k == 0;
    int count;
    if (first) {
      count = max(0, t1 - t0);
    } else if (!tail) {
      count = cand_shared ? compact<Threads>(a.marks, t0, a.tile, s_cand, s_warp)
                          : compact<Threads>(a.marks, t0, a.tile, cand, s_warp);
      __syncthreads();  // (its cand entries, for the gathers)
    } else {
      count = tail_first ? int(__ldcg(a.claims)) : s_claims[p];
      tail_first = false;
    }
    if (threadIdx.x == 0) s_seeds[p_next] = s_moved[p_next] = s_claims[p_next] = 0;
    if (threadIdx.x < kReported) s_sum[p_next][threadIdx.x] = 0;

    u64 c[kReported] = {};
    // What a gather found (take_gather): the touched particle in seed (~v when it stays), where
    // a moving one goes in disp, crossed (and next).
    auto take = [&](int v, const VertexPush& q) {
      take_gather<Mark>(c, ov, a.p.box, q, a.p.touched, v, first, &s_seeds[p],
                        [&](int m, bool moves, const R* x, const int* cr) {
                          seed[m] = moves ? v : ~v;
                          if (!moves) return;
                          if (a.next) store_xy(a.next, v, double(x[0]), double(x[1]));
                          disp[m] = make_double2(double(x[0]), double(x[1]));
                          crossed[m] = make_char2(char(cr[0]), char(cr[1]));
                          atomicAdd(&s_moved[p], 1);
                        });
    };
    if (first || count > kGroupBelow<Threads>) {  // one thread per particle
      for (int i = int(threadIdx.x); i < count; i += Threads) {
        const int v = first ? t0 + i : !tail && cand_shared ? s_cand[i] : __ldcg(cand + i);
        if (tail)  // its claim: cleared for the next check
          atomicAnd(mark_word(a.marks, v), ~mark_bit(a.marks, v));
        int ids[kCached], d;
        const VertexPush q =
            neighbor_ids(ov, v, first, a.nb, a.degree, a.fan, ids, d) ? gather_ids(ov, v, ids, d) : ov.gather(v);
        take(v, q);
        if (first && a.next && !(q.touched && (q.dx != 0 || q.dy != 0))) {  // next = pos where v stays
          double x, y;
          load_xy(a.p.pos, v, x, y);
          store_xy(a.next, v, x, y);
        }
      }
    } else {  // one lane group per particle (the loop is uniform over the block: shuffles)
      const int l = int(threadIdx.x) % kGroup;
      for (int base = 0; base < count; base += kGroups) {
        const int i = base + int(threadIdx.x) / kGroup;
        const bool has = i < count;
        const int v = !has ? 0 : !tail && cand_shared ? s_cand[i] : __ldcg(cand + i);
        if (tail && has && l == 0)  // its claim: cleared for the next check
          atomicAnd(mark_word(a.marks, v), ~mark_bit(a.marks, v));
        const VertexPush q = group_gather(ov, v, has, l, a.nb, a.degree);
        if (has && l == 0) take(v, q);
      }
    }
    // The iteration's sums: in the tail, shared atomics (u64 sums do not depend on the order) and
    // one barrier; in a team, warp sums, the block's in s_tot, then the team's.
    const u64* sums = s_tot;
    if (tail) {
#pragma unroll
      for (int q = 0; q < kReported; ++q) {
        const u64 s = warp_sum(c[q]);
        if (lane == 0 && s) atomicAdd(&s_sum[p][q], s);
      }
      __syncthreads();
      sums = s_sum[p];
    } else {
      u64 s = block_sum(c, s_red);
      if (threadIdx.x < kAll) {
        if (threadIdx.x == kMoved) s = u64(s_moved[p]);
        if (kCluster)
          s_part[threadIdx.x] = s;
        else if (s)
          atomicAdd(a.slots + (std::size_t(j) * kAll + threadIdx.x) * kShards * kShardStride + shard, s);
      }
      team_sync<Team>();
      if (threadIdx.x < kAll) {
        u64 s = 0;
        if constexpr (kCluster) {
          // Read here, between the barrier and the next team barrier: s_part is written again
          // only after that, and a block returns only after one more barrier (below).
          for (int r = 0; r < Team; ++r) s += load_in_block(s_part + threadIdx.x, r);
        } else {
          s = slot_total<kAll>(a.slots, j, int(threadIdx.x));
        }
        s_tot[threadIdx.x] = s;
      }
      __syncthreads();
    }
    keep_row(j, sums);
    std::uint64_t tot[kReported];
#pragma unroll
    for (int q = 0; q < kReported; ++q) tot[q] = sums[q];
    // The step ends here. Every mark is clear: the compaction or the gather cleared each one,
    // and none is set before the check that follows an apply.
    if (!keeps_going(tot, k, a.max_iterations)) {
      // A cluster's block keeps its shared memory until the others have read its sums.
      if (kCluster && !tail) team_sync<Team>();
      end_rows(j + 1);
      return;
    }

    const int ns = s_seeds[p];
    for (int i = int(threadIdx.x); i < ns; i += Threads) {
      const int v = seed[i];
      if (v >= 0) {
        const double2 x = disp[i];
        const char2 c = crossed[i];
        store_xy(a.p.pos, v, x.x, x.y);
        if (c.x) a.p.image[2 * v] += c.x;
        if (c.y) a.p.image[2 * v + 1] += c.y;
      }
    }
    // With next (a.next): the check reads the new positions from next, complete since the
    // gathers wrote them before the barrier above, while the apply writes pos, which nothing reads
    // until the barrier after the check; so only this block's own apply, its image counts, which
    // the check's wall test reads, needs to be done, and only with walls. Without next: every
    // block's apply first.
    if (a.next) {
      if constexpr (Walls) __syncthreads();
    } else if (tail) {
      __syncthreads();
    } else {
      team_sync<Team>();
    }
    const Overlaps<R, Walls>& ovc = a.ov_check;

    // The check (positions are the new ones now): marks the next iteration's candidates. The
    // last iteration of a batch leaves plain marks, which the next launch compacts.
    const bool last = j + 1 == kDeviceBatch;
    const bool to_tail = !tail && s_tot[kMoved] <= u64(Team == kClusterTailTeam ? kClusterTailMoved : kTailMoved);
    const bool claim = (tail || to_tail) && !last;
    const bool in_block = tail && !last;  // block 0 alone: the claims counted in its shared memory
    auto mark_it = [&](int u) {
      if (!in_block)
        mark(a.marks, u, claim, a.cand, a.claims);
      else if (claim_mark(a.marks, u))
        a.cand[atomicAdd(&s_claims[p_next], 1)] = u;
    };
    if (ns > kGroupBelow<Threads>) {  // one thread per listed particle
      for (int i = int(threadIdx.x); i < ns; i += Threads) {
        const int v = seed[i];
        if (v < 0)
          mark_it(~v);
        else if (in_block)
          claim_checked(ovc, v, a.nb, a.degree, a.marks, a.cand, &s_claims[p_next], mark_it);
        else if (thread_check(ovc, v, a.nb, a.degree, mark_it))  // (the fan closed in iteration 0)
          mark_it(v);
      }
    } else {
      const int l = int(threadIdx.x) % kGroup;
      for (int base = 0; base < ns; base += kGroups) {  // one lane group per listed particle
        const int i = base + int(threadIdx.x) / kGroup;
        const int v = i < ns ? seed[i] : ~0;
        if (i < ns && v < 0 && l == 0) mark_it(~v);
        // The fan closed in iteration 0 (else the step ended there), and the walk is range-checked.
        if (group_check(ovc, v, i < ns && v >= 0, l, a.nb, a.degree, mark_it) && l == 0) mark_it(v);
      }
    }
    if (last) {  // the host launches the next batch
      end_rows(kDeviceBatch);
      return;
    }
    if (tail) {
      __syncthreads();
    } else {
      team_sync<Team>();
      if (to_tail) {
        if (blockIdx.x != 0) return;
        if constexpr (SharedTail) {
          extern __shared__ __align__(16) unsigned char s_tail[];
          end_rows(shared_tail<R, Threads, Walls, Mark>(a, j + 1, int(__ldcg(a.claims)), s_tail, keep_row));
          return;
        }
        tail = tail_first = true;
      }
    }
  }
}

}  // namespace

}  // namespace ff::overlap
