#include "core/registry.h"
#include "stages/observe/gr/stage.h"

namespace ff::observe {

void register_gr(Registry& r) {
  r.declare({"observe.gr",
             "pair distribution g(r) accumulated over calls (cell list); metrics g_contact = g(σ⁺) and the "
             "hard-core pressure Z; writes gr.csv",
             GrParams::schema(), {2, 3}, true});
  const StageFactory make = [](const ParamValues& v, const RunInfo& info) -> std::unique_ptr<Stage> {
    return std::make_unique<Gr>(GrParams::from(v), info);
  };
  r.implement("observe.gr", Backend::cpu, make);
#ifdef FLIPFLOW_HAVE_CUDA
  r.implement("observe.gr", Backend::cuda, make);  // host accesses: the core brings fields to the host
#endif
}

}  // namespace ff::observe
