#include "core/registry.h"
#include "stages/delaunay/check/stage.h"

namespace ff::delaunay {

void register_check(Registry& r) {
  r.declare({"delaunay.check",
             "observer: compare the maintained triangulation with CGAL's Delaunay triangulation of the current "
             "positions (co-circular ties tolerated); RunError naming the step and edges on a mismatch",
             CheckParams::schema(),
             {2},
             true});
  // Host-only work: the CUDA backend runs the same stage, the core copies the fields to the host.
  auto make = [](const ParamValues& v, const RunInfo&) -> std::unique_ptr<Stage> {
    return std::make_unique<Check>(CheckParams::from(v));
  };
  r.implement("delaunay.check", Backend::cpu, make);
#ifdef FLIPFLOW_HAVE_CUDA
  r.implement("delaunay.check", Backend::cuda, make);
#endif
}

}  // namespace ff::delaunay
