// neighbors.verlet: cell list + Verlet list with Tran's dynamic rebuild test, 2D and 3D, periodic.
// Every step it checks whether some particle moved more than skin/2 since the last build and
// rebuilds only then (metric `rebuilds`, 0 or 1). Row capacity grows (reallocate + rebuild)
// whenever a particle has more neighbours than fit (metric `max_neighbors`).
//
// On CUDA the host must have the test's answer before it can launch (or skip) the build; a test
// kernel of its own and the wait for its answer would drain the stream in the middle of the step
// (bench/experiments/README.md, lj-s13). Where the stage that moved the particles has already
// answered the test (neighbors.moved, list.h: overdamped.integrate with max_step does, in its own
// loop, read back with its own counters; on the CPU too, saving a pass), run() takes that answer: the same test on the same
// positions and build positions, so the same decisions. Else it tests itself. (Enqueuing the
// test at the end of the step before instead, in after_step, gained less: bench/experiments.)
#pragma once
#include <algorithm>
#include <cmath>
#include <string>

#include "core/base/error.h"
#include "core/backend/comm.h"
#include "core/backend/exec.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/neighbors/list.h"
#include "stages/neighbors/verlet/build.h"
#include "stages/neighbors/verlet/kernel.h"

namespace ff::neighbors {

struct VerletParams {
  double cutoff = 2.5;  // pairs closer than this must be in the list
  double skin = 0.5;    // extra radius: the list stays complete until a particle moves skin/2
  double ghost_margin = 0.3;  // decomposed teams: the drift beyond skin/2 allowed before a migration

  template <class P>
  void describe(P& p) {
    p(cutoff, "cutoff", "interaction cutoff r_c (a length in the box's units, not scaled by σ): every pair closer is listed").above(0);
    p(skin, "skin",
      "Verlet skin (box units): lists hold pairs within r_c + skin and are rebuilt when a particle has moved more than "
      "skin/2")
        .above(0);
    p(ghost_margin, "ghost_margin",
      "decomposed teams (--gpus N, docs/multi-gpu.md): a rank holds ghosts within r_c + 2 skin + 2 margin of "
      "its slab (box units), migrates particles only once one moved skin/2 + margin, and rebuilds the list in between "
      "on its own; 0: ghosts within r_c + skin, a migration at every rebuild. No effect alone")
        .at_least(0);
  }
};

template <class R>
class Verlet final : public Stage {
 public:
  static StageDecl declaration() {
    return {"neighbors.verlet",
            "cell list + Verlet list (fields neighbors.list/count), rebuilt when a particle moved > skin/2",
            schema_of<VerletParams>(), {2, 3}, false};
  }

  template <class Exec>
  Verlet(const ParamValues& v, const RunInfo& info, Exec exec)
      : p_(params_from<VerletParams>(v)),
        team_(info.team),
        where_(Exec::where),
        builder_(exec) {}

  // The list is written only on the steps that rebuild it (ListBuild::build announces the
  // writes), so the rollback snapshot copies it only then.
  std::vector<Access> accesses() const override {
    std::vector<Access> a{{fields::position, where_, Mode::read}, {kMoved, Where::host, Mode::read}};
    for (const char* f : kListFields) a.push_back(Access::on_demand_write(f, where_));
    return a;
  }

  // In a decomposed team: built from every particle the rank holds, owned or ghost (the rows of
  // ghosts are incomplete, and no stage reads them), never exchanged; rows sorted by global id.
  // An owned particle's row is the one alone has when the rank holds every particle within
  // rl = cutoff + skin of it at the build. Two ways (docs/multi-gpu.md):
  //  - ghost_margin 0: ghosts within rl of the slab, and the core migrates once a particle moved
  //    skin/2 since the last migration, which is when the list is due: it is built at every
  //    migration (the particles renumbered) and only then.
  //  - ghost_margin M > 0: ghosts within rl + skin + 2M, migrations at skin/2 + M. The list is
  //    rebuilt when one rank alone rebuilds it: every step the ranks join their tests (one
  //    all-reduce, so the stage communicates), which is alone's test over every particle. A build
  //    between migrations, from particles that moved at most skin/2 + M since the last, finds
  //    every neighbour within rl held (rl + 2(skin/2 + M) of the slab). A migration on which the
  //    list is not due keeps its rows: they are made again from the positions at the last build,
  //    at most skin/2 from the migration's (rl + skin of the slab: held). So the list, and every
  //    rebuild metric, is alone's at every step, which overlap_correct.verlet's in-step rebuilds
  //    need (stages/overlap_correct/verlet/stage.h).
  Scheduling scheduling() const override {
    Scheduling s;
    s.team = TeamWork::local;
    const double rl = p_.cutoff + p_.skin, M = p_.ghost_margin;
    s.ghost_band = M > 0 ? rl + p_.skin + 2 * M : rl;
    s.ghost_slack = 0.5 * p_.skin + M;
    s.communicates = M > 0;
    return s;
  }

