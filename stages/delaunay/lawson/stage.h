// delaunay.lawson: parallel Lawson flips until every edge is locally Delaunay (Navarro et al.,
// as used by Carter et al. 2017). Rounds of mark / decide / apply over lists (kernel.h): round 0
// tests every edge, later rounds only the edges whose quad changed. The lowest marked edge id
// wins both of its triangles, so the result is independent of thread scheduling and backend.
// The host reads the counters after round 0's marks (on the device not always: see run()) and
// then after every round on the CPU; on the device after one grid round (none when round 0 marked
// few enough edges for the tail: small systems) and the rounds of a tail kernel that follow it
// (one block; a cluster from 32 768 particles: lawson/cuda.cu; each read waits for the device),
// or, when nothing can
// roll the step back after this stage, not before the step ends: the tail kernel then runs every
// round left and writes the counters to pinned host memory, and after_step() reads them, so the
// stages after this one queue behind its kernels instead of behind a wait for the host (with few
// candidates the tail kernel then makes round 0's marks too: the stage is one launch). In an
// attempt delaunay.detect_inversion decides on the device (StepContext::gate) that one launch
// goes before the host knows the candidates' count: the kernel reads it, and the gate (run_gated).
// The input must be a valid (all triangles positive) triangulation: run delaunay.flip first.
#pragma once
#include <algorithm>
#include <array>

#include "core/base/error.h"
#include "core/backend/exec.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/delaunay/common/host.h"
#include "stages/delaunay/lawson/kernel.h"

namespace ff::delaunay {

// Grid rounds a CUDA Lawson runs before its tail kernel when the last tail found its list too
// long (else one).
inline constexpr std::int64_t kDeviceRoundsPerRead = 3;

struct LawsonParams {
  std::int64_t max_rounds = 1000;
  double tolerance = 1e-10;

  template <class P>
  void describe(P& p) {
    p(max_rounds, "max_rounds", "flip rounds before the run stops with an error").at_least(1);
    p(tolerance, "tolerance",
      "in-circle tolerance relative to the determinant's rounding scale (co-circular points within it are left as "
      "they are)")
        .at_least(0);
  }
};

template <class R>
struct LawsonLoops {
  ElementLoop<MarkNonDelaunay<R>> mark;
  ElementLoop<DecideMarked> decide;
  ElementLoop<ApplyMarked> apply;
  // The device's later rounds in one kernel (kernel.h, LawsonTail); none on the CPU.
  void (*tail)(const LawsonTail<R>& t, CUstream_st* stream) = nullptr;
  // How many edges the tail kernel takes in one pass on a mesh of so many edges (lawson/cuda.cu:
  // 16 384 on its cluster, 1 024 in one block): it goes on while a round marks at most that many,
  // makes round 0's marks itself for at most that many candidates, and a device-decided attempt
  // after a run of more flips runs a grid round first (run_gated).
  unsigned (*tail_pass)(std::size_t edges) = nullptr;
};

// The loops of each backend (lawson/cpu.cpp, lawson/cuda.cu).
template <class R>
LawsonLoops<R> lawson_loops(CpuExec);
template <class R>
LawsonLoops<R> lawson_loops(CudaExec);

template <class R>
class Lawson final : public Stage {
 public:
  static StageDecl declaration() {
    return {"delaunay.lawson",
            "parallel Lawson edge flips until the triangulation is Delaunay",
            schema_of<LawsonParams>(),
            {2},
            false,
            // (on a valid triangulation: after the repair of what detect_inversion marked, or a build)
            {"delaunay.flip", "delaunay.build"}};
  }

  template <class Exec>
  Lawson(const ParamValues& v, const RunInfo&, Exec exec)
      : p_(params_from<LawsonParams>(v)),
        where_(Exec::where),
        loops_(lawson_loops<R>(exec)),
        mem_(exec.memory()),
        counters_(exec),
        marked_(exec),
        queued_(exec),
        go_(exec),
        list_(exec),
        marked_list_(exec) {}

