// delaunay.flip's sub-step untangling (`on_unrepairable: substep`; Porro et al. §3,
// "intermediate position"): what the stage does with triangles no single flip repairs, and
// with `passing: substep` with particles that passed each other, so that the step still ends at
// the integrator's targets instead of being rolled back. The stage (stage.h) calls Untangle::run
// when detect_inversion left it the positions at which the triangulation is valid (status
// kPrevKept); the per-element passes are kernel.h's, compiled for the CPU and CUDA alike.
//
// The triangulation is valid at V = position_prev and the integrator's targets T are in
// `position`. Each particle has a depth d (0 at first) and is tried at V + 2^-d (T − V)
// (place_at_depth). While triangles stay inverted after the repair rounds, the particles of
// those triangles go a level deeper (half as far from V) and the rounds run again from V's
// topology; once nothing is inverted the positions become the new V and every particle goes a
// level shallower: twice as far along the rest of its way as the try that worked (a particle
// that needed k halvings to pass a neighbour tries k − 1 next, not 0: going back to T at once
// would cost the k halvings again at every sub-step). Each deepening counts; after max_substeps
// the step is rolled back. The last positions tried are T itself (depth 0 copies it), so an
// accepted step ends exactly at the integrator's targets. An edge whose vector reverses between
// V and an attempt (r⁰·r¹ < 0: its particles passed each other) rolls back, or with `passing:
// substep` counts as not repaired: its two particles are halved too. Points on straight paths
// that miss each other by b > 0 give r⁰·r¹ > 0 once the remaining relative move is below ~b, so
// only a collision (b = 0) runs out of max_substeps.
//
// Every place in trouble is halved in the same try, and a try costs what the trouble costs:
// only the first try marks every edge; after it each try marks the edges that can have changed
// status (kernel.h, MarkListed): the last try's troubled edges, the first marking's (at V's
// topology, which a failed try restores) and those around the particles that moved (deepened,
// or shallower after an accepted try); a flip saves V's value of each record it is the first to
// touch (TouchLog), so a failed try puts back only those and an accepted one copies nothing (no
// copy of the whole topology either); V is updated for the active particles (depth > 0) only,
// after the first acceptance. The result is the one full passes give, bit for bit (the same
// marks everywhere, hence the same flips). The lists' loops run over guesses of their lengths
// (ListSpan), so the host waits once a try when one repair round suffices. Metrics: substeps
// (halvings), substep_tries (repair passes), substep_depth (the deepest particle's halvings),
// substep_particles (particles halved at least once).
//
// On CUDA the tries after the first failed one run on the device (DeviceTries, flip/cuda.cu):
// one cooperative kernel in which one thread, reading the counters as read_try does, decides
// what the host's loop would (the branches below, the rounds of repair_listed; flip/tries.h)
// and the grid runs that branch's passes; the host reads the counters once when it stops (at the
// try end where the host would stop, break or throw) and carries on from there. Same passes on
// the same lists, so the same bits; the CPU runs the host loop.
// nvcc-clean: included by stage.h, which both backends compile.
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/backend/exec.h"
#include "core/backend/memory.h"
#include "core/stage/stage.h"
#include "stages/delaunay/common/host.h"
#include "stages/delaunay/flip/kernel.h"

