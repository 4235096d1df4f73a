// overlap_correct: hard-core exclusion on the maintained Delaunay triangulation (Carter et al.
// 2017, sec. 2.3 and 4.4). Every pair joined by a Delaunay edge and closer than
// σ_ij = (σ_i + σ_j)/2 is pushed apart along its line of centres (kernel.h); the displacements
// are summed per particle, capped, applied, and the pass repeats until no pair overlaps by more
// than `tolerance`·σ_ij. Needs the triangulation: delaunay stages must come before it in the step.
//
// When no edge overlaps, no pair does, but only for diameters that do not differ too much
// (seed-gaps C5): if σ_ik² + σ_jk² ≥ σ_ij² for every triple of diameters, the overlapping pair with
// the smallest r_ij/σ_ij is a Gabriel edge (a point k inside its diametral circle has
// r_ik² + r_jk² < r_ij², so r_ik/σ_ik or r_jk/σ_jk would be smaller still), hence a Delaunay edge.
// For additive diameters the worst triple is (largest, largest, smallest), and the condition is
// σ_min/σ_max ≥ √2 − 1 ≈ 0.414. Below that a small disk can sit inside the diametral circle of
// two overlapping large ones, their edge need not exist, and the step can end with the overlap
// left: configure() refuses such diameters (check_diameter_ratio), pointing to
// overlap_correct.verlet, which sees every pair within its cutoff. (Also, the triangulation is
// Delaunay for the positions before the correction, not during it: pushes larger than the
// margins of the Gabriel argument can meet pairs that are not edges; the next step's
// triangulation finds them.)
//
// Walls (`walls: x | y`, kernel.h's wall_term): the triangulation stays that of the torus. Its
// edges across the seam join particles facing each other across the walls; along the wall axis a
// pair's offset is the plain difference of the coordinates, so those edges never overlap and
// never push. A particle that an integrator carried through a wall is wrapped to the far side
// and triangulated there; its wall term (on the unwrapped coordinate) reflects it back within
// the step, and its overlaps at the new place with particles that were not its neighbours are
// left to the next step's triangulation (a crossing needs a single move of more than σ/2).
#pragma once
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <memory>
#include <sstream>
#include <string>

#include "core/base/error.h"
#include "core/backend/exec.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/delaunay/common/fields.h"
#include "stages/delaunay/common/team.h"
#include "stages/overlap_correct/kernel.h"
#include "stages/overlap_correct/params.h"

namespace ff::overlap {

// One call of a backend's iteration loop: the counters of each gather it ran, in order (a loop
// may put the call's pairs and correction, summed over the gathers that went on, in the first
// row and 0 in the others: read_back needs only their sums; and a row's kBad may be 1 for any
// nonzero count but in the row where the loop gives up, whose count read_back reports; the dense
// kernels do both). The CPU
// loop returns to the host's loop every kBatch gathers; the device's runs up to kDeviceBatch in
// one launch, more than the default max_iterations, so that one launch ends the correction (its
// read may then wait past the step: StepContext::may_defer_past_step).
inline constexpr int kBatch = 64;
inline constexpr int kDeviceBatch = 1024;
struct Batch {
  std::uint64_t counters[kDeviceBatch][kCounters];
  int gathers = 0;
};

// Whether gather k's counters let the loop apply its displacements and go on (the host replays
// the same rule to report errors).
FF_HD bool keeps_going(const std::uint64_t* c, std::int64_t k, std::int64_t max_iterations) {
  return c[kBroken] == 0 && c[kBad] != 0 && k < max_iterations;
}

// A step's problem for a backend's loop. The loops compile a variant for each of walls (on when
// overlaps.wall_axis >= 0: Overlaps<R, true>, else the wall code is left out) and mark (on when
// touched is set: else no touched counter in the sums), so a run without them runs the code it
// ran before they existed.
template <class R>
struct Problem {
  Overlaps<R, true> overlaps;  // the loops take with_walls<false>() of it when wall_axis < 0
  R* pos;                // == overlaps.pos
  std::int32_t* image;
  PeriodicBox<R> box;
  std::size_t n;
  std::uint8_t* touched = nullptr;  // the touched field (mark: true), else null
  // The device only: an attempt decided on the device (StepContext::gate). While *gate is
  // non-zero the launch moves nothing and reports one gather that found nothing (the
  // correction ends at iteration 0).
  const unsigned* gate = nullptr;
};

// overlap_correct's parameters: the corrections' (params.h) and the diameter-ratio check.
struct DelaunayParams : Params {
  bool check_diameter_ratio = true;

