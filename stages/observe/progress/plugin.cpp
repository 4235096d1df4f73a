#include "core/registry.h"
#include "stages/observe/progress/stage.h"

namespace ff::observe {

void register_progress(Registry& r) {
  r.declare({"observe.progress", "progress on the terminal (steps/s, ETA), a line every `interval` s in logs",
             ProgressParams::schema(), {2, 3}, true});
  const StageFactory make = [](const ParamValues& v, const RunInfo& info) -> std::unique_ptr<Stage> {
    return std::make_unique<Progress>(ProgressParams::from(v), info);
  };
  r.implement("observe.progress", Backend::cpu, make);
#ifdef FLIPFLOW_HAVE_CUDA
  r.implement("observe.progress", Backend::cuda, make);  // host-only: reads no fields
#endif
}

}  // namespace ff::observe