namespace ff::delaunay {

// The stage's parameters the untangling obeys (FlipParams).
struct UntangleLimits {
  std::int64_t max_rounds;    // repair rounds a try
  std::int64_t max_substeps;  // halvings a step before it is rolled back
  bool passing;               // passing: substep (a reversed edge is halved, not rolled back)
};

template <class R>
struct UntangleLoops {
  ElementLoop<MarkListed<R>> mark_listed;
  ElementLoop<DecideListed> decide_listed;
  ElementLoop<ApplyListed> apply_listed;
  ElementLoop<EdgesAround> edges_around;
  ElementLoop<FindMoving<R>> find_moving;
  ElementLoop<RestoreAndDeepen<R>> restore_deepen;
  ElementLoop<ShallowerAndList<R>> shallower_list;
  ElementLoop<CopyListed<R>> copy_listed;
  ElementLoop<ResetTry> reset;
};

// The plain element loops of the backend object (CpuExec or CudaExec) that stage.h is compiled
// for (core/stage/stage_registration.h).
template <class R, class Exec>
UntangleLoops<R> untangle_loops(Exec) {
  return {&Exec::template for_each<MarkListed<R>>,       &Exec::template for_each<DecideListed>,
          &Exec::template for_each<ApplyListed>,         &Exec::template for_each<EdgesAround>,
          &Exec::template for_each<FindMoving<R>>,       &Exec::template for_each<RestoreAndDeepen<R>>,
          &Exec::template for_each<ShallowerAndList<R>>, &Exec::template for_each<CopyListed<R>>,
          &Exec::template for_each<ResetTry>};
}

// What the device's tries (DeviceTries) start from and hand back: untangle_step's variables at a
// try's end (the host's copies are updated from it), and the device's own bookkeeping.
struct TryState {
  std::int64_t halvings, tries, rounds;  // rounds: those of the tries run on the device
  std::int64_t try_rounds;               // the current try's rounds that flipped
  unsigned flips;                        // made on the device
  unsigned now, n_shallowed, accepted;   // untangle_step's
  unsigned work_gen, vertex_gen, touched_gen;
  unsigned last;   // which list the last marking's troubled edges are in: 1 + trouble_ index
  unsigned fresh;  // 1: the try that just ended was the host's (its rounds are counted)
  // Set by the deciding kernel for the passes after it (TryPhase; lengths and generations).
  unsigned phase, out, list, n_list;
  unsigned n_active, n_last, n_first, n_touched_edges, n_touched_vertices;
  unsigned first_accept, cur, n_copied;  // an accepted try: V ← positions; active_[cur]
  unsigned wg_try, wg_round, vg;
};
enum TryPhase : unsigned { kPhaseRound = 0, kPhaseAccept = 1, kPhaseFail = 2, kPhaseStop = 3 };

// Everything the device's passes need that stays put while they run: the passes of kernel.h
// built on the host with what is known there (the lengths, list choices and generations the
// deciding kernel sets are filled in on the device), the lists, the stamps, the limits.
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
  std::int64_t max_rounds, max_substeps;
  bool passing;
};

// The tries on the device (CUDA: flip/cuda.cu); null on the CPU. run: from a try's end that
// untangle_step would follow with another try, the tries until one ends where it would not (or
// a marking finds a triangle that does not close: read_try throws); `counters` gets both counter
// blocks. False: the device cannot run them (its kernel does not fit); the host carries on.
template <class R>
struct DeviceTries {
  virtual ~DeviceTries() = default;
  virtual bool run(const TryArgs<R>& a, TryState& s, unsigned* counters, CUstream_st* st) = 0;
};
template <class R>
std::unique_ptr<DeviceTries<R>> device_tries(const CpuExec&) {
  return nullptr;
}
template <class R>
std::unique_ptr<DeviceTries<R>> device_tries(const CudaExec&);

// The untangling of one stage object: its lists, stamps and copies of T and of V's topology
// (allocated on the first run, kept from step to step), and the loops of its backend.
template <class R>
class Untangle {
 public:
  template <class Exec>
  Untangle(UntangleLimits limits, Exec exec)
      : limits_(limits),
        where_(Exec::where),
        loops_(untangle_loops<R>(exec)),
        mem_(exec.memory()),
        target_(exec),
        topology_(exec),
        depth_(exec),
        sub_(exec),
        first_(exec),
        trouble_{Scratch<std::int32_t>(exec), Scratch<std::int32_t>(exec)},
        work_(exec),
        touched_edges_(exec),
        touched_vertices_(exec),
        moving_(exec),
        active_{Scratch<std::int32_t>(exec), Scratch<std::int32_t>(exec)},
        edge_stamp_(exec),
        vertex_stamp_(exec),
        touched_edge_stamp_(exec),
        touched_vertex_stamp_(exec),
        halved_stamp_(exec),
        device_(device_tries<R>(exec)) {}

