// abp.integrate: Active Brownian Particles (Carter et al. 2017, eq. 10-11), 2D and 3D: the
// standard overdamped step (stages/overdamped/integrate/kernel.h) driven by the self-propulsion,
// and the orientation's rotational diffusion (kernel.h). Force-free: a `force` or `velocity`
// field written by other stages is not read. A position or orientation that is not finite after
// its step stops the run naming the particle (the check every overdamped step makes:
// stages/overdamped/integrate/finite_check.h).
#pragma once
#include <cmath>
#include <string>
#include <utility>

#include "core/base/error.h"
#include "core/backend/exec.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "plugins/abp/integrate/kernel.h"
#include "stages/overdamped/integrate/finite_check.h"
#include "stages/overdamped/integrate/held.h"

namespace ff::abp {

inline constexpr const char* kOrientation = "orientation";  // θ (real x1) in 2D, unit vector (real x3) in 3D

struct IntegrateParams {
  double v0 = 1.0;  // self-propulsion speed
  double Dr = 1.0;  // rotational diffusion coefficient
  double D = 0.0;   // translational diffusion coefficient

  template <class P>
  void describe(P& p) {
    p(v0, "v0", "self-propulsion speed (box lengths per τ; σ/τ when system.sigma = 1)").at_least(0);
    p(Dr, "Dr",
      "rotational diffusion coefficient D_r (1/τ): θ += sqrt(2 D_r Δt)·η in 2D (a random rotation in 3D)")
        .at_least(0);
    p(D, "D",
      "translational diffusion coefficient (box length²/τ; σ²/τ when system.sigma = 1), independent of Dr "
      "(not σ²D_r/3 unless given so)")
        .at_least(0);
  }
};

inline int orientation_components(int dim) { return dim == 2 ? 1 : 3; }

template <class R>
class AbpIntegrate final : public Stage {
 public:
  static StageDecl declaration() {
    return {"abp.integrate",
            "active Brownian particles: x += v0 e(θ)Δt + sqrt(2DΔt)ξ, θ += sqrt(2D_rΔt)η (2D; unit vector in 3D)",
            schema_of<IntegrateParams>(), {2, 3}, false};
  }

  template <class Exec>
  AbpIntegrate(const ParamValues& v, const RunInfo& info, Exec exec)
      : p_(params_from<IntegrateParams>(v)),
        mem_(exec.memory()),
        seed_(info.seed),
        where_(Exec::where),
        id_(info.stage_id),
        loop2_(&Exec::template overdamped<AbpStep<R, 2>>),
        loop3_(&Exec::template overdamped<AbpStep<R, 3>>),
        finite_(Exec{}, info.steps, [this](State& s, const overdamped::NonFiniteFound& f, CUstream_st* stream) {
          not_finite(s, f, stream);
        }) {}

  // Every element is rewritten each step from the previous values, which the rollback snapshot
  // keeps instead of copying (on_demand + will_overwrite: the step reads the snapshot's arrays
  // and writes the field's; in place when no snapshot is taken).
  std::vector<Access> accesses() const override {
    return {Access::on_demand_write(fields::position, where_),
            Access::on_demand_write(fields::image, where_),
            Access::on_demand_write(kOrientation, where_)};
  }

