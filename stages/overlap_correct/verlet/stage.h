// overlap_correct.verlet: hard-core exclusion on the Verlet list, 2D and 3D (Carter et al. 2017's
// short-range runs correct overlaps with Verlet lists, Fig. 10b; seed-gaps G4). Every listed pair
// closer than σ_ij = (σ_i + σ_j)/2 is pushed apart along its line of centres with
// overlap_correct's rule (../kernel.h: reflect or contact, the same cap, tolerance,
// max_iterations and fixed-point sums); the pass repeats until no pair overlaps by more than
// `tolerance`·σ_ij. Needs neighbors.verlet before it in the step (after the integrator), with
// a cutoff of at least the largest diameter.
//
// The list holds every pair closer than the cutoff only while no particle has moved skin/2 since
// it was built, and the corrections move particles. So after the loop the stage takes the
// largest displacement since the build (neighbors.verlet's test, verlet/build.h); beyond skin/2
// it rebuilds the list (the same build) and runs the loop again on it (metric `list_rebuilds`).
// The test also covers moves made between neighbors.verlet and this stage.
//
// In 2D the pushes are overlap_correct's bit for bit, so on the same overlapping pairs the two
// give the same trajectory (test_verlet.cpp checks it for brownian hard disks).
//
// Walls (`walls: x | y | z`, ../kernel.h's wall_term): each particle's own term, on its unwrapped
// coordinate; along the wall axis pair offsets are plain differences, so the list's pairs across
// the seam never push. A particle that an integrator carried through a wall is reflected back
// within the step; that move is longer than skin/2, so the list is rebuilt and the particle's
// overlaps at its new place are corrected in the same step.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "core/backend/comm.h"
#include "core/backend/exec.h"
#include "core/base/error.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/neighbors/list.h"
#include "stages/neighbors/verlet/build.h"
#include "stages/overlap_correct/kernel.h"
#include "stages/overlap_correct/params.h"
#include "stages/overlap_correct/verlet/kernel.h"

namespace ff::overlap {

template <class R, int D, bool Walls, bool Mark>
struct VerletCorrectLoops {
  ReduceLoop<Gather<R, D, Walls, Mark>, std::uint64_t> gather;
  ReduceLoop<Apply<R, D>, std::uint64_t> apply;
};

// The loops of each variant of the gather (walls and mark compiled in or out, verlet/kernel.h),
// in D dimensions.
template <class R, int D>
struct VerletCorrectVariants {
  VerletCorrectLoops<R, D, false, false> plain;
  VerletCorrectLoops<R, D, false, true> mark;
  VerletCorrectLoops<R, D, true, false> walls;
  VerletCorrectLoops<R, D, true, true> walls_mark;

  template <class Exec>
  static VerletCorrectVariants make() {
    return {loops<Exec, false, false>(), loops<Exec, false, true>(), loops<Exec, true, false>(),
            loops<Exec, true, true>()};
  }
  template <class Exec, bool Walls, bool Mark>
  static VerletCorrectLoops<R, D, Walls, Mark> loops() {
    return {&Exec::template sum<Gather<R, D, Walls, Mark>>, &Exec::template sum<Apply<R, D>>};
  }
};

template <class R>
class OverlapCorrectVerlet final : public Stage {
 public:
  static StageDecl declaration() {
    return {"overlap_correct.verlet",
            "push overlapping pairs of the Verlet list apart (reflect or contact), iterated until none overlap; "
            "rebuilds the list when the pushes moved a particle past skin/2",
            schema_of<Params>(), {2, 3}, false};
  }

  template <class Exec>
  OverlapCorrectVerlet(const ParamValues& v, const RunInfo& info, Exec exec)
      : p_(params_from<Params>(v)),
        team_(info.team),
        where_(Exec::where),
        d2_(VerletCorrectVariants<R, 2>::template make<Exec>()),
        d3_(VerletCorrectVariants<R, 3>::template make<Exec>()),
        count_touched_(&Exec::template sum<CountTouched>),
        wall_axis_(wall_axis_of(p_.walls)),
        builder_(exec),
        sum_(exec),
        disp_(exec) {}

  std::vector<Access> accesses() const override {
    using namespace neighbors;
    std::vector<Access> a{{fields::position, where_, Mode::readwrite},
                          {fields::image, where_, Mode::readwrite},
                          {fields::diameter, where_, Mode::read}};
    // Read each step; written when the stage rebuilds the list.
    for (const char* f : {kList, kCount, kPositionAtBuild, kOrder, kCell, kCellStart, kCellEnd})
      a.push_back({f, where_, Mode::readwrite});
    a.push_back({kBuildParams, Where::host, Mode::read});
    if (p_.mark) a.push_back({touched_field, where_, Mode::write});  // every entry written each step
    return a;
  }