  // What a step's untangling did: ok (the particles at T, position_prev = T, the triangulation
  // valid there, status kPrevKept cleared) or a rollback request (`position` holds T again), and
  // the repair flips and rounds it made, for the stage's metrics and Lawson's candidates.
  struct Result {
    Outcome outcome;
    unsigned flips = 0;
    std::int64_t rounds = 0;
  };
  // `m`: the triangulation on the stage's side; `go`: the stage's flip decisions (one byte an
  // edge, shared with its plain repair rounds: the two never run in the same call).
  Result run(StepContext& ctx, const Mesh& m, std::uint8_t* go) {
    flips_ = 0;
    rounds_ = 0;
    Outcome out = untangle_step(ctx, m, go);
    return {std::move(out), flips_, rounds_};
  }

 private:
  using SubTally = std::array<unsigned, kSubstepCounters>;

  // A new generation for a stamp array (MarkListed & co.: claim): the array is cleared before
  // its generations wrap around.
  unsigned next_gen(unsigned& gen, unsigned* stamps, std::size_t count, CUstream_st* st) {
    if (++gen == 0xFFFFFFF0u) {
      mem_.fill(stamps, 0, count * sizeof(unsigned), st);
      gen = 1;
    }
    return gen;
  }
  // sub_'s two blocks (kernel.h, ResetTry): the try's first marking and lists, its rounds.
  unsigned* first_block() { return sub_.ptr(); }
  unsigned* round_block() { return sub_.ptr() + kSubstepCounters; }
  void reset_try(bool active, bool step, CUstream_st* st) {
    loops_.reset(1, ResetTry{first_block(), round_block(), active, step}, st);
  }

  // Reads both blocks: the round block's marking counters (after the last round) with the
  // first marking's reversed edges and the first block's lists and statistics; the lengths of
  // the first and the last troubled lists into n_first_ / n_last_.
  SubTally read_try(State& s, CUstream_st* st) { return tally(s, sub_.read(st).data(), st); }
  SubTally tally(State& s, const unsigned* both, CUstream_st* st) {
    const unsigned* f = both;
    const unsigned* r = f + kSubstepCounters;
    throw_if_too_long(s, where_, mem_, f[kTooLong], f[kTooLongAt], st, "delaunay.flip");
    throw_if_too_long(s, where_, mem_, r[kTooLong], r[kTooLongAt], st, "delaunay.flip");
    SubTally h;
    std::copy(f, f + kSubstepCounters, h.begin());
    std::copy(r, r + kInversionCounters, h.begin());
    h[kThrough] = f[kThrough];
    h[kThroughAt] = f[kThroughAt];
    n_first_ = f[kTroubledCount];
    n_last_ = r[kTroubledCount];
    return h;
  }