  template <class P>
  void describe(P& p) {
    Params::describe(p);
    p(check_diameter_ratio, "check_diameter_ratio",
      "refuse diameters with σ_min/σ_max < √2 − 1, for which an overlapping pair need not be a Delaunay edge and "
      "overlaps can survive the correction (seed-gaps C5); false runs anyway (use overlap_correct.verlet instead "
      "where you can)");
  }
};

// The smallest σ_min/σ_max for which every triple of additive diameters has σ_ik² + σ_jk² ≥ σ_ij².
inline constexpr double kMinDiameterRatio = 0.41421356237309503;  // √2 − 1

// A backend's iteration loop and the scratch memory it keeps across steps (cpu.cpp: host work
// lists per tile; cuda.cu: device arrays from the backend object, Scratch in core/backend/memory.h).
template <class R>
struct OverlapCorrectLoops {
  virtual ~OverlapCorrectLoops() = default;
  // Runs gathers k0, k0 + 1, ..., applying the displacements after each one that keeps_going(),
  // until one does not or max_gathers() were run, and fills `out` by the time finish() returns:
  // start() enqueues the work where it can (the device), finish() waits for it. Sizes the
  // scratch for p.n.
  virtual void start(const Problem<R>& p, std::int64_t k0, std::int64_t max_iterations, Batch& out,
                     CUstream_st* s) = 0;
  virtual void finish(Batch& out) = 0;
  // The most gathers one start() runs.
  virtual int max_gathers() const = 0;
  void iterate(const Problem<R>& p, std::int64_t k0, std::int64_t max_iterations, Batch& out, CUstream_st* s) {
    start(p, k0, max_iterations, out, s);
    finish(out);
  }
};

// The loops of each backend (cpu.cpp, cuda.cu).
template <class R>
std::unique_ptr<OverlapCorrectLoops<R>> overlap_correct_loops(CpuExec);
template <class R>
std::unique_ptr<OverlapCorrectLoops<R>> overlap_correct_loops(CudaExec);

template <class R>
class OverlapCorrect final : public Stage {
 public:
  static StageDecl declaration() {
    return {"overlap_correct",
            "push overlapping pairs apart along Delaunay edges (reflect or contact), iterated until none overlap",
            schema_of<DelaunayParams>(), {2}, false};
  }

  template <class Exec>
  OverlapCorrect(const ParamValues& v, const RunInfo& info, Exec exec)
      : p_(params_from<DelaunayParams>(v)),
        team_(in_team(info.team) ? info.team : nullptr),
        where_(Exec::where),
        wall_axis_(wall_axis_of(p_.walls)),
        loops_(overlap_correct_loops<R>(exec)) {}

  std::vector<Access> accesses() const override {
    std::vector<Access> a{{fields::position, where_, Mode::readwrite},
                          {fields::image, where_, Mode::readwrite},
                          {fields::diameter, where_, Mode::read},
                          {delaunay::fields::halfedge, where_, Mode::read},
                          {delaunay::fields::vertex_edge, where_, Mode::read},
                          {delaunay::fields::status, Where::host, Mode::read}};
    if (p_.mark) a.push_back({touched_field, where_, Mode::write});  // every entry written each step
    return a;
  }

