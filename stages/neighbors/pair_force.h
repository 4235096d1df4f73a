// A force stage for pair models through the Verlet list of a neighbors.verlet stage before it.
// The model writes its physics: its parameters, and a functor that sums the pair force on one
// particle over its row of the list. This template does the rest once for every such model: the
// parameter schema, the fields read and written, the checks against the list, the loops on each
// backend in 2D and 3D, and the `pairs` metric. A model M (a struct of parameters) provides
//
//   static constexpr const char* name, * summary;            // the stage's name, one line on it
//   double k = ...; template <class P> void describe(P& p);  // parameters (core/stage/params.h)
//   double range(double sigma_i, double sigma_j) const;      // no force between particles of
//                                                            //   these diameters beyond it
//   template <class R, int D> F<R, D> kernel() const;        // the functor, parameters set
//
// where F<R, D> has a member `PairSystem<R, D> sys` (set by the stage before every loop) and an
// FF_HD `operator()(std::size_t i)` that writes sys.force for particle i, summing over
// sys.neighbors(i) in list order (the same terms in the same order on every backend and after
// every rebuild) and calling sys.count_pair(i, j) for each pair it feels. The model's stage.h
// then ends with
//
//   template <class R> using Forces = ff::neighbors::PairForceStage<R, M>;
//   FLIPFLOW_STAGE(ff::<model>::Forces)
//
// plugins/harmonic/forces is the worked example (docs/writing-a-model.md). nvcc-clean.
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/backend/atomics.h"
#include "core/backend/exec.h"
#include "core/backend/memory.h"
#include "core/base/error.h"
#include "core/base/hd.h"
#include "core/physics/box.h"
#include "core/physics/math.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/neighbors/list.h"

namespace ff::neighbors {

inline constexpr const char* kForce = "force";  // real x dim: what overdamped.integrate reads (k_BT/σ)

// A row of the Verlet list: the neighbors of one particle, in ascending index order.
struct Row {
  const std::uint32_t* first;
  const std::uint32_t* last;
  FF_HD const std::uint32_t* begin() const { return first; }
  FF_HD const std::uint32_t* end() const { return last; }
};

// The system as a pair-force functor sees it, on its backend's side.
template <class R, int D>
struct PairSystem {
  const R* position;  // N x D
  const R* diameter;  // N
  R* force;           // N x D: the functor writes every element of its particle
  ListView verlet;    // the Verlet list (list.h)
  PeriodicBox<R> box;
  unsigned* pairs;    // the `pairs` metric
  const std::uint32_t* id = nullptr;  // global ids in a decomposed team (core/run/domain.h); null: the index

  // The neighbors j of particle i: every particle closer than the list's cutoff, and some farther.
  FF_HD Row neighbors(std::size_t i) const {
    const std::uint32_t* row = verlet.list + i * verlet.capacity;
    return {row, row + verlet.count[i]};
  }
  // Counts a pair that feels the force once (from its lower index, or id: a pair across two
  // ranks of a decomposed team is in a row on each) into the `pairs` metric.
  FF_HD void count_pair(std::size_t i, std::size_t j) const {
    if (id ? id[j] > id[i] : j > i) count_one(pairs);
  }
};

template <class R, class Model>
class PairForceStage final : public Stage {
  template <int D>
  using Kernel = decltype(std::declval<const Model&>().template kernel<R, D>());

 public:
  static StageDecl declaration() { return {Model::name, Model::summary, schema_of<Model>(), {2, 3}, false}; }

  template <class Exec>
  PairForceStage(const ParamValues& v, const RunInfo&, Exec)
      : model_(params_from<Model>(v)), where_(Exec::where), pairs_(Exec{}),
        loop2_(&Exec::template for_each<Kernel<2>>), loop3_(&Exec::template for_each<Kernel<3>>) {}

  std::vector<Access> accesses() const override {
    return {{fields::position, where_, Mode::read}, {fields::diameter, where_, Mode::read},
            {kList, where_, Mode::read},            {kCount, where_, Mode::read},
            Access::step_local_write(kForce, where_)};  // remade before it is read: no snapshot copy
  }

  void configure(State& s) override {
    // The messages do not name the stage: the step's error names it (and its line).
    if (!s.has_field(kList) || !s.has_field(kCutoff))
      throw InputError("needs a neighbors.verlet stage earlier in the step list (add `- {stage: "
                       "neighbors.verlet, cutoff: 1.0, skin: 0.3}` before it, its cutoff at least the force's range)");
    Field& c = s.field(kCutoff);
    Field& d = s.field(fields::diameter);
    c.acquire(Where::host, Mode::read);
    d.acquire(Where::host, Mode::read);
    const double cutoff = double(c.host<R>()[0]);
    const double largest = s.n() ? double(*std::max_element(d.host<R>(), d.host<R>() + s.n())) : 0.0;
    const double range = model_.range(largest, largest);
    if (cutoff < range)  // two of the largest particles could feel the force and be missing from the list
      throw InputError("the neighbors.verlet cutoff " + format_value(ParamValue(cutoff)) +
                       " is shorter than the range " + format_value(ParamValue(range)) +
                       " of the force between the largest particles; raise neighbors.verlet's `cutoff` to at "
                       "least it (or shrink system.sigma)");
    if (!s.has_field(kForce)) s.add_particle_field(kForce, s.real(), s.dim());  // overdamped.integrate checks its shape
  }

  // The pair count is read back after the step (after_step), so the stages after this one queue
  // behind its kernel instead of waiting for the host.
  Outcome run(StepContext& ctx) override {
    pairs_.reset(std::array<int, 0>{}, ctx.stream);
    if (ctx.state.dim() == 2) launch<2>(ctx, loop2_);
    else launch<3>(ctx, loop3_);
    pairs_.start_read(ctx.stream);
    return Outcome::ok();
  }
  void after_step(StepContext& ctx) override { ctx.metrics.set_sum("pairs", pairs_.finish_read()[0]); }

  // In a decomposed team each owned particle sums its row, which names ghosts (sorted by global
  // id, as alone); `pairs` is then summed over the ranks.
  Scheduling scheduling() const override {
    Scheduling s;
    s.team = TeamWork::decomposed;
    s.reads_ghosts = true;
    return s;
  }

 private:
  template <int D>
  void launch(StepContext& ctx, ElementLoop<Kernel<D>> loop) {
    State& s = ctx.state;
    Kernel<D> f = model_.template kernel<R, D>();
    f.sys = {data<R>(s, fields::position),
             data<R>(s, fields::diameter),
             data<R>(s, kForce),
             {data<std::uint32_t>(s, kList), data<std::uint32_t>(s, kCount), list_capacity(s)},
             PeriodicBox<R>::make(s.box.L),
             pairs_.ptr(),
             s.has_field(fields::particle_id) ? data<std::uint32_t>(s, fields::particle_id) : nullptr};
    loop(s.n_owned(), f, ctx.stream);  // the rows of the owned particles (all, alone)
  }
  template <class T>
  T* data(State& s, const std::string& name) const {
    Field& f = s.field(name);
    return f.data<T>(where_);
  }

  Model model_;
  Where where_;
  Counters<1> pairs_;  // the `pairs` metric, on the stage's side
  ElementLoop<Kernel<2>> loop2_;
  ElementLoop<Kernel<3>> loop3_;
};

}  // namespace ff::neighbors
