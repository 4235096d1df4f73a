#include "core/registry.h"
#include "stages/observe/h5md/stage.h"

namespace ff::observe {

void register_h5md(Registry& r) {
  r.declare({"observe.h5md", "write fields and observables to an H5MD trajectory (written by a background thread)",
             H5mdParams::schema(), {2, 3}, true});
  const StageFactory make = [](const ParamValues& v, const RunInfo& info) -> std::unique_ptr<Stage> {
    return std::make_unique<H5mdObserver>(H5mdParams::from(v), info);
  };
  r.implement("observe.h5md", Backend::cpu, make);
#ifdef FLIPFLOW_HAVE_CUDA
  r.implement("observe.h5md", Backend::cuda, make);  // host accesses: the core brings fields to the host
#endif
}

}  // namespace ff::observe
