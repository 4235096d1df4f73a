// phoretic.forces: pair velocities v_i = Σ_k μ_i α_k f(r_i - r_k) into the `velocity` field.
// range: long  -> f = r/r³, all pairs, exact O(N²) with minimum image
// range: short -> f = r/r⁷ up to `cutoff`, through the list of a neighbors.verlet stage before it
// In a team of ranks (`pipeline run --gpus N`, core/backend/comm.h) the long range splits its
// work (TeamWork::split): each rank sums its contiguous share of targets over all sources, then
// the velocities are all-gathered in place, so every rank holds the whole field with the bits
// one rank computes (each target's sum is unchanged). O(N²/P) work per rank for O(N) data.
// The short range runs decomposed: a rank sums the rows of its own particles (docs/multi-gpu.md).
#pragma once
#include <algorithm>
#include <string>
#include <tuple>
#include <vector>

#include "core/base/error.h"
#include "core/backend/comm.h"
#include "core/backend/exec.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "plugins/phoretic/forces/kernel.h"
#include "stages/neighbors/list.h"

namespace ff::phoretic {

inline constexpr const char* kVelocity = "velocity";  // real x dim, velocity units

struct ForcesParams {
  std::string range = "long";
  std::vector<double> alpha;  // per type: emitted charge
  std::vector<double> mu;     // per type: response
  double cutoff = 2.5;        // short range only

  template <class P>
  void describe(P& p) {
    p(range, "range",
      "long: f = r/r³ summed over all pairs; short: f = r/r⁷ cut at `cutoff`, through the Verlet list of a "
      "neighbors.verlet stage before this one")
        .one_of({"long", "short"});
    p(alpha, "alpha", "charge α per particle type (creates the field), indexed like system.types").required();
    p(mu, "mu", "charge μ per particle type (responds to the field), indexed like system.types").required();
    p(cutoff, "cutoff",
      "short range cutoff (a length in the box's units, not scaled by σ); must not exceed neighbors.verlet's cutoff")
        .above(0);
  }
  bool long_range() const { return range == "long"; }
};

template <class R, int D>
using LongRangeLoop = void (*)(const LongRangeVelocity<R, D>& f, CUstream_st* stream);

template <class R>
struct ForcesLoops {
  LongRangeLoop<R, 2> long2;
  LongRangeLoop<R, 3> long3;
  ElementLoop<ShortRangeVelocity<R, 2>> short2;
  ElementLoop<ShortRangeVelocity<R, 3>> short3;
};

// The loops of each backend (cpu.cpp, cuda.cu).
template <class R>
ForcesLoops<R> forces_loops(CpuExec);
template <class R>
ForcesLoops<R> forces_loops(CudaExec);

template <class R>
class Forces final : public Stage {
 public:
  static StageDecl declaration() {
    return {"phoretic.forces",
            "phoretic pair velocities v_i = Σ_k μ_i α_k f(r_ik) into `velocity` (long: r/r³ all pairs; short: "
            "r/r⁷ via Verlet list)",
            schema_of<ForcesParams>(), {2, 3}, false};
  }

  template <class Exec>
  Forces(const ParamValues& v, const RunInfo& info, Exec)
      : p_(params_from<ForcesParams>(v)), where_(Exec::where), loops_(forces_loops<R>(Exec{})), team_(info.team) {
    if (p_.alpha.size() != p_.mu.size())
      throw InputError("phoretic.forces: alpha has " + std::to_string(p_.alpha.size()) + " entries and mu has " +
                       std::to_string(p_.mu.size()) + "; give one of each per particle type");
    if (p_.alpha.empty() || p_.alpha.size() > std::size_t(kMaxTypes))
      throw InputError("phoretic.forces: alpha and mu need between 1 and " + std::to_string(kMaxTypes) +
                       " entries (one per particle type)");
    for (std::size_t t = 0; t < p_.alpha.size(); ++t) {
      q_.alpha[t] = R(p_.alpha[t]);
      q_.mu[t] = R(p_.mu[t]);
    }
  }

  std::vector<Access> accesses() const override {
    std::vector<Access> a{{fields::position, where_, Mode::read},
                          {fields::type, where_, Mode::read},
                          {kVelocity, where_, Mode::write}};
    if (!p_.long_range()) {
      a.push_back({neighbors::kList, where_, Mode::read});
      a.push_back({neighbors::kCount, where_, Mode::read});
    }
    return a;
  }

