// delaunay.build: the Delaunay triangulation of the current positions, from scratch, on the
// host with CGAL (build.cpp / cgal.cpp). It runs on every step it is scheduled for (`every: k`
// for periodic rebuilds). A pipeline without it is fine: the first topology stage that runs
// builds the triangulation once (common/host.h, ensure_topology).
#pragma once
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/delaunay/build/build.h"
#include "stages/delaunay/common/host.h"

namespace ff::delaunay {

class Build final : public Stage {
 public:
  // Host work on either backend (the core copies the fields it declares).
  static StageDecl declaration() {
    return {"delaunay.build",
            "Delaunay triangulation of the current positions from scratch (host, CGAL); schedule rebuilds "
            "with every: k",
            {},
            {2},
            false};
  }
  Build(const ParamValues&, const RunInfo&) {}

  // The topology and position_prev are on-demand writes, announced in run() (will_build): with
  // `every: k` the rollback snapshot copies them only on the steps this stage runs, and
  // delaunay.detect_inversion sees that the triangulation was built in its own step (its
  // rollback path then judges the moves since this build, not since the step's start).
  // Read-write: the snapshot's copy must be of current contents (a CUDA run's device side).
  std::vector<Access> accesses() const override {
    return {{ff::fields::position, Where::host, Mode::read},
            Access::on_demand_write(fields::halfedge, Where::host),
            Access::on_demand_write(fields::opposite, Where::host),
            Access::on_demand_write(fields::vertex_edge, Where::host),
            Access::on_demand_write(fields::position_prev, Where::host),
            {fields::status, Where::host, Mode::readwrite}};
  }
  void configure(State& s) override { add_topology_fields(s, "delaunay.build"); }
  Outcome run(StepContext& ctx) override {
    will_build(ctx);
    method_ = build_topology(ctx.state, ctx.stream);
    ctx.metrics.set("rebuilds", 1);
    return Outcome::ok();
  }
  // How the last build was done (CGAL periodic 1-sheet, or the checked 3x3-copies path).
  const std::string& method() const { return method_; }

 private:
  std::string method_;
};

}  // namespace ff::delaunay

FLIPFLOW_HOST_STAGE(ff::delaunay::Build)