  std::vector<Access> accesses() const override {
    return {{ff::fields::position, where_, Mode::read},
            {fields::lawson_candidates, where_, Mode::read},
            {fields::lawson_candidate_count, where_, Mode::read},
            Access::on_demand_write(fields::halfedge, where_),
            Access::on_demand_write(fields::opposite, where_),
            Access::on_demand_write(fields::vertex_edge, where_),
            {fields::status, Where::host, Mode::readwrite}};
  }
  void configure(State& s) override { add_topology_fields(s, "delaunay.lawson"); }
  // In a decomposed team it flips the rank's own triangulation of its held particles (built by
  // delaunay.detect_inversion, which says how far the ghosts must reach).
  // On the device it follows delaunay.detect_inversion's device decisions (run_gated) where
  // detect's candidates may stand for round 0 (the tolerance: see run()).
  Scheduling scheduling() const override {
    Scheduling sch;
    sch.team = TeamWork::local;
    sch.follows_gate = where_ == Where::device && p_.tolerance >= kCandidateTolerance;
    return sch;
  }

  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    settle(s, st, nullptr);  // a step rolled back after this stage ran: after_step was not called
    ensure_topology(ctx, *this);
    if (status(s)[kPending] || status(s)[kPrevKept])
      throw RunError("delaunay.lawson: " + std::to_string(status(s)[kPending]) +
                     " inverted triangle(s) found by delaunay.detect_inversion were not repaired; put delaunay.flip "
                     "between delaunay.detect_inversion and delaunay.lawson");
    const Mesh m = mesh_view(s, where_);
    const Points<R> pts = points_view<R>(s, ff::fields::position, where_);
    const std::size_t E = edge_count(s.n());
    if (round_ > 2000000000) {  // stamps are round ids: start over long before they wrap
      marked_.reset();
      queued_.reset();
      round_ = 0;
    }
    if (ctx.gate) return run_gated(ctx);
    std::int32_t* marked = marked_.get(E);
    std::int32_t* marked_list = marked_list_.get(E);
    // On the device, the last run's round 0 set the other bank's start values (reset_next).
    counters_.begin(std::array<int, 1>{kLawsonTooLongAt}, st);
    unsigned* c = counters_.ptr();