  // The repair rounds of one try on lists, after reset_try. `work` (`span`; null: every edge)
  // holds every edge that can be troubled at V's topology and the positions now (see
  // untangle_step); they are marked with the r⁰·r¹ test against V (`prev`), the troubled ones
  // listed (first_), then each round decides and flips among the last troubled edges and
  // re-marks those and the edges around each flip (trouble_). The first round is launched right
  // after the first marking, before the host knows whether anything is marked (with nothing
  // marked it flips nothing and re-marks the same edges): one host read a try when a round
  // suffices. Only rounds that flip count (as rounds run only while something is marked, and
  // then flip). Leaves the last troubled list in last_ / n_last_ (every edge whose mark is 1 is
  // in it), the first in first_ / n_first_, and returns read_try's counters. `go`: the flip
  // decisions (Untangle::run).
  SubTally repair_listed(State& s, const Mesh& m, std::uint8_t* go, const Points<R>& pts, const R* prev,
                         const std::int32_t* work, ListSpan span, CUstream_st* st) {
    std::uint8_t* mark = s.field(fields::flip_mark).data<std::uint8_t>(where_);
    const std::size_t E = edge_count(s.n());
    unsigned* f = first_block();
    unsigned* r = round_block();
    std::int32_t* first = first_.get(E);
    loops_.mark_listed(span.launched, MarkListed<R>{{m, pts, prev, mark, f}, work, span, first, f}, st);
    ++tries_;
    // The rounds. The first one's lists have lengths only the backend knows: launched over
    // guesses (ListSpan; the troubled edges are a small part of the marked ones even when every
    // edge is marked, and a short guess only makes each thread take more); later ones over the
    // lengths read.
    const std::int32_t* list = first;
    ListSpan listed{f + kTroubledCount, std::max<std::size_t>(1, std::min({E, span.launched, kFirstRoundGuess}))};
    std::int64_t rounds = 0;
    int out = 0;
    SubTally h{};
    bool first_round = true;
    while (true) {
      if (!first_round) reset_round(st);
      const unsigned wg = next_gen(work_gen_, edge_stamp_.get(E), E, st);
      std::int32_t* w = work_.get(E);
      const std::size_t n = listed.launched;
      loops_.decide_listed(n, DecideListed{{m, mark, go, r, kRepairFlips}, list, listed, touch_log(s)}, st);
      loops_.apply_listed(n, ApplyListed{m, go, list, listed, w, edge_stamp_.get(E), wg, r + kWorkCount}, st);
      // At most the troubled edges and four more a flip; the length is on the backend.
      const std::size_t bound = std::min<std::size_t>(E, 5 * n);
      std::int32_t* t = trouble_[out].get(E);
      loops_.mark_listed(bound, MarkListed<R>{{m, pts, nullptr, mark, r}, w, ListSpan{r + kWorkCount, bound}, t, r},
                         st);
      h = read_try(s, st);
      flips_ += h[kRepairFlips];
      if (h[kRepairFlips]) ++rounds;
      last_ = t;
      out = 1 - out;
      first_round = false;
      if (!h[kMarked] || rounds >= limits_.max_rounds) break;
      list = t;
      listed = ListSpan{nullptr, n_last_};
    }
    rounds_ += rounds;
    return h;
  }
  void reset_round(CUstream_st* st) { loops_.reset(1, ResetTry{nullptr, round_block(), false, false}, st); }

