#include "core/builtin_stages.h"

namespace ff {

namespace {
class Noop final : public Stage {
 public:
  explicit Noop(std::vector<Access> acc) : accesses_(std::move(acc)) {}
  std::vector<Access> accesses() const override { return accesses_; }
  Outcome run(StepContext&) override { return Outcome::ok(); }

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
