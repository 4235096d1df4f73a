// delaunay.dt_bound: limits each step's Δt so that no particle can move more than a fraction
// (the paper's quarter) of the distance to its nearest Delaunay neighbour, De Fabritiis &
// Coveney §5.1 (Algorithm 3 step 1), spec D3. The cell boundary is at least half that distance
// away, so every particle stays inside its own Voronoi cell of the step's start with a factor 2
// margin: a vertex rarely crosses more than one edge, which makes the step's triangulation
// repairable by single flips ("this helps to ensure that we have a valid triangulation, but it
// does not guarantee it", their Appendix A: the triangulation may be stale, and a particle's
// neighbours move too).
//
// Per particle i of type t, with h_i the distance to its nearest Delaunay neighbour, the step's
// displacement is at most |v_i + μ_t F_i| Δt + speed_t Δt + G √d √(2 D_t Δt), G = 3.04... the
// largest Gaussian the noise can draw (core/physics/rng.h); the largest Δt_i keeping it within
// fraction·h_i solves a quadratic in √Δt (kernel.h), and the stage returns
// Outcome::limit_dt(min_i Δt_i): the core takes the largest run.dt/2^k within it (spec G5).
// Put it first in the step, after the stages that write the drift it reads (`velocity`,
// `force`) and before the integrator; its D, mobility and drift must be the integrator's.
#pragma once
#include <cmath>
#include <sstream>
#include <string>

#include "core/backend/exec.h"
#include "core/base/error.h"
#include "core/physics/rng.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/delaunay/common/host.h"
#include "stages/delaunay/dt_bound/kernel.h"

namespace ff::delaunay {

struct DtBoundParams {
  PerType D{{1.0}};
  PerType mobility{{1.0}};
  PerType speed{{0.0}};
  std::string drift = "auto";
  double fraction = 0.25;

  template <class P>
  void describe(P& p) {
    p(D, "D",
      "translational diffusion coefficient D_t (box length²/τ) of the integrator, one for every type or one per "
      "type: bounds the noise's displacement")
        .at_least(0);
    p(mobility, "mobility", "the integrator's mobility μ_t (multiplies the `force` field): one, or one per type")
        .at_least(0);
    p(speed, "speed",
      "bound on a drift speed no field holds (box lengths per τ), one or one per type: v0 of self-propelled "
      "particles or boids")
        .at_least(0);
    p(drift, "drift",
      "the drift fields the integrator reads: auto (`velocity` and/or `force`, whichever a stage before creates), "
      "none, velocity, force, or velocity+force (those must exist)")
        .one_of({"auto", "none", "velocity", "force", "velocity+force"});
    p(fraction, "fraction",
      "largest step as a fraction of the distance to the nearest Delaunay neighbour (De Fabritiis: 1/4; the own "
      "Voronoi cell holds every point closer than 1/2)")
        .above(0)
        .at_most(0.5);
  }
};

template <class R>
struct DtBoundLoops {
  ElementLoop<EdgeNearest<R>> nearest;
  ElementLoop<ParticleDtBound<R>> bound;
  ReduceLoop<KeyHigh, std::uint32_t> high;
  ReduceLoop<KeyLowWhereHigh, std::uint32_t> low;
  ReduceLoop<FirstWithKey, std::uint32_t> first;
};

template <class R>
class DtBound final : public Stage {
 public:
  static StageDecl declaration() {
    return {"delaunay.dt_bound",
            "limits Δt so that no particle moves more than a quarter of the way to its nearest Delaunay "
            "neighbour (De Fabritiis §5.1)",
            schema_of<DtBoundParams>(), {2}, false};
  }

  template <class Exec>
  DtBound(const ParamValues& v, const RunInfo&, Exec)
      : p_(params_from<DtBoundParams>(v)),
        where_(Exec::where),
        loops_{&Exec::template for_each<EdgeNearest<R>>, &Exec::template for_each<ParticleDtBound<R>>,
               &Exec::template max<KeyHigh>,
               &Exec::template max<KeyLowWhereHigh>, &Exec::template max<FirstWithKey>},
        mem_(Exec::memory()),
        nearest2_(Exec{}),
        key_(Exec{}),
        nearest_(Exec{}),
        word_(Exec{}) {}

  void configure(State& s) override {
    add_topology_fields(s, "delaunay.dt_bound");
    const bool want_v = p_.drift == "velocity" || p_.drift == "velocity+force";
    const bool want_f = p_.drift == "force" || p_.drift == "velocity+force";
    for (const char* f : {kVelocity, kForce}) {
      const bool wanted = f == kVelocity ? want_v : want_f;
      if (wanted && !s.has_field(f))
        throw InputError(std::string("delaunay.dt_bound: drift: ") + p_.drift + " needs the `" + f +
                         "` field, which no stage before it creates (put the stage that writes it first)");
    }
    reads_velocity_ = want_v || (p_.drift == "auto" && s.has_field(kVelocity));
    reads_force_ = want_f || (p_.drift == "auto" && s.has_field(kForce));
    for (const char* f : {kVelocity, kForce})
      if ((f == kVelocity ? reads_velocity_ : reads_force_) &&
          (s.field(f).dtype() != s.real() || s.field(f).components() != 2 || s.field(f).count() != s.n()))
        throw InputError(std::string("delaunay.dt_bound: the field `") + f + "` must hold " + to_string(s.real()) +
                         " x2 per particle");
    const std::size_t types = s.species.empty() ? 1 : s.species.size();
    if (types > std::size_t(kDtBoundMaxTypes))
      throw InputError("delaunay.dt_bound: at most " + std::to_string(kDtBoundMaxTypes) + " particle types");
    for (auto* v : {&p_.D, &p_.mobility, &p_.speed})
      if (!v->uniform() && v->values.size() != types)
        throw InputError(std::string("delaunay.dt_bound: ") + (v == &p_.D ? "D" : v == &p_.mobility ? "mobility" : "speed") +
                         " has " + std::to_string(v->values.size()) +
                         " values; give one for every type, or one per type (system.types has " +
                         std::to_string(types) + ")");
    types_ = types;
  }