    std::size_t launch = E;             // round 0 tests every edge ...
    const std::int32_t* test = nullptr;
    // ... or only detect_inversion's candidates (a superset of the edges round 0 would mark),
    // when they are current: no flip or rebuild since (status kCandidates) and nothing wrote
    // the positions since (their Field::version, recorded by detect_inversion).
    const std::int32_t hint = status(s)[kCandidates];
    status(s)[kCandidates] = 0;  // consumed: the flips below change quads
    // The candidates are those with in-circle determinant > 0, computed by the same code in
    // another loop; at tolerance 0 a co-circular quad (determinant at rounding level) could
    // in principle round differently there (FMA contraction on the device), so test all.
    if (hint > 0 && p_.tolerance >= kCandidateTolerance &&
        position_version(status(s)) == s.field(ff::fields::position).version()) {
      launch = unsigned(hint - 1);  // the list's length: the launch's own size
      test = s.field(fields::lawson_candidates).data<std::int32_t>(ctx);
    }
    // Round 0's marks, read back: when none is needed nothing is announced to the rollback
    // snapshot (no copy of the topology), and the rounds launch over the exact count. On the
    // device, when the core says the read-back may wait (ctx.may_defer_read_back(): every
    // rollback requester ran before this stage, so no snapshot covers its writes), the read is
    // skipped (`defer`) and round 1 launches over round 0's list length, an upper bound of its
    // marks: one wait for the device fewer per step. With few candidates (small systems: bench-abp
    // tests ~18 a step at N = 2^10, of which most flip) that bound is within a pass of the tail
    // kernel, so the tail kernel alone runs the rounds, and one that finds nothing marked stops at
    // once: no grid round runs empty. Flips that would need an edge longer than half the box are
    // refused by the marking, so reporting them at a later read is safe.
    std::int32_t round = ++round_;
    MarkNonDelaunay<R> first{m, pts, p_.tolerance, test, nullptr, marked, round, marked_list, c, unsigned(launch)};
    if (where_ == Where::device) first.reset_next = counters_.next();
    // Nothing can roll back this stage's writes (the core's answer): the device may run every
    // round without the host (`defer`, see the head of this file).
    const bool defer = where_ == Where::device && ctx.may_defer_read_back() && loops_.tail;
    // Few candidates (small systems): round 0's marks are the tail kernel's first pass.
    const unsigned pass = loops_.tail ? loops_.tail_pass(E) : 0;
    const bool round0_in_tail = defer && test && launch > 0 && launch <= pass;
    if (!round0_in_tail) loops_.mark(launch, first, st);
    if (where_ == Where::device && launch > 0) counters_.next_was_reset();
    std::array<unsigned, kLawsonCounters> h{};
    std::size_t bound = launch;            // this round's marked edges (exact, or an upper bound)
    const unsigned* marked_len = c + kLawsonMarked;  // null: `bound` is exact; else their count, on the backend
    if (defer) {  // round 0's read skipped too (see above)
      h[kLawsonMarked] = 1;  // not known yet: go into the loop, which reads it
    } else {
      h = counters_.read(st);
      throw_if_too_long_flip(s, h[kLawsonTooLong], h[kLawsonTooLongAt], st);
      bound = h[kLawsonMarked];
      marked_len = nullptr;
      if (bound) will_flip(ctx);  // announce before the first flip (rollback snapshot)
    }
    std::int64_t launched = 0;  // decide/apply rounds launched
    // Then rounds of decide, apply, mark. On the device several rounds go between two reads
    // (kernels take the lists' lengths from the backend and launch over upper bounds: each
    // marked edge queues at most 4 edges), so a step waits for the device once or twice instead
    // of once per round: grid launches for one round (kDeviceRoundsPerRead while the tail kernel
    // finds its lists too long), then the tail kernel, which runs the rounds that follow in one
    // block or cluster until one marks nothing or more than a pass of edges (bench-abp at N = 2^20:
    // round 0 marks ~19,000 edges, the rounds after the first a few hundred and fewer). A round
    // after the last marking one finds empty lists and does nothing. When deferring, the tail
    // kernel runs every round left, however long its lists (a round of many edges is slower in
    // one block: the next step then runs kDeviceRoundsPerRead grid rounds first, grid_rounds_).
    std::int64_t grid_rounds = grid_rounds_;
    // Small systems: when round 0 marked no more edges than the tail kernel takes (bench-abp at
    // N = 2^14 tests ~300 candidates), the tail kernel runs from round 1 on, and the grid round's
    // kernels (decide, apply, mark and two counter fills) are not launched. The same rounds run,
    // in the tail kernel: the same flips (the lowest marked edge id wins, whoever runs the round).
    if (loops_.tail && bound <= pass) grid_rounds = 0;
    while (h[kLawsonMarked]) {
      if (launched >= p_.max_rounds) throw_not_delaunay(h);
      const std::int64_t per_read = loops_.tail ? grid_rounds : 1;
      for (std::int64_t j = 0; j < per_read && launched < p_.max_rounds; ++j, ++launched) {
        // Apply lists the next round's edges. Before the first round the count is still 0 from
        // the reset (round 0's marks do not touch it); the device skips that fill.
        if (launched > 0 || where_ != Where::device) counters_.zero(kLawsonQueued, 1, st);
        bound = grid_round(m, pts, E, bound, marked_len, round, st);
        marked_len = c + kLawsonMarked;
      }
      const bool tail = loops_.tail && launched < p_.max_rounds;
      if (tail) {
        LawsonTail<R> t = tail_args(m, pts, E, round, defer ? ~0u : pass, p_.max_rounds - launched,
                                    defer ? counters_.landing() : nullptr);
        if (round0_in_tail && launched == 0) {
          t.first_list = test;
          t.first_count = unsigned(launch);
          t.first_reset_next = first.reset_next;
        }
        loops_.tail(t, st);
      }
      if (tail && defer) {  // the counters are read by after_step (settle)
        counters_.await_published(st);
        pending_ = true;
        return Outcome::ok();
      }
      h = counters_.read(st);
      if (tail) {  // its rounds used the next round ids
        const std::int64_t ran = h[kLawsonTailRounds];
        launched += ran;
        round_ += std::int32_t(ran);
        round = round_;
        grid_rounds = ran == 0 ? kDeviceRoundsPerRead : 1;
      }
      throw_if_too_long_flip(s, h[kLawsonTooLong], h[kLawsonTooLongAt], st);
      bound = h[kLawsonMarked];
      marked_len = nullptr;
    }
    last_flips_ = h[kLawsonFlips];
    report(h, ctx.metrics);
    return Outcome::ok();
  }

  void after_step(StepContext& ctx) override { settle(ctx.state, ctx.stream, &ctx.metrics); }

 private:
  // Below this tolerance detect_inversion's candidates are not used (see run()).
  static constexpr double kCandidateTolerance = 1e-13;