  // The step's untangling (the top of this file): tries until the particles are at T with
  // nothing inverted (or reversed), or requests a rollback (max_substeps; a reversed edge
  // without `passing: substep`).
  Outcome untangle_step(StepContext& ctx, const Mesh& m, std::uint8_t* go) {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    const std::size_t n = s.n(), E = edge_count(n);
    const std::size_t bytes = s.field(ff::fields::position).bytes();
    const auto box = PeriodicBox<double>::make(s.box.L);
    R* target = target_.get(2 * n);
    std::uint32_t* depth = depth_.get(n);
    unsigned* c = first_block();
    bool announced = false, accepted = false;
    bool from_device = false;  // h is the device's: the head stops (else the host runs a try)
    std::int64_t halvings = 0;
    tries_ = 0;
    const unsigned step_gen = next_gen(step_gen_, halved_stamp_.get(n), n, st);
    next_touched_gen(n, st);
    int now = 0;                  // active_[now]: particles with depth > 0
    std::size_t n_shallowed = 0;  // active_[1 - now]: the ones the last Shallower moved
    const auto metrics = [&](const SubTally& t) {
      ctx.metrics.set("substeps", double(halvings));
      ctx.metrics.set("substep_tries", double(tries_));
      ctx.metrics.set("substep_depth", double(~t[kDepthNot]));
      ctx.metrics.set("substep_particles", double(t[kHalvedCount]));
    };
    const auto stop = [&](std::string why, std::vector<std::uint64_t> who, const SubTally& t) {
      if (announced) mem_.copy(s.field(ff::fields::position).data<R>(ctx), target, bytes, st);  // as detect left it
      metrics(t);
      return Outcome::request_rollback("delaunay.flip: " + why + "; the step is retried with a smaller time step",
                                       std::move(who));
    };
    // The first try: every edge, at V's topology and the targets.
    reset_try(true, true, st);
    SubTally h = repair_listed(s, m, go, Points<R>{s.field(ff::fields::position).data<R>(where_), box},
                               s.field(fields::position_prev).data<R>(where_), nullptr, ListSpan{nullptr, E}, st);
    while (true) {
      if (h[kThrough] && !limits_.passing) {
        auto ids = edge_vertices(s, where_, mem_, int(h[kThroughAt]), st);
        return stop("particles " + list_ids(ids) + " passed through each other between intermediate positions (r0.r1 < 0)",
                    ids, h);
      }
      R* x = s.field(ff::fields::position).data<R>(ctx);
      R* v = s.field(fields::position_prev).data<R>(ctx);
      std::int32_t* w = work_.get(E);
      std::int32_t* active = active_[now].get(n);
      std::int32_t* other = active_[1 - now].get(n);
      const std::size_t n_active = h[kActiveCount];
      // The next marking's work list is built on the backend; its loop is launched over a
      // guess of its length (ListSpan): the host reads counters once a marking, nothing else.
      std::size_t guess = 0;
      const bool valid = !h[kInverted] && !h[kThrough];
      if (valid) {
        if (n_active == 0) break;  // at the targets
      } else {
        if (halvings == limits_.max_substeps) {
          if (h[kThrough]) {
            auto ids = edge_vertices(s, where_, mem_, int(h[kThroughAt]), st);
            return stop("particles " + list_ids(ids) + " passed through each other (r0.r1 < 0) even after halving the "
                            "moves " + std::to_string(halvings) + " time(s) (max_substeps)",
                        ids, h);
          }
          return stop(std::to_string(h[kInverted]) + " inverted triangle(s) remain after halving the moves " +
                          std::to_string(halvings) + " time(s) (max_substeps)",
                      {}, h);
        }
        if (!announced) {  // the first intermediate position: keep T and V for a rollback
          ctx.will_write(ff::fields::position);
          ctx.will_write(fields::position_prev);
          announced = true;
          x = s.field(ff::fields::position).data<R>(ctx);
          v = s.field(fields::position_prev).data<R>(ctx);
          mem_.copy(target, x, bytes, st);
          mem_.fill(depth, 0, n * sizeof(std::uint32_t), st);
        }
      }
      // CUDA: the device runs the tries from here to the next try's end that the head above
      // stops at (announced: every try after the first failed one).
      if (device_ && announced && !from_device) {
        TryState ts = try_state(E, halvings, accepted, now, n_shallowed);
        if (device_->run(try_args(s, m, go, x, v, box, step_gen, bytes / sizeof(R)), ts, device_counters_.data(), st)) {
          halvings = ts.halvings;
          tries_ = ts.tries;
          flips_ += ts.flips;
          rounds_ += ts.rounds;
          accepted = ts.accepted != 0;
          now = int(ts.now);
          n_shallowed = ts.n_shallowed;
          work_gen_ = ts.work_gen;
          vertex_gen_ = ts.vertex_gen;
          touched_gen_ = ts.touched_gen;
          last_ = trouble_[ts.last - 1].get(E);
          h = tally(s, device_counters_.data(), st);
          from_device = true;
          continue;
        }
        device_.reset();  // not on this device: the host's loop from here on
      }
      from_device = false;
      if (valid) {
        reset_try(true, false, st);
        // Valid here: the next reference. Before the first acceptance every particle is at its
        // target, away from V; after it only the active particles and the ones the last
        // Shallower moved have left V.
        if (!accepted) {
          mem_.copy(v, x, bytes, st);
          accepted = true;
        } else {
          loops_.copy_listed(n_shallowed + n_active, CopyListed<R>{{other, active}, {n_shallowed, n_active}, x, v}, st);
        }
        next_touched_gen(n, st);  // V's topology is the one now: no records to keep
        // Shallower, and the next marking's work list: the edges around the particles it moves
        // and the last troubled ones.
        const unsigned wg = next_gen(work_gen_, edge_stamp_.get(E), E, st);
        loops_.shallower_list(
            n_active + n_last_,
            ShallowerAndList<R>{Shallower<R>{Points<R>{v, box}, target, x, active, depth, other, c},
                                n_active,
                                EdgesAround{m, active, ListSpan{nullptr, n_active}, w, edge_stamp_.get(E), wg, c},
                                ListEdges{last_, ListSpan{nullptr, n_last_}, w, edge_stamp_.get(E), wg, c + kWorkCount}},
            st);
        now = 1 - now;
        n_shallowed = n_active;
        guess = n_last_ + 12 * n_shallowed;
      } else {
        ++halvings;
        reset_try(false, false, st);
        // Who goes deeper: judged at the ends of the last troubled edges, of the first
        // marking's and of the edges the try's flips made.
        // The first and last troubled edges go to the next try's work list on the way.
        const unsigned vg = next_gen(vertex_gen_, vertex_stamp_.get(n), n, st);
        const unsigned wg = next_gen(work_gen_, edge_stamp_.get(E), E, st);
        std::int32_t* moving = moving_.get(n);
        const std::size_t n_touched = h[kTouchedEdgeCount];
        loops_.find_moving(n_last_ + n_first_ + n_touched,
                           FindMoving<R>{MovingRule<R>{m, Points<R>{x, box}, Points<R>{v, box}},
                                         {last_, first_.get(E), touched_edges_.get(E)},
                                         {n_last_, n_first_, n_touched},
                                         moving,
                                         vertex_stamp_.get(n),
                                         vg,
                                         c,
                                         w,
                                         edge_stamp_.get(E),
                                         wg},
                           st);
        // The flips made for the positions farther out need not be valid nearer V (a flipped
        // triangle can stay inverted however close to V its vertices come): repair from V's.
        // In the same launch the moving particles go deeper: at most both ends of those edges,
        // the count is on the backend.
        const std::size_t n_restore = h[kTouchedEdgeCount] + h[kTouchedVertexCount];
        const std::size_t n_moving = std::min<std::size_t>(n, 2 * (n_last_ + n_first_ + n_touched));
        const ListSpan moved{c + kMovingCount, n_moving};
        loops_.restore_deepen(n_restore + n_moving,
                              RestoreAndDeepen<R>{restore_records(s, h), n_restore,
                                                  Deepen<R>{Points<R>{v, box}, target, x, moving, moved, depth, active,
                                                            halved_stamp_.get(n), step_gen, c}},
                              st);
        next_touched_gen(n, st);
        loops_.edges_around(n_moving, EdgesAround{m, moving, moved, w, edge_stamp_.get(E), wg, c}, st);
        guess = n_first_ + n_last_ + 12 * std::size_t(h[kInverted] + h[kThrough]);
      }
      const std::size_t launched = std::max<std::size_t>(1, std::min(E, guess));
      h = repair_listed(s, m, go, Points<R>{x, box}, v, w, ListSpan{c + kWorkCount, launched}, st);
    }
    // position_prev ← position (= T): the next step's reference. After an accepted try V
    // differs from T only for the particles the last Shallower brought to their targets.
    R* x = s.field(ff::fields::position).data<R>(ctx);
    if (accepted) {
      loops_.copy_listed(n_shallowed, CopyListed<R>{{active_[1 - now].get(n), nullptr}, {n_shallowed, 0},
                                                    x, s.field(fields::position_prev).data<R>(ctx)},
                         st);
    } else {
      if (!announced) ctx.will_overwrite(fields::position_prev);
      mem_.copy(s.field(fields::position_prev).data<R>(ctx), x, bytes, st);
    }
    status(s)[kPrevKept] = 0;
    metrics(h);
    return Outcome::ok();
  }

