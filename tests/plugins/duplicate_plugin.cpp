// Declares a stage the testing plugin also declares: loading both must fail, naming both.
#include "core/stage/plugin_api.h"
namespace {
class Nothing final : public ff::Stage {
 public:
  std::vector<ff::Access> accesses() const override { return {}; }
  ff::Outcome run(ff::StepContext&) override { return ff::Outcome::ok(); }
};
void register_duplicate(ff::Registry& r) {
  r.declare({"testing.record", "a second testing.record", {}, {2, 3}, false});
  r.implement("testing.record", ff::Backend::cpu,
              [](const ff::ParamValues&, const ff::RunInfo&) { return std::make_unique<Nothing>(); });
}
}  // namespace
FLIPFLOW_PLUGIN(register_duplicate)