  // An attempt delaunay.detect_inversion decides on the device (StepContext::gate): the
  // deferring run()'s launches before the host knows the candidates' count, which detect's kernel
  // wrote on the device (0 when it closed the gate). When the last run flipped at most a pass of
  // the tail kernel's edges (small and middle systems), its one launch with round 0 in the tail
  // kernel (LawsonTail::gate); else one grid round first (bench-abp at N = 2^20: ~18 000
  // candidates, ~19 000 flips a step), its kernels launched over the list's capacity and their
  // lengths read on the device, so that the cluster's rounds of many edges (slower than the
  // grid's) are not the tail's. Either shape takes any count: the last flips only choose.
  // Refused (before anything is launched) when the candidates are not this step's (a stage
  // between wrote the positions) or the read cannot wait (a snapshot covers this stage's writes).
  Outcome run_gated(StepContext& ctx) {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    if (status(s)[kCandidates] != kCandidatesOnDevice || !ctx.may_defer_read_back() || !loops_.tail ||
        position_version(status(s)) != s.field(ff::fields::position).version()) {
      ctx.gate_refused = true;
      return Outcome::ok();
    }
    status(s)[kCandidates] = 0;  // consumed
    const Mesh m = mesh_view(s, where_);
    const Points<R> pts = points_view<R>(s, ff::fields::position, where_);
    const std::size_t E = edge_count(s.n());
    counters_.begin(std::array<int, 1>{kLawsonTooLongAt}, st);
    const std::int32_t* candidates = s.field(fields::lawson_candidates).data<std::int32_t>(ctx);
    const std::int32_t* count = s.field(fields::lawson_candidate_count).data<std::int32_t>(ctx);
    // A round of more than half a pass of flips runs faster on the grid than in the tail kernel
    // (bench-abp at 2^19, ~9 000 flips a step: +0.5 %; from a quarter of a pass, 2^14's one
    // block and 2^18 lost 3 % and 1 %: bench/experiments/README.md, "Lawson's tail at its edges").
    const bool grid_first = last_flips_ > loops_.tail_pass(E) / 2 && p_.max_rounds > 1;
    std::int32_t round = ++round_;
    if (grid_first) {
      unsigned* c = counters_.ptr();
      // Round 0 over the candidates (the count's i32 read as unsigned: it is not negative), then
      // one round, as run()'s grid rounds over upper bounds: the list's capacity, 4 per mark.
      const std::size_t capacity = s.field(fields::lawson_candidates).count();
      MarkNonDelaunay<R> first{m, pts, p_.tolerance, candidates, reinterpret_cast<const unsigned*>(count),
                               marked_.get(E), round, marked_list_.get(E), c, unsigned(capacity)};
      first.reset_next = counters_.next();
      loops_.mark(capacity, first, st);
      counters_.next_was_reset();
      grid_round(m, pts, E, capacity, c + kLawsonMarked, round, st);
      loops_.tail(tail_args(m, pts, E, round, ~0u, p_.max_rounds - 1, counters_.landing()), st);
    } else {
      LawsonTail<R> t = tail_args(m, pts, E, round, ~0u, p_.max_rounds, counters_.landing());
      t.first_list = candidates;
      t.first_reset_next = counters_.next();
      t.gate = ctx.gate;
      t.first_count_at = count;
      loops_.tail(t, st);
      counters_.next_was_reset();
    }
    counters_.await_published(st);
    pending_ = true;  // read by after_step (settle)
    return Outcome::ok();
  }

  // One grid round after the marks of `round` (at most `bound` of them; their count on the
  // backend at marked_len, or nullptr: exactly `bound`): decide, apply, and the next round's marks
  // over its upper bound, 4 per marked edge, stamped with the next round id (`round` and round_
  // advance to it). Returns that bound. The caller zeroes the queued count before it where needed.
  std::size_t grid_round(const Mesh& m, const Points<R>& pts, std::size_t E, std::size_t bound,
                         const unsigned* marked_len, std::int32_t& round, CUstream_st* st) {
    unsigned* c = counters_.ptr();
    std::int32_t* marked = marked_.get(E);
    std::int32_t* marked_list = marked_list_.get(E);
    std::uint8_t* go = go_.get(E);
    std::int32_t* list = list_.get(E);
    loops_.decide(bound, DecideMarked{m, marked, round, marked_list, go, c, marked_len}, st);
    loops_.apply(bound, ApplyMarked{m, marked_list, go, queued_.get(E), round + 1, list, c, marked_len}, st);
    counters_.zero(kLawsonMarked, 1, st);
    round = ++round_;
    bound = std::min<std::size_t>(4 * bound, E);
    loops_.mark(bound, MarkNonDelaunay<R>{m, pts, p_.tolerance, list, c + kLawsonQueued, marked, round, marked_list, c},
                st);
    return bound;
  }

