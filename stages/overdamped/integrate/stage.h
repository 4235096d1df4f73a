// overdamped.integrate: overdamped Langevin dynamics (Euler–Maruyama), 2D and 3D:
//   x += (v + μ_t F) Δt + sqrt(2 D_t Δt) ξ
// with the drift velocity v from the `velocity` field and the force F from the `force` field,
// each read when the pipeline has it (stages before this one create them: a force model writes
// `force`, phoretic.forces writes `velocity`), per-type mobility μ_t and diffusion coefficient D_t
// (one number for every type, or one per entry of system.types). brownian.integrate and
// phoretic.integrate are this stage with drift none / velocity.
#pragma once
#include <array>
#include <cmath>
#include <string>

#include "core/backend/memory.h"
#include "core/base/error.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/neighbors/list.h"
#include "stages/overdamped/integrate/finite_check.h"
#include "stages/overdamped/integrate/held.h"
#include "stages/overdamped/integrate/kernel.h"

namespace ff::overdamped {

inline constexpr const char* kVelocity = "velocity";  // real x dim: drift velocity (box lengths per τ)
inline constexpr const char* kForce = "force";        // real x dim: force (k_BT per box length)

struct IntegrateParams {
  PerType D{{1.0}};
  PerType mobility{{1.0}};
  std::string drift = "auto";
  double max_step = 0;
  std::string noise = "rescaled";

  template <class P>
  void describe(P& p) {
    p(D, "D",
      "translational diffusion coefficient D_t (box length²/τ; σ²/τ when system.sigma = 1): one for every "
      "type, or one per type")
        .at_least(0);
    p(mobility, "mobility",
      "mobility μ_t (box length²/(k_BT τ): velocity per unit force) multiplying the `force` field: one, or one "
      "per type")
        .at_least(0);
    p(drift, "drift",
      "fields that move particles besides noise: auto (`velocity` and/or `force`, whichever a stage before "
      "creates), none, velocity, force, or velocity+force (those must exist)")
        .one_of({"auto", "none", "velocity", "force", "velocity+force"});
    p(max_step, "max_step",
      "longest step a particle may take (box units, not scaled by σ); a longer one rolls the step back with a "
      "smaller Δt instead of going on from a blown-up state (0: no check; with a check the step cannot be "
      "replayed from a CUDA graph). A non-finite position stops the run naming the particle with or without it")
        .at_least(0);
    p(noise, "noise",
      "how the Gaussians ξ are kept within ±3: rescaled (a pair outside is redrawn, then scaled to unit "
      "variance) or clamp (each clamped to ±3, variance 0.995: Carter et al. 2017 §2.4, for exact reproduction)")
        .one_of({"rescaled", "clamp"});
  }
};

// The plain Brownian loop and the general one (kernel.h says why two), in 2D and 3D, in place
// and, for a step whose previous positions the rollback snapshot keeps (will_overwrite), from
// those arrays into the field's.
template <class R, bool InPlace>
struct IntegrateLoopsOf {
  ElementLoop<OverdampedStep<R, 2, false, NoDrift, InPlace>> plain2;
  ElementLoop<OverdampedStep<R, 2, true, FieldDrift<R, 2>, InPlace>> general2;
  ElementLoop<OverdampedStep<R, 3, false, NoDrift, InPlace>> plain3;
  ElementLoop<OverdampedStep<R, 3, true, FieldDrift<R, 3>, InPlace>> general3;
};
template <class R>
struct IntegrateLoops {
  IntegrateLoopsOf<R, true> in_place;
  IntegrateLoopsOf<R, false> from_snapshot;
};

// The overdamped loops of the backend object (CpuExec or CudaExec) this stage.h is compiled for
// (core/stage/stage_registration.h).
template <class R, bool InPlace, class Exec>
IntegrateLoopsOf<R, InPlace> integrate_loops_of(Exec) {
  return {&Exec::template overdamped<OverdampedStep<R, 2, false, NoDrift, InPlace>>,
          &Exec::template overdamped<OverdampedStep<R, 2, true, FieldDrift<R, 2>, InPlace>>,
          &Exec::template overdamped<OverdampedStep<R, 3, false, NoDrift, InPlace>>,
          &Exec::template overdamped<OverdampedStep<R, 3, true, FieldDrift<R, 3>, InPlace>>};
}
template <class R, class Exec>
IntegrateLoops<R> integrate_loops(Exec exec) {
  return {integrate_loops_of<R, true>(exec), integrate_loops_of<R, false>(exec)};
}

template <class R>
class OverdampedIntegrate final : public Stage {
 public:
  static StageDecl declaration() {
    return {"overdamped.integrate", "overdamped Langevin step x += (v + μF)Δt + sqrt(2DΔt)·ξ (per-type μ, D)",
            schema_of<IntegrateParams>(), {2, 3}, false};
  }

