// delaunay.flip: repair the inverted triangles that delaunay.detect_inversion marked, by edge
// flips (Carter et al. 2017, figs. 5–6), in parallel without conflicts (common/flip.h). Each
// round flips the marked edges that win their triangles, then re-detects; a flip turns one
// inverted triangle into two positive ones and touches nothing else, so the number of inverted
// triangles drops every round. Whatever cannot be repaired this way requests a rollback, or,
// with `on_unrepairable: substep`, is untangled through intermediate positions (untangle.h;
// Porro et al. §3) so that the step still ends at the integrator's targets; so are particles
// that passed each other (an edge vector reversed), which detect_inversion leaves to it then.
#pragma once
#include <array>
#include <string>
#include <utility>

#include "core/base/error.h"
#include "core/backend/exec.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/delaunay/build/build.h"
#include "stages/delaunay/common/host.h"
#include "stages/delaunay/common/team.h"
#include "stages/delaunay/flip/kernel.h"
#include "stages/delaunay/flip/untangle.h"

namespace ff::delaunay {

struct FlipParams {
  std::int64_t max_rounds = 64;
  std::string on_unrepairable = "rollback";
  std::string passing = "rollback";
  std::int64_t max_substeps = 8;

  template <class P>
  void describe(P& p) {
    p(max_rounds, "max_rounds", "repair rounds before the step is rolled back").at_least(1);
    p(on_unrepairable, "on_unrepairable",
      "what to do with triangles no single flip repairs (a vertex across several edges, an edge crossed from "
      "both sides): rollback = retry the step with a smaller time step (new noise); substep = move their "
      "particles half way back, repair, then on to the targets (Porro et al. 3; keeps the trajectory)")
        .one_of({"rollback", "substep"});
    p(passing, "passing",
      "what to do with two particles whose edge vector reversed in the step (they passed each other closer "
      "than their move): rollback = retry with a smaller time step (hard disks: they would have gone through "
      "each other); substep (needs on_unrepairable: substep) = move them part of the way as above until no "
      "sub-step reverses an edge (points such as boids, which may pass each other at any distance; a "
      "collision exhausts max_substeps and rolls back)")
        .one_of({"rollback", "substep"});
    p(max_substeps, "max_substeps",
      "with on_unrepairable: substep, how many times a step may halve the remaining moves before it is rolled "
      "back")
        .at_least(1);
  }
};

template <class R>
struct FlipLoops {
  ElementLoop<DecideFlips> decide;
  ElementLoop<ApplyFlips> apply;
  ElementLoop<MarkInversions<R>> mark;
};

// The plain element loops of the backend object (CpuExec or CudaExec) this stage.h is compiled
// for (core/stage/stage_registration.h).
template <class R, class Exec>
FlipLoops<R> flip_loops(Exec) {
  return {&Exec::template for_each<DecideFlips>, &Exec::template for_each<ApplyFlips>,
          &Exec::template for_each<MarkInversions<R>>};
}

template <class R>
class Flip final : public Stage {
 public:
  static StageDecl declaration() {
    return {"delaunay.flip",
            "repair the inverted triangles marked by delaunay.detect_inversion by parallel edge flips",
            schema_of<FlipParams>(),
            {2},
            false,
            {"delaunay.detect_inversion"}};
  }

  template <class Exec>
  Flip(const ParamValues& v, const RunInfo& info, Exec exec)
      : p_(params_from<FlipParams>(v)),
        team_(in_team(info.team) ? info.team : nullptr),
        substep_(p_.on_unrepairable == "substep"),
        passing_(p_.passing == "substep"),
        where_(Exec::where),
        loops_(flip_loops<R>(exec)),
        mem_(exec.memory()),
        counters_(exec),
        go_(exec),
        untangle_(UntangleLimits{p_.max_rounds, p_.max_substeps, passing_}, exec) {}

