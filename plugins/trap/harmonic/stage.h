// trap.harmonic: an external harmonic potential (an optical trap) on every particle, U = k/2 |x − c|²
// with the minimum-image displacement (kernel.h), fixed or moving at a constant velocity, on every
// particle or on those of the listed types, into the `force` field that overdamped.integrate
// reads (x += μ F Δt + sqrt(2DΔt) ξ). Alone it writes `force`; with add: true it adds onto the force
// a stage before it wrote this step (harmonic.forces, pair.lj: those replace the field, so they
// come first). With energy: true it also writes U_i per particle (`trap.energy`) for observers.
// 2D and 3D, CPU and CUDA (the same bits), float and double.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "core/backend/exec.h"
#include "core/base/error.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "core/stage/type_names.h"
#include "plugins/trap/harmonic/kernel.h"

namespace ff::trap {

inline constexpr const char* kForce = "force";         // real x dim (k_BT per box length)
inline constexpr const char* kEnergy = "trap.energy";  // real x1: U_i (k_BT)

struct TrapParams {
  double k = 1;
  std::vector<double> centre{};
  std::vector<std::string> axes{};
  std::vector<double> velocity{};
  std::vector<std::string> types{};
  bool add = false;
  bool energy = false;

  template <class P>
  void describe(P& p) {
    p(k, "k", "stiffness k (k_BT/length², box units) of the trap U = k/2 |x − c|² (μk is the relaxation rate; "
              "⟨(x − c)_a²⟩ = k_BT/k per trapped axis)")
        .at_least(0);
    p(centre, "centre",
      "the trap's centre c: one number per dimension (box units); [] (the default) is the box centre. Each "
      "particle is pulled towards the nearest periodic image of c");
    p(axes, "axes", "the trapped axes (x, y, z); [] (the default): all of them. The others are free")
        .one_of({"x", "y", "z"});
    p(velocity, "velocity",
      "the trap's velocity v: one number per dimension (box units per unit time); the centre is c + v t at the "
      "start of each step, wrapped into the box. [] (the default): a fixed trap. A particle dragged at v lags "
      "behind the centre by v/(μk) (Stokes drag)");
    p(types, "types",
      "the names of the system.types whose particles feel the trap (a probe among a bath); [] (the default): every "
      "particle. The others get no force from it (and trap.energy 0)");
    p(add, "add",
      "add the trap's force to the `force` field a stage before it wrote this step (harmonic.forces, pair.lj), "
      "instead of writing it");
    p(energy, "energy",
      "also write the per-particle field trap.energy, U_i = k/2 |x_i − c|² (k_BT) at the positions the step "
      "starts from");
  }
};

template <class R>
class HarmonicTrap final : public Stage {
 public:
  static StageDecl declaration() {
    return {"trap.harmonic",
            "external harmonic trap U = k/2 |x − c|², F = −k (x − c) (minimum image) into `force`",
            schema_of<TrapParams>(), {2, 3}, false};
  }

  template <class Exec>
  HarmonicTrap(const ParamValues& v, const RunInfo&, Exec)
      : p_(params_from<TrapParams>(v)), where_(Exec::where),
        loop2_(&Exec::template for_each<TrapForce<R, 2>>), loop3_(&Exec::template for_each<TrapForce<R, 3>>) {
    for (int a = 0; a < 3; ++a) {
      velocity_[a] = a < int(p_.velocity.size()) ? p_.velocity[a] : 0.0;
      moving_ = moving_ || velocity_[a] != 0.0;
    }
  }

  std::vector<Access> accesses() const override {
    // Remade (or, with add, finished) before it is read: no snapshot copy.
    std::vector<Access> a{{fields::position, where_, Mode::read},
                          Access::step_local_write(kForce, where_, p_.add ? Mode::readwrite : Mode::write)};
    if (p_.energy) a.push_back(Access::step_local_write(kEnergy, where_));
    if (!p_.types.empty()) a.push_back({fields::type, where_, Mode::read});
    return a;
  }