  void configure(State& s) override {
    if (s.dim() != 2)
      throw InputError("overlap_correct works on the 2D Delaunay triangulation (system.dimensions is " +
                       std::to_string(s.dim()) + ")");
    for (const char* f : {delaunay::fields::halfedge, delaunay::fields::vertex_edge, delaunay::fields::status})
      if (!s.has_field(f))
        throw InputError(std::string("overlap_correct needs the Delaunay triangulation (field '") + f +
                         "'), which no stage before it provides: put the delaunay stages before it in `step:` "
                         "(delaunay.detect_inversion, delaunay.flip, delaunay.lawson after the integrator, or "
                         "delaunay.build)");
    diam_.template measure<R>(s, nullptr);
    if (!(diam_.min > 0)) throw InputError("overlap_correct: every particle needs a positive diameter");
    if (const std::string e = ratio_problem(s); !e.empty()) throw InputError(e);
    if (wall_axis_ > 1)
      throw InputError("overlap_correct: walls: z: the triangulation is 2D; use walls: x or y");
    check_walls(s, wall_axis_, diam_.max, "overlap_correct");
    unit_ = diam_.max;
    tol_ = tolerance_for(p_, s, diam_.min);
    if (team_ && (p_.mark || wall_axis_ >= 0))
      throw InputError("overlap_correct: mark: true and walls do not run in a team of ranks yet: run on one GPU");
    if (p_.mark) {
      Field& f = s.add_particle_field(touched_field, DType::u8, 1);
      f.acquire(Where::host, Mode::write);
      std::memset(f.host<std::uint8_t>(), 0, s.n());
    }
  }

  // In a decomposed team each rank corrects its owned particles from their stars in its own
  // triangulation (exact: common/team.h's band condition, checked here for the triangulation
  // Lawson left), reading the ghosts' positions, which every iteration's exchange keeps current.
  // On the device it follows a decider's gate (StepContext::gate; Problem::gate).
  Scheduling scheduling() const override {
    Scheduling sch;
    sch.team = TeamWork::decomposed;
    sch.reads_ghosts = true;
    sch.communicates = true;
    sch.follows_gate = where_ == Where::device;
    return sch;
  }

  Outcome run(StepContext& ctx) override {
    if (team_ && ctx.ghosts) return run_team(ctx);
    settle(ctx, true);  // the read the last step left past its end, if any (the particles have moved since)
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    if (!s.field(delaunay::fields::status).host<std::int32_t>()[delaunay::kBuilt])
      throw RunError("overlap_correct: step " + std::to_string(ctx.host_params.step) +
                     ": no Delaunay triangulation has been built yet; put delaunay.build (or "
                     "delaunay.detect_inversion) before overlap_correct");
    const std::size_t n = s.n();
    R* x = s.field(fields::position).data<R>(ctx);
    std::int32_t* img = s.field(fields::image).data<std::int32_t>(ctx);
    const R* diam = s.field(fields::diameter).data<R>(ctx);
    const std::int32_t* he = s.field(delaunay::fields::halfedge).data<std::int32_t>(ctx);
    const std::int32_t* ve = s.field(delaunay::fields::vertex_edge).data<std::int32_t>(ctx);
    if (diam_.stale(s)) {  // written since: measure again
      diam_.template measure<R>(s, st);
      if (const std::string e = ratio_problem(s); !e.empty())
        throw RunError("overlap_correct: step " + std::to_string(ctx.host_params.step) + ": the diameters changed; " + e);
      if (wall_axis_ >= 0 && !(s.box.L[wall_axis_] >= 2 * diam_.max))
        throw RunError("overlap_correct: step " + std::to_string(ctx.host_params.step) +
                       ": the diameters changed; the largest is now more than half the distance between the walls");
    }
    const Overlaps<R, true> overlaps{push_rule(p_, s, tol_, unit_, diam_, wall_axis_),
                                     x,
                                     diam,
                                     he,
                                     ve,
                                     std::int32_t(n),
                                     diam_.max * diam_.max,
                                     wall_axis_ >= 0 ? img : nullptr};
    std::uint8_t* touched = p_.mark ? s.field(touched_field).data<std::uint8_t>(ctx) : nullptr;
    const Problem<R> prob{overlaps, x, img, PeriodicBox<R>::make(s.box.L), n, touched, ctx.gate};

    loops_->start(prob, 0, p_.max_iterations, batch_, st);
    // When one call of the device's loop runs every gather the correction can need (max_iterations
    // below kDeviceBatch), nothing after this step depends on its read: it may wait past the step
    // (the next step's kernels queue behind this one's instead of behind the host).
    if (where_ == Where::device && ctx.may_defer_past_step() && p_.max_iterations < loops_->max_gathers()) {
      pending_ = true;
      pending_step_ = ctx.host_params.step;
      return Outcome::ok();
    }
    loops_->finish(batch_);
    read_back(ctx, ctx.host_params.step, &prob);
    return Outcome::ok();
  }