  // The tail kernel's arguments that run() and run_gated() share: this step's mesh, positions,
  // work arrays and counters, from round `round` on.
  LawsonTail<R> tail_args(const Mesh& m, const Points<R>& pts, std::size_t E, std::int32_t round, unsigned max_marked,
                          std::int64_t max_rounds, unsigned* publish) {
    LawsonTail<R> t{m,          pts,          p_.tolerance,    marked_.get(E), queued_.get(E),
                    go_.get(E), list_.get(E), marked_list_.get(E), counters_.ptr(), round,
                    max_marked, max_rounds,   publish};
    t.edges = E;
    return t;
  }

  void report(const std::array<unsigned, kLawsonCounters>& h, Metrics& metrics) {
    metrics.set("lawson_rounds", double(h[kLawsonRounds]));  // rounds that flipped something
    metrics.set("lawson_flips", h[kLawsonFlips]);
  }

  // Reads the counters a deferring run left to its tail kernel (waits for it): advances the round
  // ids past the tail's rounds, throws what the rounds found, and reports the metrics (none when
  // called from run(): the step they belong to was rolled back).
  void settle(State& s, CUstream_st* st, Metrics* metrics) {
    if (!pending_) return;
    pending_ = false;
    const std::array<unsigned, kLawsonCounters> h = counters_.finish_read();
    const std::int64_t ran = h[kLawsonTailRounds];
    round_ += std::int32_t(ran);
    grid_rounds_ = h[kLawsonTailLargest] > loops_.tail_pass(edge_count(s.n())) ? kDeviceRoundsPerRead : 1;
    throw_if_too_long_flip(s, h[kLawsonTooLong], h[kLawsonTooLongAt], st);
    if (h[kLawsonMarked]) throw_not_delaunay(h);
    last_flips_ = h[kLawsonFlips];
    if (metrics) report(h, *metrics);
  }

  void throw_not_delaunay(const std::array<unsigned, kLawsonCounters>& h) const {
    throw RunError("delaunay.lawson: the triangulation is still not Delaunay after max_rounds = " +
                   std::to_string(p_.max_rounds) + " rounds (" + std::to_string(h[kLawsonFlips]) + " flips; " +
                   std::to_string(h[kLawsonMarked]) +
                   " edge(s) left). Raise max_rounds, or raise tolerance if points are (nearly) co-circular");
  }

  void throw_if_too_long_flip(State& s, unsigned count, unsigned at, CUstream_st* st) {
    if (!count) return;
    const auto ids = edge_vertices(s, where_, mem_, int(at), st);
    throw RunError("delaunay.lawson: restoring the Delaunay property needs an edge longer than half the box (next to "
                   "the edge between particles " +
                   list_ids(ids) + "; " + std::to_string(count) +
                   " such flip(s)); the periodic triangulation is stored by minimum image and cannot hold it. Use a "
                   "larger system (more particles at this density); if the particles leave an empty region as wide as "
                   "half the box (a trap, a droplet, walls far apart), find the overlaps on a neighbour list "
                   "instead: neighbors.verlet and overlap_correct.verlet (pipelines/trap-hard-disks.yaml)");
  }

  LawsonParams p_;
  Where where_;
  LawsonLoops<R> loops_;
  const MemoryOps& mem_;
  Counters<kLawsonCounters> counters_;
  Scratch<std::int32_t> marked_;  // round stamps: marked in that round
  Scratch<std::int32_t> queued_;  // round stamps: queued for that round
  Scratch<std::uint8_t> go_;
  Scratch<std::int32_t> list_;         // edges to test in the next round
  Scratch<std::int32_t> marked_list_;  // edges marked in this round
  std::int32_t round_ = 0;
  std::int64_t grid_rounds_ = 1;        // grid rounds before the tail kernel (see run())
  bool pending_ = false;                // a tail kernel publishes this run's counters (settle)
  unsigned last_flips_ = 0;             // the last run's flips: the shape of a gated launch (run_gated)
};

}  // namespace ff::delaunay

FLIPFLOW_STAGE(ff::delaunay::Lawson)
