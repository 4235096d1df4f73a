#include "core/registry.h"
#include "stages/delaunay/lawson/cpu.h"
#ifdef FLIPFLOW_HAVE_CUDA
#include "stages/delaunay/lawson/cuda.cuh"
#endif

namespace ff::delaunay {

namespace {
template <class R>
std::unique_ptr<Stage> make(const LawsonParams& p, Backend b) {
#ifdef FLIPFLOW_HAVE_CUDA
  if (b == Backend::cuda) return std::make_unique<Lawson<R>>(p, Where::device, lawson_cuda_ops<R>());
#endif
  (void)b;
  return std::make_unique<Lawson<R>>(p, Where::host, lawson_cpu_ops<R>());
}

StageFactory factory(Backend b) {
  return [b](const ParamValues& v, const RunInfo& info) {
    const auto p = LawsonParams::from(v);
    return info.precision == Precision::f32 ? make<float>(p, b) : make<double>(p, b);
  };
}
}  // namespace

void register_lawson(Registry& r) {
  r.declare({"delaunay.lawson", "parallel Lawson edge flips until the triangulation is Delaunay",
             LawsonParams::schema(), {2}, false});
  r.implement("delaunay.lawson", Backend::cpu, factory(Backend::cpu));
#ifdef FLIPFLOW_HAVE_CUDA
  r.implement("delaunay.lawson", Backend::cuda, factory(Backend::cuda));
#endif
}

}  // namespace ff::delaunay