  std::vector<Access> accesses() const override {
    std::vector<Access> a{{ff::fields::position, where_, Mode::read},
                          Access::on_demand_write(fields::halfedge, where_),
                          Access::on_demand_write(fields::opposite, where_),
                          Access::on_demand_write(fields::vertex_edge, where_),
                          Access::step_local_write(fields::flip_mark, where_, Mode::readwrite),
                          {fields::status, Where::host, Mode::readwrite}};
    if (substep_) {  // intermediate positions, and the next step's reference
      a[0] = Access::on_demand_write(ff::fields::position, where_);
      a.push_back(Access::on_demand_write(fields::position_prev, where_));
    }
    return a;
  }
  void configure(State& s) override {
    add_topology_fields(s, "delaunay.flip");
    Field& f = s.field(fields::status);
    f.acquire(Where::host, Mode::readwrite);
    if (passing_ && !substep_)
      throw InputError("delaunay.flip: passing: substep sub-steps pairs as on_unrepairable: substep does; set "
                       "on_unrepairable: substep too");
    if (team_ && substep_)
      throw InputError("delaunay.flip: on_unrepairable: substep does not run in a team of ranks yet (it moves "
                       "particles of several ranks within the step): run on one GPU");
    // Tells delaunay.detect_inversion what to leave to us.
    status(s)[kSubstep] = substep_ ? (passing_ ? 2 : 1) : 0;
  }
  // Requests come from run(), after reading the counters. In a decomposed team: the rank's own
  // triangulation (TeamWork::local), requests agreed with the other ranks. In an attempt
  // delaunay.detect_inversion decides on the device (StepContext::gate) the stage launches
  // nothing: the gate opens only when nothing is left to repair.
  Scheduling scheduling() const override {
    Scheduling sch{true, false, false, false};
    sch.follows_gate = true;
    sch.team = TeamWork::local;
    sch.communicates = true;
    return sch;
  }

  Outcome run(StepContext& ctx) override {
    if (team_ && ctx.ghosts) return run_team(ctx);
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    ensure_topology(ctx, *this);
    ctx.metrics.set("flips", 0);
    ctx.metrics.set("flip_rounds", 0);
    if (substep_) ctx.metrics.set("substeps", 0);
    if (ctx.gate) return Outcome::ok();  // repairs only ever follow a closed gate (then without it)
    // kPrevKept: detect_inversion (substep mode) found something inverted and left
    // position_prev at the positions where the triangulation was valid.
    const bool kept = status(s)[kPrevKept] != 0;
    if (status(s)[kPending] == 0 && !kept) return Outcome::ok();  // detect_inversion found nothing to repair
    will_flip(ctx);  // the topology is in the rollback snapshot only on steps that flip

    flips_ = 0;
    rounds_ = 0;
    const Mesh m = mesh_view(s, where_);
    Outcome out = Outcome::ok();
    if (kept) {
      // Substep mode marks again with the r⁰·r¹ test against position_prev (untangle.h): detect
      // left reversed edges to the untangling, which must see them.
      status(s)[kPending] = 0;
      auto u = untangle_.run(ctx, m, go_.get(edge_count(s.n())));
      out = std::move(u.outcome);
      flips_ = u.flips;
      rounds_ = u.rounds;
    } else {
      // Detect's marks (it made some: kPending).
      const Points<R> now = points_view<R>(s, ff::fields::position, where_);
      const Tally h = repair(s, m, now, st);
      status(s)[kPending] = 0;
      if (h[kInverted])
        out = Outcome::request_rollback("delaunay.flip: " + std::to_string(h[kInverted]) +
                                        " inverted triangle(s) remain after " + std::to_string(flips_) +
                                        " repair flip(s) in " + std::to_string(rounds_) +
                                        " round(s); the step is retried with a smaller time step");
    }
    if (flips_) status(s)[kCandidates] = 0;  // quads changed: Lawson tests every edge
    ctx.metrics.set("flips", flips_);
    ctx.metrics.set("flip_rounds", double(rounds_));
    return out;
  }

