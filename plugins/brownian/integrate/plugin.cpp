#include "core/registry.h"
#include "plugins/brownian/integrate/cpu.h"
#ifdef FLIPFLOW_HAVE_CUDA
#include "plugins/brownian/integrate/cuda.cuh"
#endif

namespace ff::brownian {

namespace {
template <class R>
std::unique_ptr<Stage> make(const ParamValues& v, Backend b) {
  const auto p = IntegrateParams::from(v);
#ifdef FLIPFLOW_HAVE_CUDA
  if (b == Backend::cuda) return std::make_unique<Integrate<R>>(p, Where::device, cuda_loops<R>());
#endif
  (void)b;
  return std::make_unique<Integrate<R>>(p, Where::host, cpu_loops<R>());
}

StageFactory factory(Backend b) {
  return [b](const ParamValues& v, const RunInfo& info) {
    return info.precision == Precision::f32 ? make<float>(v, b) : make<double>(v, b);
  };
}
}  // namespace

void register_integrate(Registry& r) {
  r.declare({"brownian.integrate", "free overdamped Brownian motion, x += sqrt(2DΔt)·ξ", IntegrateParams::schema(),
             {2, 3}, false});
  r.implement("brownian.integrate", Backend::cpu, factory(Backend::cpu));
#ifdef FLIPFLOW_HAVE_CUDA
  r.implement("brownian.integrate", Backend::cuda, factory(Backend::cuda));
#endif
}

}  // namespace ff::brownian