  // The device's tries (untangle_step): where the host's loop is at a try's end.
  TryState try_state(std::size_t E, std::int64_t halvings, bool accepted, int now, std::size_t n_shallowed) {
    TryState t{};
    t.halvings = halvings;
    t.tries = tries_;
    t.now = unsigned(now);
    t.n_shallowed = unsigned(n_shallowed);
    t.accepted = accepted;
    t.work_gen = work_gen_;
    t.vertex_gen = vertex_gen_;
    t.touched_gen = touched_gen_;
    t.last = last_ == trouble_[0].get(E) ? 1 : 2;  // (the last marking is a round's: trouble_)
    t.fresh = 1;
    t.phase = kPhaseStop;
    return t;
  }
  // The passes untangle_step and repair_listed launch, with what the host knows of them: the
  // lengths, lists and generations a try sets are filled in on the device (flip/cuda.cu).
  TryArgs<R> try_args(State& s, const Mesh& m, std::uint8_t* go, R* x, R* v, const PeriodicBox<double>& box,
                      unsigned step_gen, std::size_t values) {
    const std::size_t n = s.n(), E = edge_count(n);
    std::uint8_t* mark = s.field(fields::flip_mark).data<std::uint8_t>(where_);
    unsigned* f = first_block();
    unsigned* r = round_block();
    std::int32_t* w = work_.get(E);
    std::int32_t* first = first_.get(E);
    std::int32_t* active = active_[0].get(n);
    std::int32_t* moving = moving_.get(n);
    unsigned* edge_stamp = edge_stamp_.get(E);
    const Points<R> at{x, box}, valid{v, box};
    const ListSpan unknown{nullptr, 0};
    const TouchedRecords restore = restore_records(s, SubTally{});
    TryArgs<R> a{
        MarkListed<R>{{m, at, v, mark, f}, w, ListSpan{f + kWorkCount, 0}, first, f},
        MarkListed<R>{{m, at, nullptr, mark, r}, w, ListSpan{r + kWorkCount, 0}, nullptr, r},
        DecideListed{{m, mark, go, r, kRepairFlips}, nullptr, unknown, touch_log(s)},
        ApplyListed{m, go, nullptr, unknown, w, edge_stamp, 0, r + kWorkCount},
        FindMoving<R>{MovingRule<R>{m, at, valid}, {nullptr, first, touched_edges_.get(E)}, {0, 0, 0}, moving,
                      vertex_stamp_.get(n), 0, f, w, edge_stamp, 0},
        RestoreAndDeepen<R>{restore, 0,
                            Deepen<R>{valid, target_.get(2 * n), x, moving, ListSpan{f + kMovingCount, 0}, depth_.get(n),
                                      active, halved_stamp_.get(n), step_gen, f}},
        EdgesAround{m, moving, ListSpan{f + kMovingCount, 0}, w, edge_stamp, 0, f},
        ShallowerAndList<R>{Shallower<R>{valid, target_.get(2 * n), x, active, depth_.get(n), active, f}, 0,
                            EdgesAround{m, active, unknown, w, edge_stamp, 0, f},
                            ListEdges{nullptr, unknown, w, edge_stamp, 0, f + kWorkCount}},
        CopyListed<R>{{nullptr, nullptr}, {0, 0}, x, v},
        x,
        v,
        values,
        {first, trouble_[0].get(E), trouble_[1].get(E)},
        {active_[0].get(n), active_[1].get(n)},
        f,
        r,
        edge_stamp,
        vertex_stamp_.get(n),
        touched_edge_stamp_.get(E),
        touched_vertex_stamp_.get(n),
        n,
        E,
        limits_.max_rounds,
        limits_.max_substeps,
        limits_.passing};
    return a;
  }

