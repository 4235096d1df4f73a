// delaunay.flip: repair the inverted triangles that delaunay.detect_inversion marked, by edge
// flips (Carter et al. 2017, figs. 5–6), in parallel without conflicts (common/flip.h). Each
// round flips the marked edges that win their triangles, then re-detects; a flip turns one
// inverted triangle into two positive ones and touches nothing else, so the number of inverted
// triangles drops every round. Whatever cannot be repaired this way requests a rollback, or,
// with `on_unrepairable: substep`, is untangled through intermediate positions (untangle below;
// Porro et al. §3) so that the step still ends at the integrator's targets; so are particles
// that passed each other (an edge vector reversed), which detect_inversion leaves to it then.
#pragma once
#include <algorithm>
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
  // on_unrepairable: substep (lists)
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

// The plain element loops of the backend object (CpuExec or CudaExec) this stage.h is compiled
// for (core/stage/stage_registration.h).
template <class R, class Exec>
FlipLoops<R> flip_loops(Exec) {
  return {&Exec::template for_each<DecideFlips>,     &Exec::template for_each<ApplyFlips>,
          &Exec::template for_each<MarkInversions<R>>, &Exec::template for_each<MarkListed<R>>,
          &Exec::template for_each<DecideListed>,    &Exec::template for_each<ApplyListed>,
          &Exec::template for_each<EdgesAround>,
          &Exec::template for_each<FindMoving<R>>,
          &Exec::template for_each<RestoreAndDeepen<R>>, &Exec::template for_each<ShallowerAndList<R>>,
          &Exec::template for_each<CopyListed<R>>,   &Exec::template for_each<ResetTry>};
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
        halved_stamp_(exec) {}

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
    Outcome out = Outcome::ok();
    if (kept) {
      // Substep mode marks again with the r⁰·r¹ test against position_prev (untangle): detect
      // left reversed edges to the untangling, which must see them.
      status(s)[kPending] = 0;
      out = untangle(ctx, m);
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
    ensure_topology(ctx, accesses());
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
  SubTally read_try(State& s, CUstream_st* st) {
    const auto& both = sub_.read(st);
    const unsigned* f = both.data();
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
  // untangle); they are marked with the r⁰·r¹ test against V (`prev`), the troubled ones listed
  // (first_), then each round decides and flips among the last troubled edges and re-marks
  // those and the edges around each flip (trouble_). The first round is launched right after
  // the first marking, before the host knows whether anything is marked (with nothing marked it
  // flips nothing and re-marks the same edges): one host read a try when a round suffices. Only
  // rounds that flip count (as rounds run only while something is marked, and then flip). Leaves
  // the last troubled list in last_ / n_last_ (every edge whose mark is 1 is in it), the first
  // in first_ / n_first_, and returns read_try's counters.
  SubTally repair_listed(State& s, const Mesh& m, const Points<R>& pts, const R* prev, const std::int32_t* work,
                         ListSpan span, CUstream_st* st) {
    std::uint8_t* mark = s.field(fields::flip_mark).data<std::uint8_t>(where_);
    const std::size_t E = edge_count(s.n());
    std::uint8_t* go = go_.get(E);
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
      if (!h[kMarked] || rounds >= p_.max_rounds) break;
      list = t;
      listed = ListSpan{nullptr, n_last_};
    }
    rounds_ += rounds;
    return h;
  }
  void reset_round(CUstream_st* st) { loops_.reset(1, ResetTry{nullptr, round_block(), false, false}, st); }

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
  //
  // Every place in trouble is halved in the same try, and a try costs what the trouble costs:
  // only the first try marks every edge; after it each try marks the edges that can have
  // changed status (kernel.h, MarkListed): the last try's troubled edges, the first marking's
  // (at V's topology, which a failed try restores) and those around the particles that moved
  // (deepened, or shallower after an accepted try); a flip saves V's value of each record it is
  // the first to touch (TouchLog), so a failed try puts back only those and an accepted one
  // copies nothing (no copy of the whole topology either); V is updated for the active
  // particles (depth > 0) only, after the first acceptance. The
  // result is the one full passes give, bit for bit (the same marks everywhere, hence the same
  // flips). The lists' loops run over guesses of their lengths (ListSpan), so the host waits
  // once a try when one repair round suffices. Metrics: substeps (halvings), substep_tries
  // (repair passes), substep_depth (the deepest particle's halvings), substep_particles
  // (particles halved at least once).
  Outcome untangle(StepContext& ctx, const Mesh& m) {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    const std::size_t n = s.n(), E = edge_count(n);
    const std::size_t bytes = s.field(ff::fields::position).bytes();
    const auto box = PeriodicBox<double>::make(s.box.L);
    R* target = target_.get(2 * n);
    std::uint32_t* depth = depth_.get(n);
    unsigned* c = first_block();
    bool announced = false, accepted = false;
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
    SubTally h = repair_listed(s, m, Points<R>{s.field(ff::fields::position).data<R>(where_), box},
                               s.field(fields::position_prev).data<R>(where_), nullptr, ListSpan{nullptr, E}, st);
    while (true) {
      if (h[kThrough] && !passing_) {
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
      if (!h[kInverted] && !h[kThrough]) {
        if (n_active == 0) break;  // at the targets
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
        if (halvings == p_.max_substeps) {
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
      h = repair_listed(s, m, Points<R>{x, box}, v, w, ListSpan{c + kWorkCount, launched}, st);
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
    TouchedRecords t{touched_edges_.get(edge_count(s.n())), h[kTouchedEdgeCount], touched_vertices_.get(s.n())};
    t.from_he = k.he, t.from_opp = k.opp, t.from_vedge = k.vedge;
    t.to_he = s.field(fields::halfedge).data<std::int32_t>(where_);
    t.to_opp = s.field(fields::opposite).data<std::int32_t>(where_);
    t.to_vedge = s.field(fields::vertex_edge).data<std::int32_t>(where_);
    return t;
  }
  // The touched lists' generation (one for the edge and the vertex stamps).
  void next_touched_gen(std::size_t n, CUstream_st* st) {
    const std::size_t E = edge_count(n);
    unsigned* ve = touched_vertex_stamp_.get(n);
    if (next_gen(touched_gen_, touched_edge_stamp_.get(E), E, st) == 1) mem_.fill(ve, 0, n * sizeof(unsigned), st);
  }

  static constexpr std::array<int, 4> kMinSlots{kThroughAt, kTwiceAt, kUnrepairableAt, kTooLongAt};
  static constexpr std::size_t kFirstRoundGuess = std::size_t(1) << 16;  // repair_listed
  FlipParams p_;
  Communicator* team_;  // a decomposed team's rank; null alone
  bool substep_;
  bool passing_;
  Where where_;
  FlipLoops<R> loops_;
  const MemoryOps& mem_;
  Counters<kInversionCounters> counters_;
  Scratch<std::uint8_t> go_;
  Scratch<R> target_;              // substep: the integrator's targets T
  Scratch<std::int32_t> topology_; // substep: V's topology where flips touched it (TouchLog)
  Scratch<std::uint32_t> depth_;   // substep: each particle's depth (Deepen, Shallower)
  // Substep lists (kernel.h): their lengths and the step's statistics in sub_.
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
  std::int64_t tries_ = 0;
  unsigned flips_ = 0;
  std::int64_t rounds_ = 0;
};

}  // namespace ff::delaunay

FLIPFLOW_STAGE(ff::delaunay::Flip)