  template <class Exec>
  OverdampedIntegrate(const ParamValues& v, const RunInfo& info, Exec exec)
      : p_(params_from<IntegrateParams>(v)),
        mem_(exec.memory()),
        where_(Exec::where),
        loops_(integrate_loops<R>(Exec{})),
        id_(info.stage_id),
        too_far_(Exec{}),
        finite_(Exec{}, info.steps,
                [this](State& s, const NonFiniteFound& f, CUstream_st* stream) { not_finite(s, f, stream); }) {}

  void configure(State& s) override {
    state_ = &s;
    const bool want_v = p_.drift == "velocity" || p_.drift == "velocity+force";
    const bool want_f = p_.drift == "force" || p_.drift == "velocity+force";
    for (const char* f : {kVelocity, kForce}) {
      const bool wanted = f == kVelocity ? want_v : want_f;
      if (wanted && !s.has_field(f))
        throw InputError(std::string("overdamped.integrate: drift: ") + p_.drift + " needs the `" + f +
                         "` field, which no stage before it creates (put the stage that writes it first)");
    }
    reads_velocity_ = want_v || (p_.drift == "auto" && s.has_field(kVelocity));
    reads_force_ = want_f || (p_.drift == "auto" && s.has_field(kForce));
    for (const char* f : {kVelocity, kForce})
      if ((f == kVelocity ? reads_velocity_ : reads_force_) &&
          (s.field(f).dtype() != s.real() || s.field(f).components() != s.dim() || s.field(f).count() != s.n()))
        throw InputError(std::string("overdamped.integrate: the field `") + f + "` must hold " + to_string(s.real()) +
                         " x" + std::to_string(s.dim()) + " per particle");
    types_ = s.species.empty() ? 1 : s.species.size();
    check_per_type("D", p_.D);
    check_per_type("mobility", p_.mobility);
    // A Verlet list made before this stage (neighbors.verlet): answer its rebuild test for the
    // positions this step writes, where the counters are read back anyway (max_step) and the
    // test would otherwise cost a pass over the positions (CPU) or a kernel and a wait of its
    // own (CUDA). skin/2 squared as ListBuild::moved_too_far computes it, so the answers are the
    // same.
    lists_moved_ = p_.max_step > 0 && s.has_field(neighbors::kMoved) &&
                   s.has_field(neighbors::kBuildParams);
    if (lists_moved_) {
      Field& bp = s.field(neighbors::kBuildParams);
      bp.acquire(Where::host, Mode::read);
      const R half = R(0.5 * bp.host<double>()[1]);
      skin_half2_ = half * half;
    }
  }

