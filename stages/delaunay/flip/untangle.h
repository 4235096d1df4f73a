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
// What the loop does next and the passes of each branch are stated once, in flip/tries.h:
// decide_next (another repair round, an accepted try, a failed one, a stop) and the pass
// functions (copy_pass & co.: kernel.h's functors with the lists, lengths and generations the
// decision set). The host's loop below (untangle_step) calls them on the CPU, and on CUDA until
// the first failed try; from its decision on the device runs the tries (DeviceTries,
// flip/cuda.cu: one cooperative kernel in which one thread calls decide_next on the counters in
// place and the grid runs the branch's passes) and the host reads the counters once, when
// decide_next stops. Same decisions, same passes on the same lists, so the same bits.
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
#include "stages/delaunay/flip/tries.h"

namespace ff::delaunay {

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

// The tries on the device (CUDA: flip/cuda.cu); null on the CPU. run: from a decision of the
// host's loop (`s`, s.decided: its passes still to run), the passes and decisions until
// decide_next stops (`s` gets the state it stops with: why, the statistics, the generations);
// `counters` gets both counter blocks. False: the device cannot run them (its kernel does not
// fit); the host carries on.
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
    Outcome out = untangle_step(ctx, m, go);
    return {std::move(out), try_.flips, try_.rounds};
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

  // Reads both blocks (the try's first marking and lists, then the last round's marking), after
  // the passes launched before; throws where a marking found a triangle that does not close.
  const unsigned* read_try(State& s, CUstream_st* st) {
    const unsigned* both = sub_.read(st).data();
    throw_if_unclosed(s, both, st);
    return both;
  }
  void throw_if_unclosed(State& s, const unsigned* both, CUstream_st* st) {
    const unsigned* f = both;
    const unsigned* r = f + kSubstepCounters;
    throw_if_too_long(s, where_, mem_, f[kTooLong], f[kTooLongAt], st, "delaunay.flip");
    throw_if_too_long(s, where_, mem_, r[kTooLong], r[kTooLongAt], st, "delaunay.flip");
  }
  // What the metrics and the rollback messages read: the last marking's counters with the first
  // marking's reversed edges and the first block's statistics.
  static SubTally tally(const unsigned* both) {
    const unsigned* f = both;
    const unsigned* r = f + kSubstepCounters;
    SubTally h;
    std::copy(f, f + kSubstepCounters, h.begin());
    std::copy(r, r + kInversionCounters, h.begin());
    h[kThrough] = f[kThrough];
    h[kThroughAt] = f[kThroughAt];
    return h;
  }

  // decide_next (flip/tries.h) on the counters read, with the resets and stamp clears it asks
  // for made on the backend, before the passes of its branch.
  unsigned decide(const unsigned* both, std::size_t n, CUstream_st* st) {
    TryState& t = try_;
    t.phase = decide_next(both, both + kSubstepCounters, limits_, t);
    if (t.phase == kPhaseStop) return t.phase;
    loops_.reset(1, phase_reset(t.phase, first_block(), round_block()), st);
    const std::size_t E = edge_count(n);
    if (t.clear & kClearEdges) mem_.fill(edge_stamp_.get(E), 0, E * sizeof(unsigned), st);
    if (t.clear & kClearVertices) mem_.fill(vertex_stamp_.get(n), 0, n * sizeof(unsigned), st);
    if (t.clear & kClearTouched) {
      mem_.fill(touched_edge_stamp_.get(E), 0, E * sizeof(unsigned), st);
      mem_.fill(touched_vertex_stamp_.get(n), 0, n * sizeof(unsigned), st);
    }
    return t.phase;
  }