  // The copy of V's topology (TouchLog saves into it): the three fields' records, one field
  // after another.
  struct Kept {
    std::int32_t *he, *opp, *vedge;
  };
  Kept kept(State& s) {
    Field& he = s.field(fields::halfedge);
    Field& opp = s.field(fields::opposite);
    Field& ve = s.field(fields::vertex_edge);
    std::int32_t* k = topology_.get(he.size() + opp.size() + ve.size());
    return {k, k + he.size(), k + he.size() + opp.size()};
  }
  TouchLog touch_log(State& s) {
    const std::size_t n = s.n(), E = edge_count(n);
    const Kept k = kept(s);
    return {touched_edges_.get(E), touched_edge_stamp_.get(E), touched_vertices_.get(n), touched_vertex_stamp_.get(n),
            touched_gen_,          first_block() ,              k.he,                     k.opp,
            k.vedge};
  }
  // After a failed try: the records its flips changed back to V's (TouchLog's lists, lengths
  // in h; RestoreAndDeepen). After an accepted one the new V's topology is the one now: nothing
  // to copy. Either way a new generation of the lists starts (next_touched_gen; their lengths:
  // reset_try).
  TouchedRecords restore_records(State& s, const SubTally& h) {
    const Kept k = kept(s);
    return TouchedRecords{touched_edges_.get(edge_count(s.n())),
                          h[kTouchedEdgeCount],
                          touched_vertices_.get(s.n()),
                          k.he,
                          k.opp,
                          k.vedge,
                          s.field(fields::halfedge).data<std::int32_t>(where_),
                          s.field(fields::opposite).data<std::int32_t>(where_),
                          s.field(fields::vertex_edge).data<std::int32_t>(where_)};
  }
  // The touched lists' generation (one for the edge and the vertex stamps).
  void next_touched_gen(std::size_t n, CUstream_st* st) {
    const std::size_t E = edge_count(n);
    unsigned* ve = touched_vertex_stamp_.get(n);
    if (next_gen(touched_gen_, touched_edge_stamp_.get(E), E, st) == 1) mem_.fill(ve, 0, n * sizeof(unsigned), st);
  }

