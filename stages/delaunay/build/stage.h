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

  std::vector<Access> accesses() const override {
    return {{ff::fields::position, Where::host, Mode::read},
            {fields::halfedge, Where::host, Mode::write},
            {fields::opposite, Where::host, Mode::write},
            {fields::vertex_edge, Where::host, Mode::write},
            {fields::position_prev, Where::host, Mode::write},
            {fields::status, Where::host, Mode::readwrite}};
  }
  void configure(State& s) override { add_topology_fields(s, "delaunay.build"); }
  Outcome run(StepContext& ctx) override {
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
