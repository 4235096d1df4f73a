#include "core/registry.h"
#include "stages/delaunay/sort/stage.h"

namespace ff::delaunay {

void register_sort(Registry& r) {
  r.declare({"delaunay.sort",
             "renumber the particles along a Hilbert curve once, at configure time (every per-particle field "
             "permuted alike), for memory locality; list it first",
             {},
             {2},
             false});
  auto make = [](const ParamValues&, const RunInfo&) -> std::unique_ptr<Stage> { return std::make_unique<Sort>(); };
  r.implement("delaunay.sort", Backend::cpu, make);
#ifdef FLIPFLOW_HAVE_CUDA
  r.implement("delaunay.sort", Backend::cuda, make);  // host work at configure time; run() enqueues nothing
#endif
}

}  // namespace ff::delaunay