  // Every element of position and image is rewritten each step from its previous value, which
  // the rollback snapshot keeps instead of copying (on_demand + will_overwrite, as abp.integrate).
  std::vector<Access> accesses() const override {
    std::vector<Access> a{Access::on_demand_write(fields::position, where_),
                          Access::on_demand_write(fields::image, where_)};
    if (reads_velocity_) a.push_back({kVelocity, where_, Mode::read});
    if (reads_force_) a.push_back({kForce, where_, Mode::read});
    if (per_type()) a.push_back({fields::type, where_, Mode::read});
    if (lists_moved_) {
      a.push_back({neighbors::kPositionAtBuild, where_, Mode::read});
      a.push_back({neighbors::kMoved, Where::host, Mode::write});
    }
    return a;
  }

  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    finite_.look(s, ctx.stream);  // an earlier step's (CUDA)
    // Where the previous values are now: the snapshot's copy, or the field itself (in place).
    Field& pos_in = ctx.will_overwrite(fields::position);
    Field& img_in = ctx.will_overwrite(fields::image);
    overdamped::keep_unowned(s, pos_in, fields::position, where_, mem_, ctx.stream);
    overdamped::keep_unowned(s, img_in, fields::image, where_, mem_, ctx.stream);
    auto ptr = [&](const char* f) { return s.field(f).data<R>(where_); };
    Field& img = s.field(fields::image);
    const bool in_place = &pos_in == &s.field(fields::position) && &img_in == &img;
    Field& type = s.field(fields::type);
    const std::int32_t* t = per_type() ? type.data<std::int32_t>(where_) : nullptr;
    // The members every configuration sets (in place: position_in and image_in are not read).
    auto common = [&](auto f) {
      f.position = ptr(fields::position);
      f.image = img.data<std::int32_t>(where_);
      f.position_in = in_place ? nullptr : pos_in.data<R>(where_);
      f.image_in = in_place ? nullptr : img_in.data<std::int32_t>(where_);
      f.type = nullptr;
      f.two_D[0] = 2 * p_.D[0];
      f.box = PeriodicBox<R>::make(s.box.L);
      f.key = ctx.rng;
      // In a decomposed team the rank's particles draw as their global ids (as they do alone).
      f.id = s.has_field(fields::particle_id) ? s.field(fields::particle_id).data<std::uint32_t>(where_) : nullptr;
      f.tail = p_.noise == "clamp" ? GaussianTail::clamped : GaussianTail::rescaled;
      f.params = ctx.params;
      f.non_finite = finite_.kernel_side(ctx.stream);
      return f;
    };
    auto general = [&](auto f) {
      f = common(f);
      f.type = t;
      for (std::size_t k = 0; k < std::size_t(kMaxTypes); ++k) {
        f.two_D[k] = 2 * p_.D[k < types_ ? k : 0];
        f.drift.mobility[k] = p_.mobility[k < types_ ? k : 0];
      }
      f.drift.velocity = reads_velocity_ ? ptr(kVelocity) : nullptr;
      f.drift.force = reads_force_ ? ptr(kForce) : nullptr;
      if (p_.max_step > 0) {
        f.too_far = too_far_.ptr() + 1;
        f.max_step2 = p_.max_step * p_.max_step;
      }
      if (lists_moved_) {
        f.moved = too_far_.ptr();
        f.list_test = {f.position, ptr(neighbors::kPositionAtBuild), f.box, skin_half2_};
      }
      return f;
    };
    // Counts start at 0, first particles at ~0u (they keep a minimum): fills on the loop's side.
    if (p_.max_step > 0) too_far_.reset(std::array<int, 2>{2, 4}, ctx.stream);
    if (in_place) launch(ctx, loops_.in_place, common, general);
    else launch(ctx, loops_.from_snapshot, common, general);
    const Outcome out = p_.max_step > 0 ? too_far(ctx) : Outcome::ok();
    // On the CPU the loop is done (and max_step's read waited for the device): look now. Else
    // after_step looks, once the step is enqueued.
    finite_.after_loop(s, ctx.stream, p_.max_step > 0);
    return out;
  }

  // The non-finite check's other looks (finite_check.h).
  void after_step(StepContext& ctx) override { finite_.after_step(ctx); }
  void save_state(StageState&) override { finite_.save_state(*state_); }
  void finish(State& s, bool completed) override { finite_.finish(s, completed); }

  template <bool InPlace, class Common, class General>
  void launch(StepContext& ctx, const IntegrateLoopsOf<R, InPlace>& loops, Common common, General general) const {
    const std::size_t n = ctx.state.n_owned();  // a decomposed team's ghosts move with their owners
    if (ctx.state.dim() == 2) {
      if (is_general()) loops.general2(n, general(OverdampedStep<R, 2, true, FieldDrift<R, 2>, InPlace>{}), ctx.stream);
      else loops.plain2(n, common(OverdampedStep<R, 2, false, NoDrift, InPlace>{}), ctx.stream);
    } else {
      if (is_general()) loops.general3(n, general(OverdampedStep<R, 3, true, FieldDrift<R, 3>, InPlace>{}), ctx.stream);
      else loops.plain3(n, common(OverdampedStep<R, 3, false, NoDrift, InPlace>{}), ctx.stream);
    }
  }

  // Δt, step and attempt reach the kernels through ctx.params in every configuration, so a CUDA
  // run can replay this stage from a graph; not with max_step, whose check the host reads back
  // (a request from run()).
  Scheduling scheduling() const override {
    Scheduling s;
    s.may_request_rollback = p_.max_step > 0;
    s.graph_capturable = p_.max_step == 0;
    s.reads_step_params = true;
    s.team = TeamWork::decomposed;  // each particle's step reads only its own entries
    return s;
  }

