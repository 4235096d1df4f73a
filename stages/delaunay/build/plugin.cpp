#include "core/registry.h"
#include "stages/delaunay/build/stage.h"

namespace ff::delaunay {

void register_build(Registry& r) {
  r.declare({"delaunay.build",
             "Delaunay triangulation of the current positions from scratch (host, CGAL); schedule rebuilds with every: k",
             {},
             {2},
             false});
  // Host-only work: the CUDA backend runs the same stage, the core moves positions and topology.
  auto make = [](const ParamValues&, const RunInfo&) -> std::unique_ptr<Stage> { return std::make_unique<Build>(); };
  r.implement("delaunay.build", Backend::cpu, make);
#ifdef FLIPFLOW_HAVE_CUDA
  r.implement("delaunay.build", Backend::cuda, make);
#endif
}

}  // namespace ff::delaunay