  void configure(State& s) override {
    const int dim = s.dim();
    if (!p_.centre.empty() && int(p_.centre.size()) != dim)
      throw InputError("trap.harmonic: centre has " + std::to_string(p_.centre.size()) +
                       " numbers; give one per dimension (" + std::to_string(dim) + "), or none for the box centre");
    for (int a = 0; a < 3; ++a) {
      centre_[a] = p_.centre.empty() ? 0.5 * s.box.L[a] : (a < dim ? p_.centre[a] : 0.0);
      mask_[a] = p_.axes.empty() ? 1.0 : 0.0;
    }
    if (!p_.velocity.empty() && int(p_.velocity.size()) != dim)
      throw InputError("trap.harmonic: velocity has " + std::to_string(p_.velocity.size()) +
                       " numbers; give one per dimension (" + std::to_string(dim) + "), or none for a fixed trap");
    trapped_types_ = std::uint32_t(type_mask(s, p_.types, "trap.harmonic", 32));
    for (const std::string& axis : p_.axes) {
      const int a = axis[0] - 'x';
      if (a >= dim)
        throw InputError("trap.harmonic: axes names `" + axis + "`, but the system has " + std::to_string(dim) +
                         " dimensions (x, y" + (dim == 3 ? ", z" : "") + ")");
      mask_[a] = 1.0;
    }
    const bool exists = s.has_field(kForce);
    if (p_.add && !exists)
      throw InputError("trap.harmonic: add: true adds to the `force` field, which no stage before it writes (put "
                       "the force stage first, or drop add)");
    if (!p_.add && exists)
      throw InputError("trap.harmonic: a stage before it writes `force`, which this stage would replace; set "
                       "`add: true` to add the trap's force to it");
    s.add_particle_field(kForce, s.real(), s.dim());  // or the one a stage before made, if the same shape
    if (p_.energy) s.add_particle_field(kEnergy, s.real(), 1);
  }

  Outcome run(StepContext& ctx) override {
    if (ctx.state.dim() == 2) launch<2>(ctx, loop2_);
    else launch<3>(ctx, loop3_);
    return Outcome::ok();
  }

  // One kernel on the stage's stream, nothing read back: a CUDA step may replay it from a graph.
  // In a decomposed team each rank's owned particles (each reads only its own entries).
  Scheduling scheduling() const override {
    Scheduling s;
    s.graph_capturable = true;
    s.reads_step_params = moving_;  // the moving centre's time, on the device in a replayed graph
    s.team = TeamWork::decomposed;
    return s;
  }

 private:
  template <int D>
  void launch(StepContext& ctx, ElementLoop<TrapForce<R, D>> loop) const {
    State& s = ctx.state;
    TrapForce<R, D> f{};
    f.position = s.field(fields::position).data<R>(where_);
    f.force = s.field(kForce).data<R>(where_);
    f.energy = p_.energy ? s.field(kEnergy).data<R>(where_) : nullptr;
    f.box = PeriodicBox<R>::make(s.box.L);
    f.k = R(p_.k);
    for (int a = 0; a < D; ++a) {
      f.centre[a] = centre_[a];
      f.mask[a] = R(mask_[a]);
    }
    f.add = p_.add;
    f.type = p_.types.empty() ? nullptr : s.field(fields::type).data<std::int32_t>(where_);
    f.trapped_types = trapped_types_;
    for (int a = 0; a < D; ++a) {
      f.velocity[a] = velocity_[a];
      f.length[a] = s.box.L[a];
    }
    f.params = moving_ ? ctx.params : nullptr;
    loop(s.n_owned(), f, ctx.stream);
  }

  TrapParams p_;
  Where where_;
  double centre_[3] = {};
  double mask_[3] = {};
  double velocity_[3] = {};
  bool moving_ = false;
  std::uint32_t trapped_types_ = 0;  // bit t: type t feels the trap (with types)
  ElementLoop<TrapForce<R, 2>> loop2_;
  ElementLoop<TrapForce<R, 3>> loop3_;
};

}  // namespace ff::trap

FLIPFLOW_STAGE(ff::trap::HarmonicTrap)