  static constexpr std::size_t kFirstRoundGuess = std::size_t(1) << 16;  // repair_listed
  UntangleLimits limits_;
  Where where_;
  UntangleLoops<R> loops_;
  const MemoryOps& mem_;
  Scratch<R> target_;              // the integrator's targets T
  Scratch<std::int32_t> topology_; // V's topology where flips touched it (TouchLog)
  Scratch<std::uint32_t> depth_;   // each particle's depth (Deepen, Shallower)
  // The lists (kernel.h): their lengths and the step's statistics in sub_.
  Counters<2 * kSubstepCounters> sub_;
  Scratch<std::int32_t> first_;          // edges troubled at a try's first marking
  Scratch<std::int32_t> trouble_[2];     // edges troubled at a round's marking (alternately)
  std::int32_t* last_ = nullptr;         // the last marking's troubled edges (first_ or trouble_)
  std::size_t n_first_ = 0, n_last_ = 0;
  Scratch<std::int32_t> work_;           // edges to mark
  Scratch<std::int32_t> touched_edges_;  // edges whose records flips changed since V's topology
  Scratch<std::int32_t> touched_vertices_;
  Scratch<std::int32_t> moving_;         // particles that go deeper
  Scratch<std::int32_t> active_[2];      // particles with depth > 0, and the last Shallower's
  // Stamps (claim): an id is in the list being built when its stamp equals the generation.
  Scratch<unsigned> edge_stamp_, vertex_stamp_, touched_edge_stamp_, touched_vertex_stamp_, halved_stamp_;
  unsigned work_gen_ = 0, vertex_gen_ = 0, touched_gen_ = 0, step_gen_ = 0;
  std::int64_t tries_ = 0;   // repair passes in the step (metric substep_tries)
  unsigned flips_ = 0;       // in the step (Result)
  std::int64_t rounds_ = 0;  // in the step (Result)
  // CUDA: the tries on the device (null on the CPU, or where the device cannot run them) and
  // the counters they end with.
  std::unique_ptr<DeviceTries<R>> device_;
  std::array<unsigned, 2 * kSubstepCounters> device_counters_{};
};

}  // namespace ff::delaunay