  // The step's untangling (the top of this file): the first try on every edge, then what
  // decide_next decides after each marking (flip/tries.h: another round, an accepted or a failed
  // try, a stop), until the particles are at T with nothing inverted (or reversed), or a rollback
  // request (max_substeps; a reversed edge without `passing: substep`).
  Outcome untangle_step(StepContext& ctx, const Mesh& m, std::uint8_t* go) {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    const std::size_t n = s.n(), E = edge_count(n);
    const std::size_t bytes = s.field(ff::fields::position).bytes();
    const auto box = PeriodicBox<double>::make(s.box.L);
    R* target = target_.get(2 * n);
    TryState& t = try_;
    {  // A new step: the stamps' generations go on.
      const TryState last = t;
      t = TryState{};
      t.work_gen = last.work_gen;
      t.vertex_gen = last.vertex_gen;
      t.touched_gen = last.touched_gen;
    }
    bool announced = false;
    const unsigned step_gen = next_gen(step_gen_, halved_stamp_.get(n), n, st);
    next_touched_gen(n, st);
    const auto metrics = [&](const SubTally& h) {
      ctx.metrics.set("substeps", double(t.halvings));
      ctx.metrics.set("substep_tries", double(t.tries));
      ctx.metrics.set("substep_depth", double(~h[kDepthNot]));
      ctx.metrics.set("substep_particles", double(h[kHalvedCount]));
    };
    const auto stop = [&](std::string why, std::vector<std::uint64_t> who, const SubTally& h) {
      if (announced) mem_.copy(s.field(ff::fields::position).data<R>(ctx), target, bytes, st);  // as detect left it
      metrics(h);
      return Outcome::request_rollback("delaunay.flip: " + why + "; the step is retried with a smaller time step",
                                       std::move(who));
    };
    const auto args = [&] {  // the passes, at the positions now
      return try_args(s, m, go, s.field(ff::fields::position).data<R>(ctx), s.field(fields::position_prev).data<R>(ctx),
                      box, step_gen, bytes / sizeof(R));
    };
    TryArgs<R> a = args();
    // The first try: every edge, at V's topology and the targets (its counters and the step's
    // statistics start; later tries': decide).
    loops_.reset(1, ResetTry{first_block(), round_block(), true, true}, st);
    ++t.tries;
    t.wg_round = next_gen(t.work_gen, edge_stamp_.get(E), E, st);
    TryLoop<MarkListed<R>> all = mark_first_pass(a, E);
    all.f.list = nullptr;
    all.f.span = ListSpan{nullptr, E};
    const unsigned* both = run_try(s, a, all, st);
    unsigned phase;
    while ((phase = decide(both, n, st)) != kPhaseStop) {
      if (phase == kPhaseFail && !announced) {  // the first intermediate position: keep T and V for a rollback
        ctx.will_write(ff::fields::position);
        ctx.will_write(fields::position_prev);
        announced = true;
        a = args();
        mem_.copy(target, a.copy_from, bytes, st);  // a.copy_from: the positions, at T
        mem_.fill(depth_.get(n), 0, n * sizeof(std::uint32_t), st);
      }
      // CUDA: the device runs the tries from this decision (every try after the first failed
      // one) until decide_next stops; the host reads the counters once, then.
      if (device_ && announced) {
        t.decided = 1;
        if (device_->run(a, t, device_counters_.data(), st)) {
          both = device_counters_.data();
          throw_if_unclosed(s, both, st);
          break;
        }
        t.decided = 0;
        device_.reset();  // not on this device: the host's loop from here on
      }
      both = run_passes(phase, s, a, both, st);
    }
    const SubTally h = tally(both);
    if (t.stop == kStopThrough) {
      auto ids = edge_vertices(s, where_, mem_, int(h[kThroughAt]), st);
      return stop("particles " + list_ids(ids) + " passed through each other between intermediate positions (r0.r1 < 0)",
                  ids, h);
    }
    if (t.stop == kStopSubsteps) {
      if (h[kThrough]) {
        auto ids = edge_vertices(s, where_, mem_, int(h[kThroughAt]), st);
        return stop("particles " + list_ids(ids) + " passed through each other (r0.r1 < 0) even after halving the "
                        "moves " + std::to_string(t.halvings) + " time(s) (max_substeps)",
                    ids, h);
      }
      return stop(std::to_string(h[kInverted]) + " inverted triangle(s) remain after halving the moves " +
                      std::to_string(t.halvings) + " time(s) (max_substeps)",
                  {}, h);
    }
    // At the targets. position_prev ← position (= T): the next step's reference. After an
    // accepted try V differs from T only for the particles the last Shallower brought to their
    // targets.
    R* x = s.field(ff::fields::position).data<R>(ctx);
    if (t.accepted) {
      loops_.copy_listed(t.n_shallowed, CopyListed<R>{{active_[1 - t.now].get(n), nullptr}, {t.n_shallowed, 0},
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

  // The passes of decide_next's branch (flip/tries.h: the passes run_pass runs on the device),
  // launched by the host; returns the counters they leave (read_try). The loops over lists whose
  // lengths are on the backend (the next marking's work list, the moving particles) are launched
  // over guesses of them (ListSpan): the host reads counters once a marking, nothing else.
  // `both`: the counters decide_next decided on.
  const unsigned* run_passes(unsigned phase, State& s, const TryArgs<R>& a, const unsigned* both, CUstream_st* st) {
    const TryState& t = try_;
    if (phase == kPhaseRound) return run_round(s, a, t.n_list, st);
    std::size_t guess = 0;
    if (phase == kPhaseAccept) {
      // Valid here: the next reference. Before the first acceptance every particle is at its
      // target, away from V; after it only the active particles and the ones the last
      // Shallower moved have left V.
      if (t.first_accept) {
        mem_.copy(a.copy_to, a.copy_from, a.values * sizeof(R), st);
      } else {
        launch(loops_.copy_listed, copy_pass(a, t), st);
      }
      launch(loops_.shallower_list, shallower_pass(a, t), st);
      guess = t.n_last + 12 * std::size_t(t.n_shallowed);
    } else {
      launch(loops_.find_moving, find_moving_pass(a, t), st);
      // The flips made for the positions farther out need not be valid nearer V (a flipped
      // triangle can stay inverted however close to V its vertices come): repair from V's.
      // The moving particles: at most both ends of the edges FindMoving judged.
      const std::size_t n_moving =
          std::min<std::size_t>(a.n, 2 * (std::size_t(t.n_last) + t.n_first + t.n_touched_edges));
      launch(loops_.restore_deepen, restore_deepen_pass(a, t, n_moving), st);
      launch(loops_.edges_around, edges_around_pass(a, t, n_moving), st);
      const unsigned* f = both;
      const unsigned* r = both + kSubstepCounters;
      guess = t.n_first + t.n_last + 12 * std::size_t(r[kInverted] + f[kThrough]);
    }
    return run_try(s, a, mark_first_pass(a, std::max<std::size_t>(1, std::min(a.E, guess))), st);
  }
  // A try's first marking (`marking`) and first repair round. The round is launched right after
  // the marking, before the host knows whether anything is marked (with nothing marked it flips
  // nothing and re-marks the same edges): one host read a try when a round suffices. Its list
  // has a length only the backend knows: launched over a guess (the troubled edges are a small
  // part of the marked ones even when every edge is marked, and a short guess only makes each
  // thread take more).
  const unsigned* run_try(State& s, const TryArgs<R>& a, const TryLoop<MarkListed<R>>& marking, CUstream_st* st) {
    launch(loops_.mark_listed, marking, st);
    return run_round(s, a, std::max<std::size_t>(1, std::min({a.E, marking.elements, kFirstRoundGuess})), st);
  }
  // A repair round (decide, apply, mark) over the last marking's troubled edges, launched over
  // `launched` (their number after a round, a guess of it after a try's first marking);
  // returns the counters (read_try).
  const unsigned* run_round(State& s, const TryArgs<R>& a, std::size_t launched, CUstream_st* st) {
    const TryState& t = try_;
    const ListSpan span = round_span(a, t, nullptr, launched);
    launch(loops_.decide_listed, decide_pass(a, t, span), st);
    launch(loops_.apply_listed, apply_pass(a, t, span), st);
    // At most the troubled edges and four more a flip; the length is on the backend.
    launch(loops_.mark_listed, mark_round_pass(a, t, std::min<std::size_t>(a.E, 5 * span.launched)), st);
    return read_try(s, st);
  }
  template <class F>
  static void launch(ElementLoop<F> loop, const TryLoop<F>& l, CUstream_st* st) {
    loop(l.elements, l.f, st);
  }

  // The passes of the tries (flip/tries.h) with what is known before a try: the lengths, lists
  // and generations decide_next sets are filled in by the pass functions of tries.h (copy_pass
  // & co.), on the host or on the device.
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
    const TouchedRecords restore = restore_records(s, 0);
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
        limits_};
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
            try_.touched_gen,      first_block() ,              k.he,                     k.opp,
            k.vedge};
  }
  // After a failed try: the records its flips changed back to V's (TouchLog's lists, `edges`
  // of them and the vertices; RestoreAndDeepen). After an accepted one the new V's topology is
  // the one now: nothing to copy. Either way a new generation of the lists starts (decide_next;
  // their lengths: phase_reset).
  TouchedRecords restore_records(State& s, unsigned edges) {
    const Kept k = kept(s);
    return TouchedRecords{touched_edges_.get(edge_count(s.n())),
                          edges,
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
    if (next_gen(try_.touched_gen, touched_edge_stamp_.get(E), E, st) == 1) mem_.fill(ve, 0, n * sizeof(unsigned), st);
  }

  static constexpr std::size_t kFirstRoundGuess = std::size_t(1) << 16;  // mark_first
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
  Scratch<std::int32_t> work_;           // edges to mark
  Scratch<std::int32_t> touched_edges_;  // edges whose records flips changed since V's topology
  Scratch<std::int32_t> touched_vertices_;
  Scratch<std::int32_t> moving_;         // particles that go deeper
  Scratch<std::int32_t> active_[2];      // particles with depth > 0, and the last Shallower's
  // Stamps (claim): an id is in the list being built when its stamp equals the generation.
  Scratch<unsigned> edge_stamp_, vertex_stamp_, touched_edge_stamp_, touched_vertex_stamp_, halved_stamp_;
  unsigned step_gen_ = 0;
  // Where the step's untangling is, its statistics and the stamps' generations (flip/tries.h;
  // the device's tries take it and hand it back).
  TryState try_{};
  // CUDA: the tries on the device (null on the CPU, or where the device cannot run them) and
  // the counters they end with.
  std::unique_ptr<DeviceTries<R>> device_;
  std::array<unsigned, 2 * kSubstepCounters> device_counters_{};
};

}  // namespace ff::delaunay