 private:
  Outcome too_far(StepContext& ctx) {
    const std::array<unsigned, 5>& all = too_far_.read(ctx.stream);
    if (lists_moved_) {  // the list's test for these positions (neighbors.moved)
      std::uint64_t* moved = ctx.state.field(neighbors::kMoved).host<std::uint64_t>();
      moved[0] = ctx.state.field(fields::position).version();
      moved[1] = all[0] != 0 ? 1 : 0;
    }
    const unsigned* c = all.data() + 1;  // max_step's slots
    if (c[2]) {
      NonFiniteFound f;
      f.count = c[2];
      f.first = c[3];
      f.step = ctx.host_params.step;
      f.attempt = ctx.host_params.attempt;
      not_finite(ctx.state, f, ctx.stream);
    }
    const unsigned count = c[0], first = c[1];
    if (!count) return Outcome::ok();
    return Outcome::request_rollback("overdamped.integrate: " + std::to_string(count) +
                                         " particle(s) would move farther than max_step = " +
                                         format_value(ParamValue(p_.max_step)) + " in one step (the first is particle " +
                                         std::to_string(first) + ", at Δt = " + format_value(ParamValue(ctx.host_params.dt)) +
                                         "); the step is retried with a smaller time step",
                                     {first});
  }
  // Stops the run: `f.count` particles, the lowest `f.first`, had a non-finite position or step.
  // Names the first input of that particle that is not finite (force, velocity; else the
  // position), read back on the host.
  [[noreturn]] void not_finite(State& s, const NonFiniteFound& found, CUstream_st* stream) {
    const unsigned first = found.first, count = found.count;
    std::string what = "position (at the start of the step, or after adding its step)", values;
    for (const char* f : {kForce, kVelocity}) {
      if (!(f == kForce ? reads_force_ : reads_velocity_)) continue;
      Field& field = s.field(f);
      field.acquire(Where::host, Mode::read, stream);
      const R* v = field.host<R>() + std::size_t(first) * s.dim();
      bool bad = false;
      for (int k = 0; k < s.dim(); ++k) bad |= !std::isfinite(double(v[k]));
      if (!bad) continue;
      what = std::string("`") + f + "` field (written by a stage before this one)";
      values = " = (";
      for (int k = 0; k < s.dim(); ++k) values += (k ? ", " : "") + value_text(double(v[k]));
      values += ")";
      break;
    }
    throw RunError("stage '" + id_ + "' (overdamped.integrate), " + found.where() + ": particle " +
                   std::to_string(first) + " has a non-finite " + what + values +
                   (count > 1 ? " (" + std::to_string(count - 1) + " other particle(s) too)" : std::string()) +
                   "; a smaller time step cannot mend this, so the run stops. Look for particles that met closer "
                   "than the force model allows in the steps before (a lower run.dt or max_step helps then)");
  }
  bool per_type() const { return !p_.D.uniform() || !p_.mobility.uniform(); }
  bool is_general() const { return reads_velocity_ || reads_force_ || per_type() || p_.max_step > 0; }
  void check_per_type(const char* name, const PerType& v) const {
    if (!v.uniform() && v.values.size() != types_)
      throw InputError(std::string("overdamped.integrate: ") + name + " has " + std::to_string(v.values.size()) +
                       " values; give one for every type, or one per type (system.types has " +
                       std::to_string(types_) + ")");
    if (types_ > std::size_t(kMaxTypes))
      throw InputError("overdamped.integrate: at most " + std::to_string(kMaxTypes) + " particle types");
  }

  IntegrateParams p_;
  const MemoryOps& mem_;
  Where where_;
  IntegrateLoops<R> loops_;
  std::string id_;             // the stage's id, for messages
  State* state_ = nullptr;     // for save_state's message
  Counters<5> too_far_;        // the list's test (lists_moved_); max_step's count and first particle; non-finite ones'
  NonFiniteCheck finite_;      // every step's check of the positions (finite_check.h)
  bool reads_velocity_ = false, reads_force_ = false;
  std::size_t types_ = 1;
  bool lists_moved_ = false;  // answers a Verlet list's rebuild test (configure)
  R skin_half2_ = 0;          // (skin/2)² of that list
};

}  // namespace ff::overdamped

FLIPFLOW_STAGE(ff::overdamped::OverdampedIntegrate)
