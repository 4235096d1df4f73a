// delaunay.flip: repair the inverted triangles that delaunay.detect_inversion marked, by edge
// flips (Carter et al. 2017, figs. 5–6), in parallel without conflicts (common/flip.h). Each
// round flips the marked edges that win their triangles, then re-detects; a flip turns one
// inverted triangle into two positive ones and touches nothing else, so the number of inverted
// triangles drops every round. Whatever cannot be repaired this way requests a rollback.
#pragma once
#include <array>

#include "core/base/error.h"
#include "core/backend/exec.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/delaunay/common/host.h"
#include "stages/delaunay/flip/kernel.h"

namespace ff::delaunay {

struct FlipParams {
  std::int64_t max_rounds = 64;

  template <class P>
  void describe(P& p) {
    p(max_rounds, "max_rounds", "repair rounds before the step is rolled back").at_least(1);
  }
};

template <class R>
struct FlipLoops {
  ElementLoop<DecideFlips> decide;
  ElementLoop<ApplyFlips> apply;
  ElementLoop<MarkInversions<R>> mark;
};

// The plain element loops of the backend object (CpuExec or CudaExec) this stage.h is compiled
// for (core/stage/stage_registration.h).
template <class R, class Exec>
FlipLoops<R> flip_loops(Exec) {
  return {&Exec::template for_each<DecideFlips>, &Exec::template for_each<ApplyFlips>,
          &Exec::template for_each<MarkInversions<R>>};
}

template <class R>
class Flip final : public Stage {
 public:
  static StageDecl declaration() {
    return {"delaunay.flip",
            "repair the inverted triangles marked by delaunay.detect_inversion by parallel edge flips",
            schema_of<FlipParams>(),
            {2},
            false};
  }

  template <class Exec>
  Flip(const ParamValues& v, const RunInfo&, Exec exec)
      : p_(params_from<FlipParams>(v)),
        where_(Exec::where),
        loops_(flip_loops<R>(exec)),
        mem_(exec.memory()),
        counters_(exec),
        go_(exec) {}

  std::vector<Access> accesses() const override {
    return {{ff::fields::position, where_, Mode::read},
            Access::on_demand_write(fields::halfedge, where_),
            Access::on_demand_write(fields::opposite, where_),
            Access::on_demand_write(fields::vertex_edge, where_),
            Access::step_local_write(fields::flip_mark, where_, Mode::readwrite),
            {fields::status, Where::host, Mode::readwrite}};
  }
  void configure(State& s) override { add_topology_fields(s, "delaunay.flip"); }
  // Requests come from run(), after reading the counters.
  Scheduling scheduling() const override { return {true, false, false, false}; }

  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    ensure_topology(ctx, accesses());
    ctx.metrics.set("flips", 0);
    ctx.metrics.set("flip_rounds", 0);
    if (status(s)[kPending] == 0) return Outcome::ok();  // detect_inversion found nothing to repair
    will_flip(ctx);  // the topology is in the rollback snapshot only on steps that flip

    const Mesh m = mesh_view(s, where_);
    const Points<R> pts = points_view<R>(s, ff::fields::position, where_);
    std::uint8_t* mark = s.field(fields::flip_mark).data<std::uint8_t>(ctx);
    const std::size_t E = edge_count(s.n());
    std::uint8_t* go = go_.get(E);
    unsigned* c = counters_.ptr();

    unsigned flips = 0;
    std::int64_t rounds = 0;
    std::array<unsigned, kInversionCounters> h{};
    do {
      counters_.reset(kMinSlots, st);
      loops_.decide(E, DecideFlips{m, mark, go, c, kRepairFlips}, st);
      loops_.apply(E, ApplyFlips{m, go}, st);
      loops_.mark(E, MarkInversions<R>{m, pts, nullptr, mark, c}, st);
      h = counters_.read(st);
      flips += h[kRepairFlips];
      ++rounds;
      throw_if_too_long(s, where_, mem_, h[kTooLong], h[kTooLongAt], st, "delaunay.flip");
    } while (h[kMarked] && rounds < p_.max_rounds);
    status(s)[kPending] = 0;
    if (flips) status(s)[kCandidates] = 0;  // quads changed: Lawson tests every edge
    ctx.metrics.set("flips", flips);
    ctx.metrics.set("flip_rounds", double(rounds));
    if (h[kInverted])
      return Outcome::request_rollback("delaunay.flip: " + std::to_string(h[kInverted]) +
                                       " inverted triangle(s) remain after " + std::to_string(flips) + " repair flip(s) in " +
                                       std::to_string(rounds) + " round(s); the step is retried with a smaller time step");
    return Outcome::ok();
  }

 private:
  static constexpr std::array<int, 4> kMinSlots{kThroughAt, kTwiceAt, kUnrepairableAt, kTooLongAt};
  FlipParams p_;
  Where where_;
  FlipLoops<R> loops_;
  const MemoryOps& mem_;
  Counters<kInversionCounters> counters_;
  Scratch<std::uint8_t> go_;
};

}  // namespace ff::delaunay

FLIPFLOW_STAGE(ff::delaunay::Flip)
