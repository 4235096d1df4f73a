// chiral_abp.integrate: chiral active Brownian particles, "circle swimmers", in 2D (van Teeffelen
// & Löwen, PRE 78, 020101 (2008)); the step is in kernel.h. Force-free, like abp.integrate, whose
// `orientation` field (the angle θ) it shares: it adds the field when no stage has, with
// uniformly random angles. A stage in flipflow's shape (core/stage/stage_registration.h): the plugin's
// build (flipflow_add_plugin) compiles this header once per backend.
#pragma once
#include <string>

#include "core/base/error.h"
#include "core/backend/exec.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "kernel.h"

namespace chiral_abp {

inline constexpr const char* kOrientation = "orientation";  // θ (real x1)

// The parameters, described once: the schema `pipeline stages` shows and the YAML is checked
// against, and the values the stage reads.
struct IntegrateParams {
  double v0 = 1.0;     // self-propulsion speed
  double omega = 1.0;  // angular velocity
  double Dr = 1.0;     // rotational diffusion coefficient
  double D = 0.0;      // translational diffusion coefficient

  template <class P>
  void describe(P& p) {
    p(v0, "v0", "self-propulsion speed (box lengths per τ; σ/τ when system.sigma = 1)").at_least(0);
    p(omega, "omega", "angular velocity ω (rad/τ; > 0: counter-clockwise circles of radius v0/|ω|)");
    p(Dr, "Dr", "rotational diffusion coefficient (1/τ)").at_least(0);
    p(D, "D", "translational diffusion coefficient (box length²/τ; σ²/τ when system.sigma = 1)").at_least(0);
  }
};

template <class R>
class ChiralAbpIntegrate final : public ff::Stage {
 public:
  static ff::StageDecl declaration() {
    return {"chiral_abp.integrate",
            "chiral active Brownian particles (2D circle swimmers): θ += ωΔt + sqrt(2D_rΔt)η, "
            "x += v0 e(θ)Δt + sqrt(2DΔt)ξ",
            ff::schema_of<IntegrateParams>(), {2}, false};
  }

  // Exec: ff::CpuExec or ff::CudaExec; its overdamped loop draws the noise and calls move().
  template <class Exec>
  ChiralAbpIntegrate(const ff::ParamValues& v, const ff::RunInfo& info, Exec)
      : p_(ff::params_from<IntegrateParams>(v)),
        seed_(info.seed),
        where_(Exec::where),
        loop_(&Exec::template overdamped<ChiralStep<R>>) {}

  // Every element is rewritten from the previous values each step (on_demand + will_overwrite:
  // a rollback snapshot keeps the old arrays instead of copying them).
  std::vector<ff::Access> accesses() const override {
    return {ff::Access::on_demand_write(ff::fields::position, where_),
            ff::Access::on_demand_write(ff::fields::image, where_),
            ff::Access::on_demand_write(kOrientation, where_)};
  }

  void configure(ff::State& s) override {
    if (s.has_field(kOrientation)) {
      const ff::Field& f = s.field(kOrientation);
      if (f.dtype() != s.real() || f.components() != 1 || f.count() != s.n())
        throw ff::InputError(std::string("chiral_abp.integrate: the field 'orientation' exists with ") +
                             ff::to_string(f.dtype()) + " x" + std::to_string(f.components()) +
                             "; it must hold the angle θ, " + ff::to_string(s.real()) + " x1");
      return;
    }
    ff::Field& f = s.add_particle_field(kOrientation, s.real(), 1);
    f.acquire(ff::Where::host, ff::Mode::write);
    const RandomAngle<R> init{f.host<R>(), ff::make_rng_key(seed_, "chiral_abp.orientation")};
    for (std::size_t i = 0; i < s.n(); ++i) init(i);
  }

  ff::Outcome run(ff::StepContext& ctx) override {
    ff::State& s = ctx.state;
    // Where the previous values are now (the snapshot's copy, or the field itself).
    ff::Field& pos_in = ctx.will_overwrite(ff::fields::position);
    ff::Field& img_in = ctx.will_overwrite(ff::fields::image);
    ff::Field& ori_in = ctx.will_overwrite(kOrientation);
    ff::Field& pos = s.field(ff::fields::position);
    ff::Field& img = s.field(ff::fields::image);
    ff::Field& ori = s.field(kOrientation);
    const ChiralStep<R> step{data<R>(pos_in), data<std::int32_t>(img_in), data<R>(ori_in),
                             data<R>(pos), data<std::int32_t>(img), data<R>(ori),
                             ff::PeriodicBox<R>::make(s.box.L),
                             p_.v0, p_.omega, 2.0 * p_.D, 2.0 * p_.Dr,
                             ctx.rng, ctx.params};
    loop_(s.n(), step, ctx.stream);
    return ff::Outcome::ok();
  }

  // The kernel takes Δt, the step and the attempt from ctx.params (never ctx.host_params), so
  // on CUDA the core keeps a device copy of them and may replay the step from a captured graph.
  ff::Scheduling scheduling() const override {
    ff::Scheduling s;
    s.graph_capturable = true;
    s.reads_step_params = true;
    return s;
  }

 private:
  template <class T>
  T* data(ff::Field& f) const { return where_ == ff::Where::device ? f.device<T>() : f.host<T>(); }

  IntegrateParams p_;
  std::uint64_t seed_;
  ff::Where where_;  // host (CpuExec) or device (CudaExec)
  ff::ElementLoop<ChiralStep<R>> loop_;
};

}  // namespace chiral_abp

FLIPFLOW_STAGE(chiral_abp::ChiralAbpIntegrate)