  void configure(State& s) override {
    using namespace neighbors;
    for (const char* f : {kList, kCount, kPositionAtBuild, kOrder, kCell, kCellStart, kCellEnd, kBuildParams})
      if (!s.has_field(f))
        throw InputError(std::string("overlap_correct.verlet needs the Verlet list (field '") + f +
                         "'), which no stage before it provides: put neighbors.verlet before it in `step:` "
                         "(after the integrator), with a cutoff of at least the largest diameter");
    Field& bp = s.field(kBuildParams);
    bp.acquire(Where::host, Mode::read);
    cutoff_ = bp.host<double>()[0];
    skin_ = bp.host<double>()[1];
    diam_.template measure<R>(s, nullptr);
    if (!(diam_.min > 0)) throw InputError("overlap_correct.verlet: every particle needs a positive diameter");
    check_cutoff(false);
    check_walls(s, wall_axis_, diam_.max, "overlap_correct.verlet");
    if (p_.mark) {
      Field& f = s.add_particle_field(touched_field, DType::u8, 1);
      f.acquire(Where::host, Mode::write);
      std::memset(f.host<std::uint8_t>(), 0, s.n());
    }
    unit_ = diam_.max;
    tol_ = tolerance_for(p_, s, diam_.min);
    if (builder_.set_grid(s, cutoff_ + skin_) != s.field(kCellStart).count())
      throw InputError("overlap_correct.verlet: the cell grid of neighbors.verlet's list is not the one its cutoff "
                       "and skin give; the list was made by another stage than neighbors.verlet");
  }

  // In a decomposed team (docs/multi-gpu.md) each rank corrects its owned particles from their
  // rows (ghosts among them): every iteration's pair counts are summed over the ranks (so all
  // iterate alike) and the moved positions sent to the ghosts (StepContext::ghosts) before the
  // next gather. Displacements are fixed-point sums over each particle's overlapping pairs, whose
  // order does not matter, so the bits are one rank's. When the pushes make the list due, the
  // team rebuilds it as alone does, from the particles each rank holds, which it can while the
  // band condition holds (check_band); the core migrates skin/4 early (ghost_reserve), so that
  // pushes of up to skin/4 within a step keep it. With neighbors.verlet's ghost_margin 0 the
  // band has no room for any move (cutoff + skin) and a step whose pushes make the list due
  // stops the run.
  Scheduling scheduling() const override {
    Scheduling s;
    s.team = TeamWork::decomposed;
    s.reads_ghosts = true;
    s.communicates = true;
    s.ghost_reserve = 0.25 * skin_;
    return s;
  }

  Outcome run(StepContext& ctx) override {
    if (ctx.state.dim() == 2) return run_variant<2>(ctx, d2_);
    return run_variant<3>(ctx, d3_);
  }

 private:
  template <int D>
  Outcome run_variant(StepContext& ctx, const VerletCorrectVariants<R, D>& v) {
    const bool walls = wall_axis_ >= 0;
    if (walls && p_.mark) return run_d<D, true, true>(ctx, v.walls_mark);
    if (walls) return run_d<D, true, false>(ctx, v.walls);
    if (p_.mark) return run_d<D, false, true>(ctx, v.mark);
    return run_d<D, false, false>(ctx, v.plain);
  }