  // Adds the orientation field when no one has, and fills it with uniformly random
  // orientations (keyed by the run's seed, independent of the stage id and backend).
  void configure(State& s) override {
    state_ = &s;
    const int comps = orientation_components(s.dim());
    if (s.has_field(kOrientation)) {
      const Field& f = s.field(kOrientation);
      if (f.dtype() != s.real() || f.components() != comps || f.count() != s.n())
        throw InputError(std::string("abp.integrate: the field 'orientation' exists with ") +
                         to_string(f.dtype()) + " x" + std::to_string(f.components()) + "; in " +
                         std::to_string(s.dim()) + "D it must hold " + to_string(s.real()) + " x" +
                         std::to_string(comps) + (s.dim() == 2 ? " (the angle θ)" : " (a unit vector)"));
      return;
    }
    Field& f = s.add_particle_field(kOrientation, s.real(), comps);
    f.acquire(Where::host, Mode::write);
    const RngKey key = make_rng_key(seed_, "abp.orientation");
    R* o = f.host<R>();
    for (std::size_t i = 0; i < s.n(); ++i) {
      if (s.dim() == 2) RandomOrientation<R, 2>{o, key}(i);
      else RandomOrientation<R, 3>{o, key}(i);
    }
  }

  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    finite_.look(s, ctx.stream);  // an earlier step's (CUDA)
    // Where the previous values are now (the snapshot's copy, or the field itself).
    Field& pos_in = ctx.will_overwrite(fields::position);
    Field& img_in = ctx.will_overwrite(fields::image);
    Field& ori_in = ctx.will_overwrite(kOrientation);
    overdamped::keep_unowned(s, pos_in, fields::position, where_, mem_, ctx.stream);
    overdamped::keep_unowned(s, img_in, fields::image, where_, mem_, ctx.stream);
    overdamped::keep_unowned(s, ori_in, kOrientation, where_, mem_, ctx.stream);
    Field& pos = s.field(fields::position);
    Field& img = s.field(fields::image);
    Field& ori = s.field(kOrientation);
    R* x = pos.data<R>(where_);
    std::int32_t* im = img.data<std::int32_t>(where_);
    R* o = ori.data<R>(where_);
    const R* x0 = pos_in.data<R>(where_);
    const std::int32_t* im0 = img_in.data<std::int32_t>(where_);
    const R* o0 = ori_in.data<R>(where_);
    const auto box = PeriodicBox<R>::make(s.box.L);
    // Δt, the step and the attempt from ctx.params (the kernels' only way): capturable.
    auto step = [&](auto f) {
      f.position_in = x0;
      f.image_in = im0;
      f.position = x;
      f.image = im;
      f.type = nullptr;
      f.two_D[0] = 2.0 * p_.D;
      f.box = box;
      f.key = ctx.rng;
      // In a decomposed team the rank's particles draw as their global ids (as they do alone).
      f.id = s.has_field(fields::particle_id) ? s.field(fields::particle_id).data<std::uint32_t>(where_) : nullptr;
      f.params = ctx.params;
      f.drift = {o0, o, p_.v0, 2.0 * p_.Dr};
      f.non_finite = finite_.kernel_side(ctx.stream);
      return f;
    };
    // A decomposed team's ghosts move with their owners: the owned particles only.
    if (s.dim() == 2) loop2_(s.n_owned(), step(AbpStep<R, 2>{}), ctx.stream);
    else loop3_(s.n_owned(), step(AbpStep<R, 3>{}), ctx.stream);
    finite_.after_loop(s, ctx.stream);  // on the CPU; on CUDA after_step looks
    return Outcome::ok();
  }

  // The non-finite check's other looks (finite_check.h).
  void after_step(StepContext& ctx) override { finite_.after_step(ctx); }
  void save_state(StageState&) override { finite_.save_state(*state_); }
  void finish(State& s, bool completed) override { finite_.finish(s, completed); }

  // Its kernels take Δt, the step and the attempt from ctx.params, and will_overwrite swaps
  // nothing in a step the core captures (no snapshot then): a CUDA run can replay it from a graph.
  Scheduling scheduling() const override {
    Scheduling s;
    s.graph_capturable = true;
    s.reads_step_params = true;
    s.team = TeamWork::decomposed;  // owned particles only, noise keyed by particle id
    return s;
  }

 private:
  // Stops the run: `found.count` particles, the lowest `found.first`, had a non-finite position
  // or orientation after their step. Names the orientation when the particle's is not finite
  // (its position then is not either), else the position, with their values read back.
  [[noreturn]] void not_finite(State& s, const overdamped::NonFiniteFound& found, CUstream_st* stream) {
    const std::size_t i = found.first;
    auto values = [&](const char* name) {
      Field& f = s.field(name);
      f.acquire(Where::host, Mode::read, stream);
      const int c = f.components();
      const R* v = f.host<R>() + i * std::size_t(c);
      bool finite = true;
      std::string text = c > 1 ? "(" : "";
      for (int k = 0; k < c; ++k) {
        finite = finite && std::isfinite(double(v[k]));
        text += (k ? ", " : "") + overdamped::value_text(double(v[k]));
      }
      return std::make_pair(finite, text + (c > 1 ? ")" : ""));
    };
    const auto o = values(kOrientation), x = values(fields::position);
    const std::string what = !o.first ? std::string("orientation ") + (s.dim() == 2 ? "θ" : "e") + " = " + o.second +
                                            " (position " + x.second + ")"
                                      : "position " + x.second + " (orientation " + o.second + ")";
    throw RunError("stage '" + id_ + "' (abp.integrate), " + found.where() + ": particle " + std::to_string(i) +
                   " has a non-finite " + what +
                   (found.count > 1 ? " (" + std::to_string(found.count - 1) + " other particle(s) too)" : "") +
                   " after its step; the run stops. A value that is not finite came in with the configuration "
                   "(system.init) or from a stage before this one, or v0 Δt is not representable");
  }


  IntegrateParams p_;
  const MemoryOps& mem_;
  std::uint64_t seed_;
  Where where_;
  std::string id_;           // the stage's id, for messages
  State* state_ = nullptr;   // for save_state's message
  ElementLoop<AbpStep<R, 2>> loop2_;
  ElementLoop<AbpStep<R, 3>> loop3_;
  overdamped::NonFiniteCheck finite_;  // every step's check (stages/overdamped/integrate/finite_check.h)
};

}  // namespace ff::abp

FLIPFLOW_STAGE(ff::abp::AbpIntegrate)