  void configure(State& s) override {
    const double rl = p_.cutoff + p_.skin;
    double lmin = s.box.L[0];
    for (int k = 0; k < s.dim(); ++k) {
      if (!(s.box.L[k] > 0)) throw InputError("neighbors.verlet: the box has no size along axis " + std::to_string(k));
      lmin = std::min(lmin, s.box.L[k]);
    }
    if (2 * rl > lmin)
      throw InputError("neighbors.verlet: cutoff + skin = " + std::to_string(rl) +
                       " is more than half the smallest box edge (" + std::to_string(lmin) +
                       "); the minimum image would miss pairs: use a larger box or a smaller cutoff/skin");
    const std::size_t ncells = builder_.set_grid(s, rl);

    const std::size_t n = s.n();
    if (s.has_field(kList)) throw InputError("neighbors.verlet: only one neighbors.verlet stage may run per pipeline");
    s.add_field(kList, DType::u32, 1, n * initial_capacity(s, rl));
    s.add_particle_field(kCount, DType::u32, 1);
    s.add_particle_field(kPositionAtBuild, s.real(), s.dim());
    s.add_particle_field(kOrder, DType::u32, 1);
    s.add_particle_field(kCell, DType::u32, 1);
    s.add_field(kCellStart, DType::u32, 1, ncells);
    s.add_field(kCellEnd, DType::u32, 1, ncells);
    Field& cut = s.add_field(kCutoff, s.real(), 1, 1);
    cut.acquire(Where::host, Mode::write);
    cut.host<R>()[0] = R(p_.cutoff);
    Field& bp = s.add_field(kBuildParams, DType::f64, 1, 2);
    bp.acquire(Where::host, Mode::write);
    bp.host<double>()[0] = p_.cutoff;
    bp.host<double>()[1] = p_.skin;
    Field& moved = s.add_field(kMoved, DType::u64, 1, 2);  // nothing published yet (zeroed)
    moved.acquire(Where::host, Mode::write);
  }

  Outcome run(StepContext& ctx) override {
    if (ctx.state.dim() == 2) return run_d<2>(ctx);
    return run_d<3>(ctx);
  }

  // The list itself is in the state's fields. A continued run must not rebuild it at its first
  // step (a list built from other positions lists pairs in another order, and the forces summed
  // over it round differently): keep "built" and the longest row (the metric).
  // The step is accepted: its build (if any) stands.
  void after_step(StepContext&) override { accepted_particles_ = built_particles_; }

  void save_state(StageState& out) override {
    out.put("built", std::uint8_t(built_ ? 1 : 0));
    out.put("max_neighbors", builder_.max_neighbors());
  }
  void restore_state(const StageState& saved, State& s) override {
    if (saved.has("built")) built_ = saved.get<std::uint8_t>("built") != 0;
    if (saved.has("max_neighbors")) builder_.set_max_neighbors(saved.get<std::uint32_t>("max_neighbors"));
    // An answer published in the run that wrote the checkpoint names a version of that run's
    // position field: not this one's.
    Field& moved = s.field(kMoved);
    moved.acquire(Where::host, Mode::write);
    moved.host<std::uint64_t>()[0] = 0;
  }

 private:
  // Expected neighbours at the mean density, with room for clusters; grown when exceeded.
  static std::uint32_t initial_capacity(const State& s, double rl) {
    const double density = double(s.n()) / s.box.volume();
    constexpr double pi = 3.14159265358979323846;
    const double ball = s.dim() == 2 ? pi * rl * rl : 4.0 / 3.0 * pi * rl * rl * rl;
    const double expected = density * ball;
    return std::uint32_t(std::ceil(expected * 1.5)) + 8;
  }

  // Whether the test answered by the stage that moved the particles (neighbors.moved) is for
  // the positions as they are.
  static bool published_applies(State& s) {
    const std::uint64_t* moved = s.field(kMoved).host<std::uint64_t>();
    return moved[0] != 0 && moved[0] == s.field(fields::position).version();
  }

  // Whether some particle moved more than skin/2 since the build: the answer the stage that
  // moved them published, else the test over the particles held.
  template <int D>
  bool moved_too_far(StepContext& ctx) {
    if (published_applies(ctx.state)) return ctx.state.field(kMoved).host<std::uint64_t>()[1] != 0;
    return builder_.template moved_too_far<D>(ctx, p_.skin);
  }

  template <int D>
  Outcome run_d(StepContext& ctx) {
    State& s = ctx.state;
    const double rl = p_.cutoff + p_.skin;
    // A decomposed team's migration renumbered the particles this rank holds: the list's
    // indices are stale (State::particles_version). Compared with the version of the last
    // accepted build: a rollback restores the list an attempt rebuilt, so the retry rebuilds.
    const bool renumbered = s.particles_version() != accepted_particles_;
    bool rebuild = !built_, same_rows = false;
    if (!rebuild && p_.ghost_margin > 0 && ctx.ghosts && in_team(team_)) {
      // The team's test is alone's: any rank's particle (scheduling() above).
      std::int64_t due = moved_too_far<D>(ctx) ? 1 : 0;
      team_->all_reduce(&due, 1, ReduceOp::max);
      rebuild = due != 0;
      same_rows = !rebuild && renumbered;
    } else if (!rebuild) {
      rebuild = renumbered || moved_too_far<D>(ctx);
    }
    if (rebuild) builder_.template build<D>(ctx, rl, where_);
    if (same_rows) builder_.template rebuild_rows<D>(ctx, rl, where_);
    built_ = true;
    if (rebuild || same_rows) built_particles_ = s.particles_version();
    ctx.metrics.set("rebuilds", rebuild ? 1.0 : 0.0);
    ctx.metrics.set("max_neighbors", double(builder_.max_neighbors()));
    return Outcome::ok();
  }

  VerletParams p_;
  Communicator* team_;  // a decomposed team's rank (with StepContext::ghosts); else alone
  std::uint64_t built_particles_ = 0;     // State::particles_version() at the last build
  std::uint64_t accepted_particles_ = 0;  // the same, of the last build in an accepted step
  Where where_;
  ListBuild<R> builder_;
  bool built_ = false;
};

}  // namespace ff::neighbors

FLIPFLOW_STAGE(ff::neighbors::Verlet)
