#include "core/registry.h"
#include "stages/observe/msd/stage.h"

namespace ff::observe {

void register_msd(Registry& r) {
  r.declare({"observe.msd", "mean-squared displacement of unwrapped positions since the first run (metric `msd`)",
             {}, {2, 3}, true});
  const StageFactory make = [](const ParamValues&, const RunInfo&) -> std::unique_ptr<Stage> {
    return std::make_unique<Msd>();
  };
  r.implement("observe.msd", Backend::cpu, make);
#ifdef FLIPFLOW_HAVE_CUDA
  r.implement("observe.msd", Backend::cuda, make);  // host accesses: the core brings fields to the host
#endif
}

}  // namespace ff::observe