  void settle_pending(StepContext& ctx) override { settle(ctx, false); }

  double effective_tolerance() const { return tol_; }

  // Why these diameters break the Delaunay-edge argument (see the top of this file), or "".
  std::string ratio_problem(const State& s) const {
    if (!p_.check_diameter_ratio || diam_.min >= kMinDiameterRatio * diam_.max) return "";
    std::string small, large;
    for (std::size_t t = 0; t < s.species_diameter.size() && t < s.species.size(); ++t) {
      if (s.species_diameter[t] == diam_.min) small = " (type " + s.species[t] + ")";
      if (s.species_diameter[t] == diam_.max) large = " (type " + s.species[t] + ")";
    }
    std::ostringstream os;
    os << "overlap_correct: the smallest diameter " << diam_.min << small << " is less than √2 − 1 = 0.4142 times the "
       << "largest " << diam_.max << large << " (ratio " << diam_.min / diam_.max
       << "): then σ_ik² + σ_jk² < σ_ij² for two large disks i, j and a small one k, an overlapping pair need not be a "
          "Delaunay edge, and overlaps can survive the correction. Use overlap_correct.verlet (with neighbors.verlet), "
          "which sees every pair within its cutoff, or set check_diameter_ratio: false to run anyway";
    return os.str();
  }


  // The team's loop, on the host: every iteration gathers each owned particle around its fan
  // (Overlaps::gather, the walk the device loop makes: the same fixed-point sums, so the same
  // displacement bits as the edge passes and work lists alone, whose result is that of
  // gathering every particle), sums the counts over the ranks (all iterate alike), applies the
  // owned displacements and sends the moved positions to the ghosts before the next gather.
  // Pairs are counted once over the team: an owned particle counts a neighbour of higher id.
  Outcome run_team(StepContext& ctx) {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    for (const Access& a : accesses()) s.field(a.field).acquire(Where::host, a.mode, st);
    if (!s.field(delaunay::fields::status).host<std::int32_t>()[delaunay::kBuilt])
      throw RunError("overlap_correct: no Delaunay triangulation has been built yet");
    const std::size_t n = s.n(), owned = s.n_owned();
    R* x = s.field(fields::position).host<R>();
    std::int32_t* img = s.field(fields::image).host<std::int32_t>();
    const R* diam = s.field(fields::diameter).host<R>();
    Field& idf = s.field(fields::particle_id);
    idf.acquire(Where::host, Mode::read, st);
    const std::uint32_t* id = idf.host<std::uint32_t>();
    delaunay::band_check<R>(ctx, "overlap_correct", fields::position);  // where Lawson left it Delaunay
    if (diam_.stale(s)) diam_.template measure<R>(s, st);
    const Overlaps<R, true> ov{push_rule(p_, s, tol_, unit_, diam_, wall_axis_),
                               x,
                               diam,
                               s.field(delaunay::fields::halfedge).host<std::int32_t>(),
                               s.field(delaunay::fields::vertex_edge).host<std::int32_t>(),
                               std::int32_t(n),
                               diam_.max * diam_.max,
                               wall_axis_ >= 0 ? img : nullptr};
    return iterate_team(ctx, ov.template with_walls<false>(), id, owned);
  }

