#include "core/registry.h"
#include "stages/delaunay/flip/cpu.h"
#ifdef FLIPFLOW_HAVE_CUDA
#include "stages/delaunay/flip/cuda.cuh"
#endif

namespace ff::delaunay {

namespace {
template <class R>
std::unique_ptr<Stage> make(const FlipParams& p, Backend b) {
#ifdef FLIPFLOW_HAVE_CUDA
  if (b == Backend::cuda) return std::make_unique<Flip<R>>(p, Where::device, flip_cuda_ops<R>());
#endif
  (void)b;
  return std::make_unique<Flip<R>>(p, Where::host, flip_cpu_ops<R>());
}

StageFactory factory(Backend b) {
  return [b](const ParamValues& v, const RunInfo& info) {
    const auto p = FlipParams::from(v);
    return info.precision == Precision::f32 ? make<float>(p, b) : make<double>(p, b);
  };
}
}  // namespace

void register_flip(Registry& r) {
  r.declare({"delaunay.flip", "repair the inverted triangles marked by delaunay.detect_inversion by parallel edge flips",
             FlipParams::schema(), {2}, false});
  r.implement("delaunay.flip", Backend::cpu, factory(Backend::cpu));
#ifdef FLIPFLOW_HAVE_CUDA
  r.implement("delaunay.flip", Backend::cuda, factory(Backend::cuda));
#endif
}

}  // namespace ff::delaunay
