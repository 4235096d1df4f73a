// delaunay.flip's sub-step tries (untangle.h): what the untangling's loop does next and the
// passes of each branch, stated once for both backends. decide_next decides from the counters of
// the last marking: another repair round, an accepted try, a failed one, or a stop (at the
// targets, a rollback, a throw). The pass functions (copy_pass & co.) build each branch's passes,
// kernel.h's functors, from TryArgs with the lengths, lists and generations the decision set. The
// host's loop (Untangle::untangle_step: the CPU, and CUDA until the device takes over) calls
// decide_next on the counters it reads and launches the passes through the backend's element
// loops; the device's tries (DeviceTries, flip/cuda.cu: a cooperative kernel) call decide_next
// on the counters in place from one thread and run the passes over the grid (run_pass; ListSpan:
// every element is taken whatever the grid). So the same decisions and the same passes on the
// same lists, in the same order: the same bits.
// FF_HD; nvcc-clean.
#pragma once
#include <cstddef>
#include <cstdint>

#include "stages/delaunay/flip/kernel.h"

namespace ff::delaunay {

// The stage's parameters the untangling obeys (FlipParams).
struct UntangleLimits {
  std::int64_t max_rounds;    // repair rounds a try
  std::int64_t max_substeps;  // halvings a step before it is rolled back
  bool passing;               // passing: substep (a reversed edge is halved, not rolled back)
};

// The untangling's variables in a step: where its loop is (the host's, or the device's, which
// gets it and hands it back), what a decision set for the passes after it, and the step's
// statistics.
struct TryState {
  std::int64_t halvings, tries, rounds;  // the step's (metrics substeps, substep_tries; Result)
  std::int64_t try_rounds;               // the current try's rounds that flipped
  unsigned flips;                        // the step's repair flips
  unsigned now, n_shallowed, accepted;   // active_[now]: depth > 0; active_[1 - now]: the last Shallower's
  unsigned work_gen, vertex_gen, touched_gen;
  unsigned last;     // which list the last marking's troubled edges are in: 1 + trouble_ index
  unsigned decided;  // 1: `phase` is decided and its passes are still to run (the host hands over)
  unsigned stop;     // TryStop: why decide_next stopped
  unsigned clear;    // TryClear: the stamp arrays whose generations wrapped in the decision
  // Set by decide_next for the passes after it (TryPhase; lengths and generations).
  unsigned phase, out, list, n_list;
  unsigned n_active, n_last, n_first, n_touched_edges, n_touched_vertices;
  unsigned first_accept, cur, n_copied;  // an accepted try: V ← positions; active_[cur]
  unsigned wg_try, wg_round, vg;
};
enum TryPhase : unsigned { kPhaseRound = 0, kPhaseAccept = 1, kPhaseFail = 2, kPhaseStop = 3 };
enum TryStop : unsigned {
  kStopNone,
  kStopTargets,   // nothing inverted or reversed and every particle at its target
  kStopThrough,   // a reversed edge without `passing: substep`: a rollback
  kStopSubsteps,  // still in trouble after max_substeps halvings: a rollback
  kStopTooLong,   // a triangle that does not close (the host throws: throw_if_too_long)
};
// The stamp arrays (claim) a new generation starts in; cleared before the generations wrap around.
enum TryClear : unsigned {
  kClearEdges = 1,     // edge_stamp (work lists)
  kClearVertices = 2,  // vertex_stamp (FindMoving)
  kClearTouched = 4,   // touched_edge_stamp and touched_vertex_stamp (TouchLog)
};

// A new generation of a stamp array; `clear` gets `which` when the array must be cleared first
// (once in four billion generations).
FF_HD unsigned next_gen_of(unsigned& gen, unsigned& clear, unsigned which) {
  if (++gen == 0xFFFFFFF0u) {
    clear |= which;
    gen = 1;
  }
  return gen;
}

// The counters a decision leaves reset for the passes after it (kernel.h, ResetTry): a round's
// marking counts anew; a try counts its lists anew (an accepted one its active particles too).
FF_HD ResetTry phase_reset(unsigned phase, unsigned* first_block, unsigned* round_block) {
  return ResetTry{phase == kPhaseRound ? nullptr : first_block, round_block, phase == kPhaseAccept, false};
}

// What the untangling does after a round's marking, from the counters it left (f: the try's
// first marking and lists, r: the round's; as read_try reads them): another round while
// something is marked (at most max_rounds flipping rounds a try), else at the try's end: a stop,
// an accepted try (nothing inverted or reversed: the positions become V and the particles go a
// level shallower) or a failed one (the troubled particles go a level deeper). Sets the state's
// counters, lists and generations for the passes of the branch (run_pass; untangle_step), and
// writes nothing else: the caller resets the counters (phase_reset) and clears the stamps
// (s.clear) on its backend. A stop leaves the counters as the marking left them.
FF_HD unsigned decide_next(const unsigned* f, const unsigned* r, const UntangleLimits& limits, TryState& s) {
  s.clear = 0;
  if (f[kTooLong] || r[kTooLong]) {
    s.stop = kStopTooLong;
    return kPhaseStop;
  }
  s.flips += r[kRepairFlips];
  if (r[kRepairFlips]) ++s.try_rounds;
  s.last = 1 + s.out;
  s.out = 1 - s.out;
  if (r[kMarked] && s.try_rounds < limits.max_rounds) {
    s.list = s.last;
    s.n_list = r[kTroubledCount];
    s.wg_round = next_gen_of(s.work_gen, s.clear, kClearEdges);
    return kPhaseRound;
  }
  s.rounds += s.try_rounds;
  s.try_rounds = 0;
  const bool through = f[kThrough] != 0;
  if (through && !limits.passing) {
    s.stop = kStopThrough;
    return kPhaseStop;
  }
  s.n_last = r[kTroubledCount];
  s.n_first = f[kTroubledCount];
  unsigned phase;
  if (!r[kInverted] && !through) {
    s.n_active = f[kActiveCount];
    if (s.n_active == 0) {
      s.stop = kStopTargets;
      return kPhaseStop;
    }
    s.first_accept = !s.accepted;
    s.accepted = 1;
    s.cur = s.now;
    s.n_copied = s.n_shallowed;
    next_gen_of(s.touched_gen, s.clear, kClearTouched);  // V's topology is the one now
    s.wg_try = next_gen_of(s.work_gen, s.clear, kClearEdges);
    s.now = 1 - s.now;
    s.n_shallowed = s.n_active;
    phase = kPhaseAccept;
  } else {
    if (s.halvings == limits.max_substeps) {
      s.stop = kStopSubsteps;
      return kPhaseStop;
    }
    ++s.halvings;
    s.n_touched_edges = f[kTouchedEdgeCount];
    s.n_touched_vertices = f[kTouchedVertexCount];
    s.vg = next_gen_of(s.vertex_gen, s.clear, kClearVertices);
    s.wg_try = next_gen_of(s.work_gen, s.clear, kClearEdges);
    next_gen_of(s.touched_gen, s.clear, kClearTouched);
    s.cur = s.now;
    phase = kPhaseFail;
  }
  // The new try's first marking and first round.
  ++s.tries;
  s.out = 0;
  s.list = 0;
  s.wg_round = next_gen_of(s.work_gen, s.clear, kClearEdges);
  return phase;
}

// What the passes need that stays put during a step (Untangle::try_args; the host rebuilds it
// when the positions' storage changes): the passes of kernel.h with what is known before a try
// (the lengths, list choices and generations decide_next sets are filled in by the pass
// functions below), the lists, the stamps, the limits.
template <class R>
struct TryArgs {
  MarkListed<R> mark_first, mark_round;
  DecideListed decide;
  ApplyListed apply;
  FindMoving<R> find_moving;
  RestoreAndDeepen<R> restore_deepen;
  EdgesAround around;
  ShallowerAndList<R> shallower;
  CopyListed<R> copy;
  const R* copy_from;  // the first acceptance: V ← the positions, every value
  R* copy_to;
  std::size_t values;
  std::int32_t* lists[3];   // first_, trouble_[0], trouble_[1]
  std::int32_t* active[2];  // active_
  unsigned* first_block;
  unsigned* round_block;
  unsigned *edge_stamp, *vertex_stamp, *touched_edge_stamp, *touched_vertex_stamp;
  std::size_t n, E;
  UntangleLimits limits;
};

// decide_next on the device (one thread of flip/cuda.cu's kernel), on the counters in place;
// the resets and clears it asks for are made here, before the passes. A decision the host
// made and handed over (s.decided) is taken as it is.
template <class R>
FF_HD unsigned decide_next(const TryArgs<R>& a, TryState& s) {
  if (s.decided) {
    s.decided = 0;
    return s.phase;
  }
  const unsigned phase = decide_next(a.first_block, a.round_block, a.limits, s);
  if (phase == kPhaseStop) return phase;
  phase_reset(phase, a.first_block, a.round_block)(0);
  if (s.clear & kClearEdges)
    for (std::size_t i = 0; i < a.E; ++i) a.edge_stamp[i] = 0;
  if (s.clear & kClearVertices)
    for (std::size_t i = 0; i < a.n; ++i) a.vertex_stamp[i] = 0;
  if (s.clear & kClearTouched) {
    for (std::size_t i = 0; i < a.E; ++i) a.touched_edge_stamp[i] = 0;
    for (std::size_t i = 0; i < a.n; ++i) a.touched_vertex_stamp[i] = 0;
  }
  return phase;
}

// The passes of each branch, as both backends launch them: kernel.h's functors from TryArgs
// with the lengths, lists and generations decide_next set, and how many elements each loop
// takes (`elements`; each functor takes element k of its loop). Where a list's length is on
// the backend (ListSpan), `launched` is what the caller launches over: the device's grid, the
// host's guess of the length (every element is taken whatever it is).
template <class F>
struct TryLoop {
  F f;
  std::size_t elements;
};
// Accepted: V ← the positions of the active particles and of the last Shallower's (after the
// first acceptance; the first one copies every value).
template <class R>
FF_HD TryLoop<CopyListed<R>> copy_pass(const TryArgs<R>& a, const TryState& s) {
  CopyListed<R> o = a.copy;
  o.lists[0] = a.active[1 - s.cur];
  o.lists[1] = a.active[s.cur];
  o.counts[0] = s.n_copied;
  o.counts[1] = s.n_active;
  return {o, std::size_t(s.n_copied) + s.n_active};
}
// Accepted: Shallower, and the next marking's work list: the edges around the particles it
// moves and the last troubled ones.
template <class R>
FF_HD TryLoop<ShallowerAndList<R>> shallower_pass(const TryArgs<R>& a, const TryState& s) {
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
  return {o, std::size_t(s.n_active) + s.n_last};
}
// Failed: who goes deeper, judged at the ends of the last troubled edges, of the first
// marking's and of the edges the try's flips made (FindMoving); those edges go to the next
// try's work list on the way.
template <class R>
FF_HD TryLoop<FindMoving<R>> find_moving_pass(const TryArgs<R>& a, const TryState& s) {
  FindMoving<R> o = a.find_moving;
  o.edges[0] = a.lists[s.last];
  o.counts[0] = s.n_last;
  o.counts[1] = s.n_first;
  o.counts[2] = s.n_touched_edges;
  o.gen = s.vg;
  o.work_gen = s.wg_try;
  return {o, std::size_t(s.n_last) + s.n_first + s.n_touched_edges};
}
// Failed: the records the try's flips changed back to V's, and in the same loop the moving
// particles go deeper (`moving` of them: FindMoving's count, or a guess of it).
template <class R>
FF_HD TryLoop<RestoreAndDeepen<R>> restore_deepen_pass(const TryArgs<R>& a, const TryState& s, std::size_t moving) {
  RestoreAndDeepen<R> o = a.restore_deepen;
  o.restore.n_edges = s.n_touched_edges;
  o.n_restore = std::size_t(s.n_touched_edges) + s.n_touched_vertices;
  o.deepen.span.launched = moving > 0 ? moving : 1;
  o.deepen.active = a.active[s.cur];
  return {o, o.n_restore + moving};
}
// Failed: the next marking's work list gets the edges around the moving particles.
template <class R>
FF_HD TryLoop<EdgesAround> edges_around_pass(const TryArgs<R>& a, const TryState& s, std::size_t launched) {
  EdgesAround o = a.around;
  o.span.launched = launched;
  o.work_gen = s.wg_try;
  return {o, launched};
}
// A new try's first marking (MarkListed against V) of its work list.
template <class R>
FF_HD TryLoop<MarkListed<R>> mark_first_pass(const TryArgs<R>& a, std::size_t launched) {
  MarkListed<R> o = a.mark_first;
  o.span.launched = launched;
  return {o, launched};
}
// A round decides and flips among the last marking's troubled edges: the first marking's (its
// length on the backend) or the last round's (n_list; `n_list_at`: where the backend reads it,
// or null: `launched` is the length).
template <class R>
FF_HD ListSpan round_span(const TryArgs<R>& a, const TryState& s, const unsigned* n_list_at, std::size_t launched) {
  return ListSpan{s.list == 0 ? a.first_block + kTroubledCount : n_list_at, launched};
}
template <class R>
FF_HD TryLoop<DecideListed> decide_pass(const TryArgs<R>& a, const TryState& s, ListSpan span) {
  DecideListed o = a.decide;
  o.list = a.lists[s.list];
  o.span = span;
  o.touched.gen = s.touched_gen;
  return {o, span.launched};
}
template <class R>
FF_HD TryLoop<ApplyListed> apply_pass(const TryArgs<R>& a, const TryState& s, ListSpan span) {
  ApplyListed o = a.apply;
  o.list = a.lists[s.list];
  o.span = span;
  o.work_gen = s.wg_round;
  return {o, span.launched};
}
// The round's marking: the troubled edges and those around each flip, listed in trouble_[out].
template <class R>
FF_HD TryLoop<MarkListed<R>> mark_round_pass(const TryArgs<R>& a, const TryState& s, std::size_t launched) {
  MarkListed<R> o = a.mark_round;
  o.troubled = a.lists[1 + s.out];
  o.span.launched = launched;
  return {o, launched};
}

// The passes in the order the branches launch them, and the branches they belong to.
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

// Thread i of `threads` of the device's grid: its elements i, i + threads, ... of a loop.
template <class F>
FF_HD void run_loop(const TryLoop<F>& l, std::size_t i, std::size_t threads) {
  for (std::size_t k = i; k < l.elements; k += threads) l.f(k);
}
// Thread i of `threads` in pass `pass` on the device; `sp`: the decided state (device memory;
// a round's list length is read from it). The passes over lists whose lengths are on the
// device are launched over the grid; FindMoving's count is read, the pass before.
template <class R>
FF_HD void run_pass(int pass, const TryArgs<R>& a, const TryState* sp, std::size_t i, std::size_t threads) {
  const TryState& s = *sp;
  if (!pass_runs(pass, s.phase)) return;
  switch (pass) {
    case kPassCopy:
      if (s.first_accept) {
        for (std::size_t k = i; k < a.values; k += threads) a.copy_to[k] = a.copy_from[k];
        return;
      }
      return run_loop(copy_pass(a, s), i, threads);
    case kPassShallower:
      return run_loop(shallower_pass(a, s), i, threads);
    case kPassFindMoving:
      return run_loop(find_moving_pass(a, s), i, threads);
    case kPassRestoreDeepen:
      return run_loop(restore_deepen_pass(a, s, a.first_block[kMovingCount]), i, threads);
    case kPassEdgesAround:
      return run_loop(edges_around_pass(a, s, threads), i, threads);
    case kPassMarkFirst:
      return run_loop(mark_first_pass(a, threads), i, threads);
    case kPassDecide:
      return run_loop(decide_pass(a, s, round_span(a, s, &sp->n_list, threads)), i, threads);
    case kPassApply:
      return run_loop(apply_pass(a, s, round_span(a, s, &sp->n_list, threads)), i, threads);
    case kPassMarkRound:
      return run_loop(mark_round_pass(a, s, threads), i, threads);
    default:
      return;
  }
}

}  // namespace ff::delaunay