  template <bool W>
  Outcome iterate_team(StepContext& ctx, const Overlaps<R, W>& ov, const std::uint32_t* id, std::size_t owned) {
    State& s = ctx.state;
    R* x = s.field(fields::position).host<R>();
    std::int32_t* img = s.field(fields::image).host<std::int32_t>();
    const PeriodicBox<R> box = PeriodicBox<R>::make(s.box.L);
    std::vector<VertexPush> push(owned);
    std::int64_t iterations = 0;
    std::uint64_t pairs = 0;
    std::uint64_t correction_fixed = 0;  // as read_back: converted once
    for (;;) {
      // bad, pairs, broken: each pair once over the team (the owned end of lower id counts it)
      std::int64_t c[3] = {0, 0, 0};
      for (std::size_t v = 0; v < owned; ++v) {
        VertexPush& p = push[v];
        p = ov.gather(int(v));
        c[2] += p.broken ? 1 : 0;
        if (!p.touched) continue;
        // gather counted the overlapping neighbours of higher index: every ghost (they come
        // after the owned particles); count those of higher id instead.
        double xv, yv;
        load_xy(x, int(v), xv, yv);
        const double sv = ov.diameter_of(int(v));
        unsigned pv = 0, bv = 0;
        ov.for_each_neighbor(int(v), [&](int u, int) {
          if (!(id[u] > id[v])) return;
          double xu, yu, tx, ty;
          load_xy(x, u, xu, yu);
          const PairOverlap o = pair_term(ov.min_image(xu - xv, 0), ov.min_image(yu - yv, 1), sv,
                                          ov.diameter_of(u), ov.factor, ov.tol, int(v), u, tx, ty);
          if (!counted(o)) return;
          ++pv;
          if (o == kBeyond) ++bv;
        });
        c[0] += bv;
        c[1] += pv;
      }
      team_->all_reduce(c, 3, ReduceOp::sum);
      if (c[2])
        throw RunError("overlap_correct: step " + std::to_string(ctx.host_params.step) +
                       ": the triangulation is corrupt on a rank of the team (a fan that does not close)");
      if (!c[0]) break;
      if (iterations == p_.max_iterations) give_up(ctx, ctx.host_params.step, std::uint64_t(c[0]), false);
      // The moves are written on the host: say so before every apply (a refresh sends from
      // the device when every field is current there; Domain::refresh).
      s.field(fields::position).acquire(Where::host, Mode::readwrite, ctx.stream);
      s.field(fields::image).acquire(Where::host, Mode::readwrite, ctx.stream);
      std::int64_t moved = 0;
      for (std::size_t v = 0; v < owned; ++v) {
        const VertexPush& p = push[v];
        if (p.dx == 0 && p.dy == 0) continue;
        apply_one(x, img, box, v, p.dx, p.dy);
        moved += std::int64_t(ov.fixed_len(p.len));
      }
      team_->all_reduce(&moved, 1, ReduceOp::sum);
      ctx.ghosts->refresh(s, {fields::position, fields::image});
      x = s.field(fields::position).host<R>();  // refresh wrote the ghosts' entries on the host
      pairs += std::uint64_t(c[1]);
      correction_fixed += std::uint64_t(moved);
      ++iterations;
    }
    ctx.metrics.set("iterations", double(iterations));
    ctx.metrics.set("pairs", double(pairs));
    ctx.metrics.set("correction", double(correction_fixed) / kFixedOne * unit_);
    return Outcome::ok();
  }
 private:
  // The read left past its step. `moved`: the next step's stages before this one have run (an
  // error then names the worst pair where the particles are now).
  void settle(StepContext& ctx, bool moved) {
    if (!pending_) return;
    pending_ = false;
    loops_->finish(batch_);
    read_back(ctx, pending_step_, nullptr, moved);
  }

