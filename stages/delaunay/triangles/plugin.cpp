#include "core/registry.h"
#include "stages/delaunay/triangles/stage.h"

namespace ff::delaunay {

void register_triangles(Registry& r) {
  r.declare({"delaunay.triangles",
             "observer: the maintained triangles into the field delaunay.triangles (i32 x 3, 2N, CCW) for "
             "observe.h5md's /connectivity; list it before observe.h5md with the same every",
             {},
             {2},
             true});
  auto make = [](const ParamValues&, const RunInfo&) -> std::unique_ptr<Stage> {
    return std::make_unique<Triangles>();
  };
  r.implement("delaunay.triangles", Backend::cpu, make);
#ifdef FLIPFLOW_HAVE_CUDA
  r.implement("delaunay.triangles", Backend::cuda, make);  // host-only: the core copies the half-edges
#endif
}

}  // namespace ff::delaunay
