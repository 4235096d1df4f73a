// delaunay.flip: repair the inverted triangles that delaunay.detect_inversion marked, by edge
// flips (Carter et al. 2017, figs. 5–6), in parallel without conflicts (common/flip.h). Each
// round flips the marked edges that win their triangles, then re-detects; a flip turns one
// inverted triangle into two positive ones and touches nothing else, so the number of inverted
// triangles drops every round. Whatever cannot be repaired this way requests a rollback, or,
// with `on_unrepairable: substep`, is untangled through intermediate positions (untangle below;
// Porro et al. §3) so that the step still ends at the integrator's targets; so are particles
// that passed each other (an edge vector reversed), which detect_inversion leaves to it then.
#pragma once
#include <array>
#include <string>

#include "core/base/error.h"
#include "core/backend/exec.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/delaunay/build/build.h"
#include "stages/delaunay/common/host.h"
#include "stages/delaunay/common/team.h"
#include "stages/delaunay/flip/kernel.h"

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
  ElementLoop<MarkInvertedVertices<R>> moving;
  ElementLoop<Deepen<R>> deepen;
  ElementLoop<Shallower<R>> shallower;
};

// The plain element loops of the backend object (CpuExec or CudaExec) this stage.h is compiled
// for (core/stage/stage_registration.h).
template <class R, class Exec>
FlipLoops<R> flip_loops(Exec) {
  return {&Exec::template for_each<DecideFlips>, &Exec::template for_each<ApplyFlips>,
          &Exec::template for_each<MarkInversions<R>>, &Exec::template for_each<MarkInvertedVertices<R>>,
          &Exec::template for_each<Deepen<R>>, &Exec::template for_each<Shallower<R>>};
}