  std::vector<Access> accesses() const override {
    // The topology is written only when none exists yet (the first step builds it, as the
    // other delaunay stages do).
    std::vector<Access> a{{ff::fields::position, where_, Mode::read},
                          Access::on_demand_write(fields::halfedge, where_),
                          Access::on_demand_write(fields::opposite, where_),
                          Access::on_demand_write(fields::vertex_edge, where_),
                          Access::on_demand_write(fields::position_prev, where_),
                          {fields::status, Where::host, Mode::readwrite}};
    if (reads_velocity_) a.push_back({kVelocity, where_, Mode::read});
    if (reads_force_) a.push_back({kForce, where_, Mode::read});
    if (per_type()) a.push_back({ff::fields::type, where_, Mode::read});
    return a;
  }

  // The limit is read back on the host in run(): never replayed from a CUDA graph.
  Scheduling scheduling() const override {
    Scheduling s;
    s.may_limit_dt = true;
    return s;
  }

  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    ensure_topology(ctx, *this);
    const std::size_t n = s.n();
    // Squared distances start at 0x7f7f...: 1.4e306, above any squared edge length.
    std::uint64_t* nearest2 = nearest2_.get(n);
    mem_.fill(nearest2, 0x7f, n * sizeof(std::uint64_t), st);
    loops_.nearest(edge_count(n),
                   EdgeNearest<R>{mesh_view(s, where_), points_view<R>(s, ff::fields::position, where_), nearest2}, st);
    ParticleDtBound<R> f{};
    f.velocity = reads_velocity_ ? s.field(kVelocity).data<R>(where_) : nullptr;
    f.force = reads_force_ ? s.field(kForce).data<R>(where_) : nullptr;
    f.type = per_type() ? s.field(ff::fields::type).data<std::int32_t>(where_) : nullptr;
    for (std::size_t t = 0; t < std::size_t(kDtBoundMaxTypes); ++t) {
      const std::size_t k = t < types_ ? t : 0;
      f.mobility[t] = p_.mobility[k];
      f.speed[t] = p_.speed[k];
      // G √d √(2 D_t): each of the d components of the noise is at most G·√(2 D_t Δt).
      f.noise[t] = kLargestGaussian * std::sqrt(2.0) * std::sqrt(2 * p_.D[k]);
    }
    f.fraction = p_.fraction;
    f.nearest2 = nearest2;
    f.key = key_.get(n);
    f.nearest = nearest_.get(n);
    loops_.bound(n, f, st);
    const std::uint32_t high = loops_.high(n, KeyHigh{f.key}, word_, st);
    const std::uint32_t low = loops_.low(n, KeyLowWhereHigh{f.key, high}, word_, st);
    const std::uint64_t best = (std::uint64_t(high) << 32) | low;
    const double dt_max = dt_of_key(best);
    ctx.metrics.set("dt_max", dt_max);
    if (!(dt_max < ctx.host_params.dt)) return Outcome::limit_dt(dt_max, "");
    // Binding: name the particle (the lowest index that needs the smallest Δt) for the message.
    const std::uint32_t i = std::uint32_t(n) - loops_.first(n, FirstWithKey{f.key, best, std::uint32_t(n)}, word_, st);
    double h = 0;
    mem_.to_host(&h, f.nearest + i, sizeof h, st);
    std::ostringstream why;
    why << "delaunay.dt_bound: particle " << i << " is " << h << " from its nearest Delaunay neighbour and may move "
        << p_.fraction << " of that in a step";
    return Outcome::limit_dt(dt_max, why.str(), {i});
  }

 private:
  static constexpr const char* kVelocity = "velocity";
  static constexpr const char* kForce = "force";
  bool per_type() const { return !p_.D.uniform() || !p_.mobility.uniform() || !p_.speed.uniform(); }

  DtBoundParams p_;
  Where where_;
  DtBoundLoops<R> loops_;
  const MemoryOps& mem_;
  Scratch<std::uint64_t> nearest2_;
  Scratch<std::uint64_t> key_;
  Scratch<double> nearest_;
  Reduction<std::uint32_t> word_;
  bool reads_velocity_ = false, reads_force_ = false;
  std::size_t types_ = 1;
};

}  // namespace ff::delaunay

FLIPFLOW_STAGE(ff::delaunay::DtBound)
