// delaunay.flip's sub-step tries as the device runs them (DeviceTries, untangle.h; the kernel is
// flip/cuda.cu's): decide_next, one thread's decision of what untangle_step's loop and
// repair_listed's rounds would do next, from the counters as read_try reads them; and the
// passes of each branch (run_pass), kernel.h's with the lengths, lists and generations that
// decision set, each taking elements i, i + threads, ... of its list (ListSpan: every element
// is taken whatever the grid), and doing nothing outside its branch. The same passes on the
// same lists in the same order as the host's loop, so the same bits.
// FF_HD; nvcc-clean.
#pragma once
#include <cstddef>

#include "stages/delaunay/flip/untangle.h"

namespace ff::delaunay {

// The host's next_gen (Untangle): a new generation of a stamp array, cleared before the
// generations wrap around (by the one deciding thread: once in four billion generations).
FF_HD unsigned next_gen_of(unsigned& gen, unsigned* stamps, std::size_t count) {
  if (++gen == 0xFFFFFFF0u) {
    for (std::size_t i = 0; i < count; ++i) stamps[i] = 0;
    gen = 1;
  }
  return gen;
}

template <class R>
FF_HD void next_touched_gen_of(const TryArgs<R>& a, TryState& s) {
  if (next_gen_of(s.touched_gen, a.touched_edge_stamp, a.E) == 1)
    for (std::size_t i = 0; i < a.n; ++i) a.touched_vertex_stamp[i] = 0;
}

// What repair_listed does after a round's marking (or, `fresh`, after the host's try): another
// round, or at the try's end what the head of untangle_step's loop does; the counter resets and
// generations of what follows. kPhaseStop leaves the counters as the marking left them, for the
// host (which then stops, breaks or throws as its loop would).
template <class R>
FF_HD unsigned decide_next(const TryArgs<R>& a, TryState& s) {
  unsigned* f = a.first_block;
  unsigned* r = a.round_block;
  if (!s.fresh) {
    if (f[kTooLong] || r[kTooLong]) return kPhaseStop;  // read_try throws
    s.flips += r[kRepairFlips];
    if (r[kRepairFlips]) ++s.try_rounds;
    s.last = 1 + s.out;
    s.out = 1 - s.out;
    if (r[kMarked] && s.try_rounds < a.max_rounds) {
      s.list = s.last;
      s.n_list = r[kTroubledCount];
      ResetTry{nullptr, r, false, false}(0);
      s.wg_round = next_gen_of(s.work_gen, a.edge_stamp, a.E);
      return kPhaseRound;
    }
    s.rounds += s.try_rounds;
    s.try_rounds = 0;
  }
  s.fresh = 0;
  const bool through = f[kThrough] != 0;
  if (through && !a.passing) return kPhaseStop;
  s.n_last = r[kTroubledCount];
  s.n_first = f[kTroubledCount];
  unsigned phase;
  if (!r[kInverted] && !through) {
    s.n_active = f[kActiveCount];
    if (s.n_active == 0) return kPhaseStop;  // at the targets
    ResetTry{f, r, true, false}(0);
    s.first_accept = !s.accepted;
    s.accepted = 1;
    s.cur = s.now;
    s.n_copied = s.n_shallowed;
    next_touched_gen_of(a, s);
    s.wg_try = next_gen_of(s.work_gen, a.edge_stamp, a.E);
    s.now = 1 - s.now;
    s.n_shallowed = s.n_active;
    phase = kPhaseAccept;
  } else {
    if (s.halvings == a.max_substeps) return kPhaseStop;  // a rollback
    ++s.halvings;
    s.n_touched_edges = f[kTouchedEdgeCount];
    s.n_touched_vertices = f[kTouchedVertexCount];
    ResetTry{f, r, false, false}(0);
    s.vg = next_gen_of(s.vertex_gen, a.vertex_stamp, a.n);
    s.wg_try = next_gen_of(s.work_gen, a.edge_stamp, a.E);
    next_touched_gen_of(a, s);
    s.cur = s.now;
    phase = kPhaseFail;
  }
  // The new try's first marking and first round (repair_listed).
  ++s.tries;
  s.out = 0;
  s.list = 0;
  s.wg_round = next_gen_of(s.work_gen, a.edge_stamp, a.E);
  return phase;
}

// The passes in the order untangle_step launches them, and the branches they belong to.
enum TryPass : int {
  kPassCopy,            // accepted: V ← the positions (all the first time, else the active lists)
  kPassShallower,       // accepted: ShallowerAndList
  kPassFindMoving,      // failed: FindMoving
  kPassRestoreDeepen,   // failed: RestoreAndDeepen
  kPassEdgesAround,     // failed: EdgesAround the moving particles
  kPassMarkFirst,       // a new try's first marking (MarkListed against V)
  kPassDecide,          // every round: DecideListed
  kPassApply,           // ApplyListed
  kPassMarkRound,       // the round's marking
  kTryPasses
};
FF_HD constexpr bool pass_runs(int pass, unsigned phase) {
  return phase != kPhaseStop &&
         (pass <= kPassShallower   ? phase == kPhaseAccept
          : pass <= kPassEdgesAround ? phase == kPhaseFail
          : pass == kPassMarkFirst   ? phase != kPhaseRound
                                     : true);
}

// Thread i of `threads` in pass `pass`; `sp`: the decided state (device memory on CUDA; a
// round's list length is read from it).
template <class R>
FF_HD void run_pass(int pass, const TryArgs<R>& a, const TryState* sp, std::size_t i, std::size_t threads) {
  const TryState& s = *sp;
  if (!pass_runs(pass, s.phase)) return;
  const std::int32_t* round_list = a.lists[s.list];
  const ListSpan round_span{s.list == 0 ? a.first_block + kTroubledCount : &sp->n_list, threads};
  switch (pass) {
    case kPassCopy: {
      if (s.first_accept) {
        for (std::size_t k = i; k < a.values; k += threads) a.copy_to[k] = a.copy_from[k];
        return;
      }
      CopyListed<R> o = a.copy;
      o.lists[0] = a.active[1 - s.cur];
      o.lists[1] = a.active[s.cur];
      o.counts[0] = s.n_copied;
      o.counts[1] = s.n_active;
      for (std::size_t k = i; k < std::size_t(s.n_copied) + s.n_active; k += threads) o(k);
      return;
    }
    case kPassShallower: {
      ShallowerAndList<R> o = a.shallower;
      o.shallower.active = a.active[s.cur];
      o.shallower.still = a.active[1 - s.cur];
      o.n_active = s.n_active;
      o.around.vertices = a.active[s.cur];
      o.around.span = ListSpan{nullptr, s.n_active};
      o.around.work_gen = s.wg_try;
      o.last.list = a.lists[s.last];
      o.last.span = ListSpan{nullptr, s.n_last};
      o.last.work_gen = s.wg_try;
      for (std::size_t k = i; k < std::size_t(s.n_active) + s.n_last; k += threads) o(k);
      return;
    }
    case kPassFindMoving: {
      FindMoving<R> o = a.find_moving;
      o.edges[0] = a.lists[s.last];
      o.counts[0] = s.n_last;
      o.counts[1] = s.n_first;
      o.counts[2] = s.n_touched_edges;
      o.gen = s.vg;
      o.work_gen = s.wg_try;
      for (std::size_t k = i; k < std::size_t(s.n_last) + s.n_first + s.n_touched_edges; k += threads) o(k);
      return;
    }
    case kPassRestoreDeepen: {
      RestoreAndDeepen<R> o = a.restore_deepen;
      const unsigned moving = a.first_block[kMovingCount];  // FindMoving's, the pass before
      o.restore.n_edges = s.n_touched_edges;
      o.n_restore = std::size_t(s.n_touched_edges) + s.n_touched_vertices;
      o.deepen.span.launched = moving > 0 ? moving : 1;
      o.deepen.active = a.active[s.cur];
      for (std::size_t k = i; k < o.n_restore + moving; k += threads) o(k);
      return;
    }
    case kPassEdgesAround: {
      EdgesAround o = a.around;
      o.span.launched = threads;
      o.work_gen = s.wg_try;
      o(i);
      return;
    }
    case kPassMarkFirst: {
      MarkListed<R> o = a.mark_first;
      o.span.launched = threads;
      o(i);
      return;
    }
    case kPassDecide: {
      DecideListed o = a.decide;
      o.list = round_list;
      o.span = round_span;
      o.touched.gen = s.touched_gen;
      o(i);
      return;
    }
    case kPassApply: {
      ApplyListed o = a.apply;
      o.list = round_list;
      o.span = round_span;
      o.work_gen = s.wg_round;
      o(i);
      return;
    }
    case kPassMarkRound: {
      MarkListed<R> o = a.mark_round;
      o.troubled = a.lists[1 + s.out];
      o.span.launched = threads;
      o(i);
      return;
    }
    default:
      return;
  }
}

}  // namespace ff::delaunay