template <class R>
class Flip final : public Stage {
 public:
  static StageDecl declaration() {
    return {"delaunay.flip",
            "repair the inverted triangles marked by delaunay.detect_inversion by parallel edge flips",
            schema_of<FlipParams>(),
            {2},
            false};
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
        target_(exec),
        moving_(exec),
        topology_(exec),
        depth_(exec),
        deep_(exec) {}

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
  // triangulation (TeamWork::local), requests agreed with the other ranks.
  Scheduling scheduling() const override {
    Scheduling sch{true, false, false, false};
    sch.team = TeamWork::local;
    sch.communicates = true;
    return sch;
  }

  Outcome run(StepContext& ctx) override {
    if (team_ && ctx.ghosts) return run_team(ctx);
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    ensure_topology(ctx, accesses());
    ctx.metrics.set("flips", 0);
    ctx.metrics.set("flip_rounds", 0);
    if (substep_) ctx.metrics.set("substeps", 0);
    // kPrevKept: detect_inversion (substep mode) found something inverted and left
    // position_prev at the positions where the triangulation was valid.
    const bool kept = status(s)[kPrevKept] != 0;
    if (status(s)[kPending] == 0 && !kept) return Outcome::ok();  // detect_inversion found nothing to repair
    will_flip(ctx);  // the topology is in the rollback snapshot only on steps that flip

    flips_ = 0;
    rounds_ = 0;
    const Mesh m = mesh_view(s, where_);
    // Detect's marks when it made any; else (only unrepairable triangles) nothing to flip yet.
    // Substep mode (kept) marks again with the r⁰·r¹ test against position_prev: detect left
    // reversed edges to the untangling, which must see them.
    const Points<R> now = points_view<R>(s, ff::fields::position, where_);
    if (kept) topology(s, true, st);  // valid at position_prev: untangle's halvings start from it
    auto h = kept ? repair(s, m, now, s.field(fields::position_prev).data<R>(where_), true, st)
                  : repair(s, m, now, nullptr, status(s)[kPending] == 0, st);
    status(s)[kPending] = 0;
    Outcome out = Outcome::ok();
    if (kept) {
      out = untangle(ctx, m, h);
    } else if (h[kInverted]) {
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
    ensure_topology(ctx, accesses());
    flips_ = 0;
    rounds_ = 0;
    bool left = false;
    if (status(s)[kPending] != 0) {
      will_flip(ctx);
      const Points<R> now = points_view<R>(s, ff::fields::position, where_);
      const Tally h = repair(s, mesh_view(s, where_), now, nullptr, false, st);
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

  // Repair rounds (decide → apply → re-mark) while something is marked, up to max_rounds.
  // `mark_first`: the positions changed since the marks were made, so mark them first, with the
  // r⁰·r¹ test against `prev` when given (substep mode). The last counters, with the first
  // marking's reversed edges (kThrough, kThroughAt): the rounds repair what single flips can
  // around a pair that passed each other, and untangle halves what is left.
  Tally repair(State& s, const Mesh& m, const Points<R>& pts, const R* prev, bool mark_first, CUstream_st* st) {
    std::uint8_t* mark = s.field(fields::flip_mark).data<std::uint8_t>(where_);
    const std::size_t E = edge_count(s.n());
    std::uint8_t* go = go_.get(E);
    unsigned* c = counters_.ptr();
    Tally h{};
    if (mark_first) {
      counters_.reset(kMinSlots, st);
      loops_.mark(E, MarkInversions<R>{m, pts, prev, mark, c}, st);
      h = counters_.read(st);
      throw_if_too_long(s, where_, mem_, h[kTooLong], h[kTooLongAt], st, "delaunay.flip");
      if (!h[kMarked]) return h;
    }
    const unsigned through = h[kThrough], through_at = h[kThroughAt];
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
    h[kThrough] = through;
    h[kThroughAt] = through_at;
    return h;
  }

  // Substep untangling (Porro et al. §3, "intermediate position"). The triangulation is valid
  // at V = position_prev and the integrator's targets T are in `position`. Each particle has a
  // depth d (0 at first) and is tried at V + 2^-d (T − V) (place_at_depth). While triangles stay
  // inverted after the repair rounds, the particles of those triangles go a level deeper (half
  // as far from V) and the rounds run again from V's topology; once nothing is inverted the
  // positions become the new V and every particle goes a level shallower: twice as far along
  // the rest of its way as the try that worked (a particle that needed k halvings to pass a
  // neighbour tries k − 1 next, not 0: going back to T at once would cost the k halvings again
  // at every sub-step). Each deepening counts; after max_substeps the step is rolled back. The
  // last positions tried are T itself (depth 0 copies it), so an accepted step ends exactly at
  // the integrator's targets. An edge whose vector reverses
  // between V and an attempt (r⁰·r¹ < 0: its particles passed each other) rolls back, or with
  // `passing: substep` counts as not repaired: its two particles are halved too. Points on straight paths that miss each other
  // by b > 0 give r⁰·r¹ > 0 once the remaining relative move is below ~b, so only a collision
  // (b = 0) runs out of max_substeps.
  Outcome untangle(StepContext& ctx, const Mesh& m, Tally h) {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    const std::size_t n = s.n();
    const std::size_t bytes = s.field(ff::fields::position).bytes();
    const auto box = PeriodicBox<double>::make(s.box.L);
    R* target = target_.get(2 * n);
    std::uint8_t* moving = moving_.get(n);
    std::uint32_t* depth = depth_.get(n);
    bool at_target = true, announced = false;
    std::int64_t halvings = 0;
    const auto stop = [&](std::string why, std::vector<std::uint64_t> who) {
      if (announced) mem_.copy(s.field(ff::fields::position).data<R>(ctx), target, bytes, st);  // as detect left it
      ctx.metrics.set("substeps", double(halvings));
      return Outcome::request_rollback("delaunay.flip: " + why + "; the step is retried with a smaller time step",
                                       std::move(who));
    };
    while (true) {
      if (h[kThrough] && !passing_) {
        auto ids = edge_vertices(s, where_, mem_, int(h[kThroughAt]), st);
        return stop("particles " + list_ids(ids) + " passed through each other between intermediate positions (r0.r1 < 0)",
                    ids);
      }
      R* x = s.field(ff::fields::position).data<R>(ctx);
      R* v = s.field(fields::position_prev).data<R>(ctx);
      if (!h[kInverted] && !h[kThrough]) {
        if (at_target) break;
        mem_.copy(v, x, bytes, st);  // valid here: the next reference
        topology(s, true, st);
        deep_.reset(std::array<int, 0>{}, st);
        loops_.shallower(n, Shallower<R>{Points<R>{v, box}, target, x, depth, deep_.ptr()}, st);
        at_target = deep_.read(st)[0] == 0;
      } else {
        if (halvings == p_.max_substeps) {
          if (h[kThrough]) {
            auto ids = edge_vertices(s, where_, mem_, int(h[kThroughAt]), st);
            return stop("particles " + list_ids(ids) + " passed through each other (r0.r1 < 0) even after halving the "
                            "moves " + std::to_string(halvings) + " time(s) (max_substeps)",
                        ids);
          }
          return stop(std::to_string(h[kInverted]) + " inverted triangle(s) remain after halving the moves " +
                          std::to_string(halvings) + " time(s) (max_substeps)",
                      {});
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
        ++halvings;
        loops_.moving(n, MarkInvertedVertices<R>{m, Points<R>{x, box}, Points<R>{v, box}, moving}, st);
        loops_.deepen(n, Deepen<R>{Points<R>{v, box}, target, x, moving, depth}, st);
        // The flips made for the positions farther out need not be valid nearer V (a flipped
        // triangle can stay inverted however close to V its vertices come): repair from V's.
        topology(s, false, st);
        at_target = false;
      }
      h = repair(s, m, Points<R>{x, box}, v, true, st);
    }
    // position_prev ← position (= T): the next step's reference.
    if (!announced) ctx.will_overwrite(fields::position_prev);
    mem_.copy(s.field(fields::position_prev).data<R>(ctx), s.field(ff::fields::position).data<R>(ctx), bytes, st);
    status(s)[kPrevKept] = 0;
    ctx.metrics.set("substeps", double(halvings));
    return Outcome::ok();
  }

  // Substep mode: keep (`keep`) the topology where the triangulation is valid (V), or put it
  // back (the three topology fields, one after another in topology_).
  void topology(State& s, bool keep, CUstream_st* st) {
    std::size_t words = 0;
    for (const char* f : {fields::halfedge, fields::opposite, fields::vertex_edge}) words += s.field(f).size();
    std::int32_t* kept = topology_.get(words);
    for (const char* f : {fields::halfedge, fields::opposite, fields::vertex_edge}) {
      Field& fl = s.field(f);
      std::int32_t* d = fl.data<std::int32_t>(where_);
      if (keep) mem_.copy(kept, d, fl.bytes(), st);
      else mem_.copy(d, kept, fl.bytes(), st);
      kept += fl.bytes() / sizeof(std::int32_t);
    }
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
  Scratch<std::uint8_t> go_;
  Scratch<R> target_;            // substep: the integrator's targets T
  Scratch<std::uint8_t> moving_; // substep: particles with an inverted triangle around them
  Scratch<std::int32_t> topology_; // substep: the topology valid at V (halfedge, opposite, vertex_edge)
  Scratch<std::uint32_t> depth_;   // substep: each particle's depth (Deepen, Shallower)
  Counters<1> deep_;               // substep: particles not yet at their target after Shallower
  unsigned flips_ = 0;
  std::int64_t rounds_ = 0;
};

}  // namespace ff::delaunay

FLIPFLOW_STAGE(ff::delaunay::Flip)