  // Replays the loop's rule on each gather's counters (batch_: the loop's first call, finished):
  // error, converged, or apply and go on, calling the loop again while it is not done. A read
  // left past its step has no problem to call it with (`prob` null): its call ran every gather
  // the correction could need, so it ended the correction. Sets the step's metrics.
  void read_back(StepContext& ctx, std::uint64_t step, const Problem<R>* prob, bool moved = false) {
    std::int64_t iterations = 0;
    // The correction is summed in its fixed point and converted once: the same value however a
    // loop spreads it over its rows (the dense kernels put a launch's total in its first row).
    std::uint64_t pairs = 0, first_touches = 0, correction_fixed = 0;
    for (bool done = false, first = true; !done; first = false) {
      if (!first) {
        if (!prob)
          throw RunError("overlap_correct: step " + std::to_string(step) + ": the device's loop stopped after " +
                         std::to_string(iterations) + " iterations without ending the correction (internal error)");
        loops_->iterate(*prob, iterations, p_.max_iterations, batch_, ctx.stream);
      }
      if (batch_.gathers < 1 || batch_.gathers > loops_->max_gathers())
        throw RunError("overlap_correct: step " + std::to_string(step) + ": the iteration loop reported " +
                       std::to_string(batch_.gathers) + " gathers");
      for (int j = 0; j < batch_.gathers && !done; ++j) {
        const std::uint64_t* h = batch_.counters[j];
        if (h[kBroken])
          throw RunError("overlap_correct: step " + std::to_string(step) + ": the triangulation is corrupt (" +
                         std::to_string(h[kBroken]) + " failed check(s): half-edge indices out of range, next "
                         "pointers that are not a permutation, or the half-edges around a particle that do not "
                         "form a closed fan); a delaunay stage before overlap_correct failed to keep it valid");
        first_touches += h[kTouched];
        if (!h[kBad]) {
          done = true;
          break;
        }
        if (iterations == p_.max_iterations) give_up(ctx, step, h[kBad], moved);
        pairs += h[kPairs];
        correction_fixed += h[kCorrection];
        ++iterations;
      }
    }
    ctx.metrics.set("iterations", double(iterations));
    ctx.metrics.set("pairs", double(pairs));
    ctx.metrics.set("correction", double(correction_fixed) / kFixedOne * unit_);
    if (p_.mark) {
      ctx.metrics.set("touched", double(first_touches));
      ctx.metrics.set("touched_fraction", double(first_touches) / double(ctx.state.n()));
    }
  }

  // The error path: find the worst pair on the host (fields are copied there) and stop.
  // `moved`: read back past its step (may_defer_past_step) after the next step moved the particles.
  [[noreturn]] void give_up(StepContext& ctx, std::uint64_t step, std::uint64_t bad, bool moved) {
    State& s = ctx.state;
    for (const Access& a : accesses()) s.field(a.field).acquire(Where::host, Mode::read, ctx.stream);
    const R* x = s.field(fields::position).host<R>();
    const R* d = s.field(fields::diameter).host<R>();
    const std::int32_t* he = s.field(delaunay::fields::halfedge).host<std::int32_t>();
    const auto box = PeriodicBox<double>::make(s.box.L);
    int wa = -1, wb = -1;
    double worst = -1, wr = 0, ws = 0;
    for (std::size_t e = 0; e < 3 * s.n(); ++e) {
      const int a = he[4 * e], b = he[4 * e + 2];
      const double dx = double(x[2 * b]) - double(x[2 * a]), dy = double(x[2 * b + 1]) - double(x[2 * a + 1]);
      const double rx = wall_axis_ == 0 ? dx : box.min_image(dx, 0), ry = wall_axis_ == 1 ? dy : box.min_image(dy, 1);
      const double sab = 0.5 * (double(d[a]) + double(d[b])), r = std::sqrt(rx * rx + ry * ry);
      if ((sab - r) / sab > worst) {
        worst = (sab - r) / sab;
        wa = std::min(a, b);
        wb = std::max(a, b);
        wr = r;
        ws = sab;
      }
    }
    std::ostringstream os;
    os << "overlap_correct: step " << step << ": " << bad << " pair(s) still overlap by more than tolerance = " << tol_
       << " after max_iterations = " << p_.max_iterations << " iterations; the worst "
       << (moved ? "now (the next step had moved the particles when this was read back) " : "") << "is particles " << wa
       << " and " << wb << " at r = " << wr << " with σ_ij = " << ws << " (overlap " << worst
       << "·σ_ij)" << (wall_axis_ >= 0 ? " or a particle and a wall" : "") << ". " << unconverged_advice(p_);
    throw RunError(os.str());
  }

  DelaunayParams p_;
  Communicator* team_;  // a decomposed team's rank (with StepContext::ghosts); null alone
  Where where_;
  int wall_axis_;  // walls: 0 (x) or 1 (y); -1: none
  std::unique_ptr<OverlapCorrectLoops<R>> loops_;
  Batch batch_;
  bool pending_ = false;  // a read left past its step (settle_pending)
  std::uint64_t pending_step_ = 0;
  double unit_ = 1;  // length unit of the fixed-point correction counter (largest diameter)
  DiameterRange diam_;  // min equal to max: the walks read no diameters
  double tol_ = 1e-6;
};

}  // namespace ff::overlap

FLIPFLOW_STAGE(ff::overlap::OverlapCorrect)
