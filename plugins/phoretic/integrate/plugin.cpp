#include "core/registry.h"
#include "plugins/phoretic/integrate/cpu.h"
#ifdef FLIPFLOW_HAVE_CUDA
#include "plugins/phoretic/integrate/cuda.cuh"
#endif

namespace ff::phoretic {

namespace {
template <class R>
std::unique_ptr<Stage> make(const ParamValues& v, Backend b) {
  const auto p = IntegrateParams::from(v);
#ifdef FLIPFLOW_HAVE_CUDA
  if (b == Backend::cuda) return std::make_unique<Integrate<R>>(p, Where::device, cuda_integrate_loops<R>());
#endif
  (void)b;
  return std::make_unique<Integrate<R>>(p, Where::host, cpu_integrate_loops<R>());
}

StageFactory factory(Backend b) {
  return [b](const ParamValues& v, const RunInfo& info) {
    return info.precision == Precision::f32 ? make<float>(v, b) : make<double>(v, b);
  };
}
}  // namespace

void register_integrate(Registry& r) {
  r.declare({"phoretic.integrate", "Euler–Maruyama: x += velocity·Δt + sqrt(2DΔt)·ξ (velocity from phoretic.forces)",
             IntegrateParams::schema(), {2, 3}, false});
  r.implement("phoretic.integrate", Backend::cpu, factory(Backend::cpu));
#ifdef FLIPFLOW_HAVE_CUDA
  r.implement("phoretic.integrate", Backend::cuda, factory(Backend::cuda));
#endif
}

}  // namespace ff::phoretic
