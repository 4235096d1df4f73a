// harmonic.forces: soft repulsive disks/spheres, F_ij = k (σ_ij − r) r̂_ij for r < σ_ij, through
// the Verlet list of a neighbors.verlet stage before it, into the `force` field that
// overdamped.integrate reads (x += μ F Δt + noise). Metric `pairs`: overlapping pairs this step.
#pragma once
#include <algorithm>
#include <string>

#include "core/base/error.h"
#include "core/backend/exec.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "plugins/harmonic/forces/kernel.h"
#include "stages/neighbors/list.h"

namespace ff::harmonic {

inline constexpr const char* kForce = "force";                 // real x dim (k_BT/σ)
inline constexpr const char* kPairs = "harmonic.pairs";        // u32: overlapping pairs

struct ForcesParams {
  double k = 100;
  template <class P>
  void describe(P& p) {
    p(k, "k", "stiffness k (k_BT/σ²) of the contact force k (σ_ij − r) r̂ between overlapping particles").above(0);
  }
};

template <class R>
class Forces final : public Stage {
 public:
  static StageDecl declaration() {
    return {"harmonic.forces", "soft disks/spheres: F_ij = k (σ_ij − r) r̂_ij for r < σ_ij = (σ_i + σ_j)/2, into `force`",
            schema_of<ForcesParams>(), {2, 3}, false};
  }

  template <class Exec>
  Forces(const ParamValues& v, const RunInfo&, Exec)
      : p_(params_from<ForcesParams>(v)), where_(Exec::where),
        loop2_(&Exec::template for_each<PairForce<R, 2>>), loop3_(&Exec::template for_each<PairForce<R, 3>>) {}

  std::vector<Access> accesses() const override {
    return {{fields::position, where_, Mode::read},
            {fields::diameter, where_, Mode::read},
            {neighbors::kList, where_, Mode::read},
            {neighbors::kCount, where_, Mode::read},
            {kForce, where_, Mode::write},
            Access::step_local_write(kPairs, Where::host)};
  }

  void configure(State& s) override {
    if (!s.has_field(neighbors::kList) || !s.has_field(neighbors::kCutoff))
      throw InputError("harmonic.forces: needs a neighbors.verlet stage earlier in the step list (add "
                       "`- {stage: neighbors.verlet, cutoff: 1.0, skin: 0.3}` before it; cutoff ≥ the largest diameter)");
    Field& c = s.field(neighbors::kCutoff);
    Field& d = s.field(fields::diameter);
    c.acquire(Where::host, Mode::read);
    d.acquire(Where::host, Mode::read);
    const double cutoff = double(c.host<R>()[0]);
    const double largest = s.n() ? double(*std::max_element(d.host<R>(), d.host<R>() + s.n())) : 0.0;
    if (cutoff < largest)  // a contact pair of the two largest particles could be missing from the list
      throw InputError("harmonic.forces: the neighbors.verlet cutoff " + std::to_string(cutoff) +
                       " is smaller than the largest diameter " + std::to_string(largest) +
                       "; raise neighbors.verlet's `cutoff` to at least it (or shrink system.sigma)");
    if (!s.has_field(kForce)) s.add_particle_field(kForce, s.real(), s.dim());  // overdamped.integrate checks its shape
    s.add_field(kPairs, DType::u32, 1, 1);
  }

  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    Field& pairs = s.field(kPairs);
    pairs.acquire(Where::host, Mode::write);
    pairs.host<unsigned>()[0] = 0;
    pairs.acquire(where_, Mode::readwrite, ctx.stream);
    if (s.dim() == 2) loop2_(s.n(), pair_force<2>(s), ctx.stream);
    else loop3_(s.n(), pair_force<3>(s), ctx.stream);
    pairs.acquire(Where::host, Mode::read, ctx.stream);
    ctx.metrics.set("pairs", pairs.host<unsigned>()[0]);
    return Outcome::ok();
  }

 private:
  template <int D>
  PairForce<R, D> pair_force(State& s) const {
    return {ptr<R>(s, fields::position),  ptr<R>(s, fields::diameter), ptr<R>(s, kForce),
            ptr<std::uint32_t>(s, neighbors::kList), ptr<std::uint32_t>(s, neighbors::kCount),
            neighbors::list_capacity(s), PeriodicBox<R>::make(s.box.L), R(p_.k), ptr<unsigned>(s, kPairs)};
  }
  template <class T>
  T* ptr(State& s, const char* name) const {
    return where_ == Where::device ? s.field(name).device<T>() : s.field(name).host<T>();
  }

  ForcesParams p_;
  Where where_;
  ElementLoop<PairForce<R, 2>> loop2_;
  ElementLoop<PairForce<R, 3>> loop3_;
};

}  // namespace ff::harmonic

FLIPFLOW_STAGE(ff::harmonic::Forces)