  template <int D, bool Walls, bool Mark>
  Outcome run_d(StepContext& ctx, const VerletCorrectLoops<R, D, Walls, Mark>& loops) {
    using namespace neighbors;
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    const std::size_t n = s.n();
    const std::size_t rows = s.n_owned();  // a decomposed team's own particles (all, alone)
    GhostExchange* ghosts = ctx.ghosts;
    const bool team = in_team(team_) && ghosts;
    auto team_sum = [&](std::uint64_t v) {
      if (!team) return v;
      std::int64_t x = std::int64_t(v);
      team_->all_reduce(&x, 1, ReduceOp::sum);
      return std::uint64_t(x);
    };
    if (diam_.stale(s)) {  // written since: measure again
      diam_.template measure<R>(s, st);
      check_cutoff(true, ctx.host_params.step);
      if (wall_axis_ >= 0 && !(s.box.L[wall_axis_] >= 2 * diam_.max))
        throw RunError("overlap_correct.verlet: step " + std::to_string(ctx.host_params.step) +
                       ": the diameters changed; the largest is now more than half the distance between the walls");
    }
    std::uint8_t* touched = p_.mark ? s.field(touched_field).data<std::uint8_t>(ctx) : nullptr;
    double* disp = disp_.get((D + 1) * n);
    std::int64_t iterations = 0, rebuilds = 0;
    std::uint64_t pairs = 0;
    double correction = 0;
    // In a team: each iteration's own sum of push lengths (fixed point), summed over the ranks
    // after the loop, kApplyBatch at once (one all-reduce instead of one an iteration), and
    // added in iteration order as alone: the same bits.
    std::vector<std::int64_t> applied;
    auto add_applied = [&] {
      for (std::size_t k = 0; k < applied.size(); k += kApplyBatch) {
        const std::size_t m = std::min(kApplyBatch, applied.size() - k);
        team_->all_reduce(applied.data() + k, m, ReduceOp::sum);
        for (std::size_t j = 0; j < m; ++j) correction += double(std::uint64_t(applied[k + j])) / kFixedOne * unit_;
      }
      applied.clear();
    };
    for (;;) {
      const std::uint32_t capacity = list_capacity(s);
      // The gathers' pair counts are summed in 32 bits: each pair is in two rows.
      if (std::uint64_t(n) * capacity / 2 >= (std::uint64_t(1) << kBadShift))
        throw RunError("overlap_correct.verlet: step " + std::to_string(ctx.host_params.step) + ": " +
                       std::to_string(n) + " particles with rows of " + std::to_string(capacity) +
                       " neighbours may hold more pairs than the pair counter holds (2^32); lower the cutoff "
                       "or skin of neighbors.verlet");
      R* x = s.field(fields::position).data<R>(ctx);
      std::int32_t* img = s.field(fields::image).data<std::int32_t>(ctx);
      Gather<R, D, Walls, Mark> gather{push_rule(p_, s, tol_, unit_, diam_, wall_axis_),
                                       x,
                                       s.field(fields::diameter).data<R>(ctx),
                                       s.field(kList).data<std::uint32_t>(ctx),
                                       s.field(kCount).data<std::uint32_t>(ctx),
                                       capacity,
                                       disp,
                                       wall_axis_ >= 0 ? img : nullptr,
                                       touched};
      gather.id = s.has_field(fields::particle_id) ? s.field(fields::particle_id).data<std::uint32_t>(ctx) : nullptr;
      const Apply<R, D> apply{x, img, PeriodicBox<R>::make(s.box.L), disp, 1.0 / unit_};
      for (;;) {  // the correction loop on this list
        gather.first = iterations == 0 && rebuilds == 0;
        const std::uint64_t c = team_sum(loops.gather(rows, gather, sum_, st));
        const std::uint64_t bad = c >> kBadShift;
        if (!bad) break;
        if (iterations == p_.max_iterations) give_up<D>(ctx, bad);
        pairs += c & ((std::uint64_t(1) << kBadShift) - 1);
        if (team) {
          // The apply writes the positions and images on this stage's side. The scheduler's
          // acquire marked the other side stale before the first iteration only; the refresh of
          // an iteration may make the other side current again (the domain packs there), so
          // every apply says again that it writes: else the next refresh reads the copy of
          // before the apply and writes it back over the apply (on CUDA: the host copy of the
          // previous iteration uploaded over the device's: from the second iteration on every
          // apply undone, the same pushes repeated until max_iterations).
          s.field(fields::position).acquire(where_, Mode::readwrite, st);
          s.field(fields::image).acquire(where_, Mode::readwrite, st);
        }
        const std::uint64_t moved_here = loops.apply(rows, apply, sum_, st);
        if (team) applied.push_back(std::int64_t(moved_here));
        else correction += double(moved_here) / kFixedOne * unit_;
        if (team) ghosts->refresh(s, {fields::position, fields::image});
        ++iterations;
      }
      if (team) add_applied();
      bool moved = builder_.template moved_too_far<D>(ctx, skin_);
      if (team) {
        std::int64_t m = moved ? 1 : 0;
        team_->all_reduce(&m, 1, ReduceOp::max);
        moved = m != 0;
        if (moved) check_band(ctx, *ghosts);
      }
      if (!moved) break;
      // A pair the list leaves out may overlap now: rebuild from the positions now, correct again.
      builder_.template build<D>(ctx, cutoff_ + skin_, where_);
      ++rebuilds;
    }
    ctx.metrics.set("iterations", double(iterations));
    ctx.metrics.set("pairs", double(pairs));
    ctx.metrics.set("correction", correction);
    ctx.metrics.set("list_rebuilds", double(rebuilds));
    if (p_.mark) {
      const double count = double(team_sum(count_touched_(rows, CountTouched{touched}, sum_, st)));
      ctx.metrics.set("touched", count);
      ctx.metrics.set("touched_fraction", count / double(team ? std::uint64_t(team_sum(rows)) : n));
    }
    return Outcome::ok();
  }

