#include "core/registry.h"
#include "stages/delaunay/detect_inversion/cpu.h"
#ifdef FLIPFLOW_HAVE_CUDA
#include "stages/delaunay/detect_inversion/cuda.cuh"
#endif

namespace ff::delaunay {

namespace {
template <class R>
std::unique_ptr<Stage> make(Backend b) {
#ifdef FLIPFLOW_HAVE_CUDA
  if (b == Backend::cuda) return std::make_unique<DetectInversion<R>>(Where::device, detect_cuda_ops<R>());
#endif
  (void)b;
  return std::make_unique<DetectInversion<R>>(Where::host, detect_cpu_ops<R>());
}

StageFactory factory(Backend b) {
  return [b](const ParamValues&, const RunInfo& info) {
    return info.precision == Precision::f32 ? make<float>(b) : make<double>(b);
  };
}
}  // namespace

void register_detect_inversion(Registry& r) {
  r.declare({"delaunay.detect_inversion",
             "find inverted triangles after integration; mark single-flip repairs or request a rollback",
             {},
             {2},
             false});
  r.implement("delaunay.detect_inversion", Backend::cpu, factory(Backend::cpu));
#ifdef FLIPFLOW_HAVE_CUDA
  r.implement("delaunay.detect_inversion", Backend::cuda, factory(Backend::cuda));
#endif
}

}  // namespace ff::delaunay