 private:
  using Tally = std::array<unsigned, kInversionCounters>;

  // A decomposed team (docs/multi-gpu.md "The Delaunay pipelines"): the repair rounds on the
  // rank's triangulation; a triangle left inverted rolls the step back only where the rank can
  // trust it (an owned vertex: common/team.h), and then on every rank (one all-reduce, whether
  // or not this rank had anything to repair); elsewhere the rank rebuilds its triangulation for
  // the current positions.
  Outcome run_team(StepContext& ctx) {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    ensure_topology(ctx, *this);
    flips_ = 0;
    rounds_ = 0;
    bool left = false;
    if (status(s)[kPending] != 0) {
      will_flip(ctx);
      const Points<R> now = points_view<R>(s, ff::fields::position, where_);
      const Tally h = repair(s, mesh_view(s, where_), now, st);
      status(s)[kPending] = 0;
      left = h[kInverted] != 0;
    }
    const bool mine = left && owned_inverted<R>(HostMesh::of(s, st), host_positions<R>(s, s.field(ff::fields::position), st),
                                                s.n_owned(), PeriodicBox<double>::make(s.box.L));
    const bool any = any_rank(team_, mine);
    if (flips_) status(s)[kCandidates] = 0;  // quads changed: Lawson tests every edge
    bool local_rebuild = false;
    if (!any && left) {
      will_build(ctx);
      build_topology(s, st);
      for (const Access& a : accesses()) s.field(a.field).acquire(a.where, a.mode, st);
      local_rebuild = true;
    }
    ctx.metrics.set("flips", flips_);
    ctx.metrics.set("flip_rounds", double(rounds_));
    ctx.metrics.set("local_rebuilds", local_rebuild ? 1 : 0);
    if (any)
      return Outcome::request_rollback(std::string("delaunay.flip: ") +
                                       (mine ? "inverted triangles remain on this rank" : "inverted triangles remain on another rank") +
                                       " after the repair flips; the step is retried with a smaller time step");
    return Outcome::ok();
  }

  // Repair rounds (decide → apply → re-mark) from detect's marks while something is marked, up
  // to max_rounds; the last counters.
  Tally repair(State& s, const Mesh& m, const Points<R>& pts, CUstream_st* st) {
    std::uint8_t* mark = s.field(fields::flip_mark).data<std::uint8_t>(where_);
    const std::size_t E = edge_count(s.n());
    std::uint8_t* go = go_.get(E);
    unsigned* c = counters_.ptr();
    Tally h{};
    std::int64_t rounds = 0;
    do {
      counters_.reset(kMinSlots, st);
      loops_.decide(E, DecideFlips{m, mark, go, c, kRepairFlips}, st);
      loops_.apply(E, ApplyFlips{m, go}, st);
      loops_.mark(E, MarkInversions<R>{m, pts, nullptr, mark, c}, st);
      h = counters_.read(st);
      flips_ += h[kRepairFlips];
      ++rounds;
      throw_if_too_long(s, where_, mem_, h[kTooLong], h[kTooLongAt], st, "delaunay.flip");
    } while (h[kMarked] && rounds < p_.max_rounds);
    rounds_ += rounds;
    return h;
  }

  static constexpr std::array<int, 4> kMinSlots{kThroughAt, kTwiceAt, kUnrepairableAt, kTooLongAt};
  FlipParams p_;
  Communicator* team_;  // a decomposed team's rank; null alone
  bool substep_;
  bool passing_;
  Where where_;
  FlipLoops<R> loops_;
  const MemoryOps& mem_;
  Counters<kInversionCounters> counters_;
  Scratch<std::uint8_t> go_;  // flip decisions, one byte an edge (also the untangling's)
  unsigned flips_ = 0;         // in the step
  std::int64_t rounds_ = 0;
  // on_unrepairable: substep (its lists are allocated on its first run).
  Untangle<R> untangle_;
};

}  // namespace ff::delaunay

FLIPFLOW_STAGE(ff::delaunay::Flip)