  void configure(State& s) override {
    // Every particle's type must have charges.
    Field& type = s.field(fields::type);
    type.acquire(Where::host, Mode::read);
    std::size_t types = s.species.size();
    const std::int32_t* t = type.host<std::int32_t>();
    for (std::size_t i = 0; i < s.n(); ++i) {
      if (t[i] < 0) throw InputError("phoretic.forces: particle " + std::to_string(i) + " has a negative type");
      types = std::max(types, std::size_t(t[i]) + 1);
    }
    if (types > p_.alpha.size())
      throw InputError("phoretic.forces: the system has " + std::to_string(types) + " particle types but alpha/mu give " +
                       std::to_string(p_.alpha.size()) + "; give one α and one μ per type");
    if (!p_.long_range()) {
      if (!s.has_field(neighbors::kList) || !s.has_field(neighbors::kCutoff))
        throw InputError("phoretic.forces: range: short needs a neighbors.verlet stage earlier in the step list");
      Field& c = s.field(neighbors::kCutoff);
      c.acquire(Where::host, Mode::read);
      const double listed = double(c.host<R>()[0]);
      if (p_.cutoff > listed * (1 + 1e-12))
        throw InputError("phoretic.forces: cutoff " + std::to_string(p_.cutoff) +
                         " exceeds the neighbors.verlet cutoff " + std::to_string(listed) +
                         "; pairs in between would be missed: raise neighbors.verlet's cutoff");
    }
    s.add_particle_field(kVelocity, s.real(), s.dim());
  }

  Scheduling scheduling() const override {
    Scheduling s;
    // Long range: split by target over the replicated state. Short range: in a decomposed team
    // each owned particle sums its Verlet row (ghosts among them), sorted by global id.
    s.team = p_.long_range() ? TeamWork::split : TeamWork::decomposed;
    s.reads_ghosts = !p_.long_range();
    return s;
  }

  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    if (s.dim() == 2) run_d<2>(ctx);
    else run_d<3>(ctx);
    return Outcome::ok();
  }

 private:
  template <int D>
  void run_d(StepContext& ctx) {
    State& s = ctx.state;
    const R* x = s.field(fields::position).data<R>(ctx);
    const std::int32_t* type = s.field(fields::type).data<std::int32_t>(ctx);
    R* v = s.field(kVelocity).data<R>(ctx);
    const auto box = PeriodicBox<R>::make(s.box.L);
    if (p_.long_range()) {
      LongRangeVelocity<R, D> f{x, type, v, q_, box, s.n()};
      if (in_team(team_)) std::tie(f.first_target, f.last_target) = share_of(s.n(), team_->rank(), team_->size());
      if constexpr (D == 2) loops_.long2(f, ctx.stream);
      else loops_.long3(f, ctx.stream);
      if (in_team(team_)) {
        // Every rank's share of `velocity`, in place (stream-ordered on CUDA: the integrator
        // after this stage, on the same stream, reads the whole field).
        std::vector<std::size_t> bytes(std::size_t(team_->size()) + 1);
        for (int r = 0; r <= team_->size(); ++r)
          bytes[std::size_t(r)] = share_of(s.n(), r, team_->size()).first * D * sizeof(R);
        team_->all_gather_slices(v, bytes, ctx.stream);
      }
    } else {
      const ShortRangeVelocity<R, D> f{x, type, v, q_, box,
                                       s.field(neighbors::kList).data<std::uint32_t>(ctx),
                                       s.field(neighbors::kCount).data<std::uint32_t>(ctx),
                                       neighbors::list_capacity(s), R(p_.cutoff * p_.cutoff)};
      if constexpr (D == 2) loops_.short2(s.n_owned(), f, ctx.stream);
      else loops_.short3(s.n_owned(), f, ctx.stream);
    }
  }

  ForcesParams p_;
  Where where_;
  ForcesLoops<R> loops_;
  Communicator* team_;  // null or one rank: alone
  Charges<R> q_{};
};

}  // namespace ff::phoretic

FLIPFLOW_STAGE(ff::phoretic::Forces)