  // A decomposed team rebuilds the list within the step as alone does, from the particles the
  // rank holds: every particle within rl = cutoff + skin of an owned one now must be held. An
  // owned particle lay in the slab at the last migration, and the ghosts reach `band` beyond it
  // as it was then, so they do while rl + 2·δ ≤ band, δ the largest move of any particle since
  // the last migration (the band condition; neighbors.verlet's ghost_margin widens the band).
  // Past it the run stops: a migration happens only at the start of a step.
  void check_band(StepContext& ctx, GhostExchange& ghosts) {
    const double delta = ghosts.displacement(ctx.state, fields::position);  // one all-reduce
    if (cutoff_ + skin_ + 2 * delta <= ghosts.band()) return;
    std::ostringstream os;
    os << "overlap_correct.verlet: step " << ctx.host_params.step << ": the pushes moved particles so that the list "
       << "is due within the step, and a particle has moved " << delta << " since the decomposed team's last "
       << "migration: its rebuild would need ghosts within cutoff + skin + 2 x " << delta << " = "
       << cutoff_ + skin_ + 2 * delta << " of the slab, which hold " << ghosts.band()
       << " (particles migrate only at the start of a step): raise neighbors.verlet's ghost_margin, or lower run.dt";
    throw RunError(os.str());
  }

  // Every overlapping pair must be in the list: σ_ij ≤ the largest diameter ≤ the cutoff.
  void check_cutoff(bool running, std::uint64_t step = 0) const {
    if (cutoff_ >= diam_.max) return;
    const std::string what = "overlap_correct.verlet: neighbors.verlet's cutoff = " + std::to_string(cutoff_) +
                             " is below the largest diameter " + std::to_string(diam_.max) +
                             ", so overlapping pairs may be missing from the list; set its cutoff to at least " +
                             std::to_string(diam_.max);
    if (running) throw RunError("step " + std::to_string(step) + ": " + what);
    throw InputError(what);
  }

  // The error path: find the worst listed pair on the host (fields are copied there) and stop.
  template <int D>
  [[noreturn]] void give_up(StepContext& ctx, std::uint64_t bad) {
    using namespace neighbors;
    State& s = ctx.state;
    for (const Access& a : accesses()) s.field(a.field).acquire(Where::host, Mode::read, ctx.stream);
    const R* x = s.field(fields::position).host<R>();
    const R* d = s.field(fields::diameter).host<R>();
    const std::uint32_t* list = s.field(kList).host<std::uint32_t>();
    const std::uint32_t* count = s.field(kCount).host<std::uint32_t>();
    const std::uint32_t capacity = list_capacity(s);
    const auto box = PeriodicBox<double>::make(s.box.L);
    std::size_t wa = 0, wb = 0;
    double worst = -1, wr = 0, ws = 0;
    for (std::size_t a = 0; a < s.n(); ++a)
      for (std::uint32_t j = 0; j < std::min(count[a], capacity); ++j) {
        const std::size_t b = list[a * capacity + j];
        double r2 = 0;
        for (int k = 0; k < D; ++k) {
          const double raw = double(x[D * b + k]) - double(x[D * a + k]);
          const double dk = k == wall_axis_ ? raw : box.min_image(raw, k);
          r2 += dk * dk;
        }
        const double sab = 0.5 * (double(d[a]) + double(d[b])), r = std::sqrt(r2);
        if (a < b && (sab - r) / sab > worst) {
          worst = (sab - r) / sab;
          wa = a;
          wb = b;
          wr = r;
          ws = sab;
        }
      }
    std::ostringstream os;
    os << "overlap_correct.verlet: step " << ctx.host_params.step << ": " << bad
       << " pair(s) still overlap by more than tolerance = " << tol_ << " after max_iterations = " << p_.max_iterations
       << " iterations; the worst is particles " << wa << " and " << wb << " at r = " << wr << " with σ_ij = " << ws
       << " (overlap " << worst
       << "·σ_ij). " << unconverged_advice(p_);
    throw RunError(os.str());
  }

  static constexpr std::size_t kApplyBatch = 32;  // values a team all-reduce takes at once (comm.h: NCCL's 64)
  Params p_;
  Communicator* team_;  // a decomposed team's rank (with StepContext::ghosts); else alone
  Where where_;
  VerletCorrectVariants<R, 2> d2_;
  VerletCorrectVariants<R, 3> d3_;
  ReduceLoop<CountTouched, std::uint64_t> count_touched_;
  int wall_axis_;  // walls: the axis (0, 1, 2); -1: none
  neighbors::ListBuild<R> builder_;  // the list's rebuild when the pushes moved a particle past skin/2
  Reduction<std::uint64_t> sum_;     // the word of the backend's sums
  Scratch<double> disp_;             // N x (D + 1): each iteration's displacements and their lengths
  double cutoff_ = 0, skin_ = 0;     // neighbors.verlet's, as given (neighbors.build_params)
  double unit_ = 1;                  // length unit of the fixed-point sums (largest diameter at configure)
  DiameterRange diam_;  // largest and smallest diameter now
  double tol_ = 1e-6;
};

}  // namespace ff::overlap

FLIPFLOW_STAGE(ff::overlap::OverlapCorrectVerlet)
