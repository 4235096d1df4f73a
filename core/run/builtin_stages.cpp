#include "core/run/builtin_stages.h"

#ifdef FLIPFLOW_HAVE_CUDA
#include "core/run/cuda/noop.cuh"
#endif

namespace ff {

namespace {
class Noop final : public Stage {
 public:
  explicit Noop(std::vector<Access> acc) : accesses_(std::move(acc)) {}
  std::vector<Access> accesses() const override { return accesses_; }
  // On CUDA a no-op stage still launches one (empty) kernel, as every real stage does: the
  // overhead measured is scheduling plus one launch.
  Outcome run(StepContext& ctx) override {
#ifdef FLIPFLOW_HAVE_CUDA
    if (ctx.backend == Backend::cuda) launch_empty_kernel(ctx.stream);
#else
    (void)ctx;
#endif
    return Outcome::ok();
  }
  Scheduling scheduling() const override { return {false, false, /*graph_capturable=*/true, /*reads_step_params=*/true}; }

 private:
  std::vector<Access> accesses_;
};

StageFactory noop_factory(Where where) {
  return [where](const ParamValues& v, const RunInfo&) {
    std::vector<Access> acc;
    for (auto& f : v.strings("reads")) acc.push_back({f, where, Mode::read});
    return std::make_unique<Noop>(std::move(acc));
  };
}
}  // namespace

void register_builtin_stages(Registry& r) {
  r.set_current_plugin("(built in)");
  r.declare({"core.noop",
             "does nothing; measures the framework's per-stage overhead",
             {ParamSpec::strings("reads", {}, "fields to declare as read (exercises the access bookkeeping)")},
             {2, 3},
             false});
  r.implement("core.noop", Backend::cpu, noop_factory(Where::host));
  r.implement("core.noop", Backend::cuda, noop_factory(Where::device));
}

}  // namespace ff
