#include "core/registry.h"
#include "plugins/abp/integrate/cpu.h"
#ifdef FLIPFLOW_HAVE_CUDA
#include "plugins/abp/integrate/cuda.cuh"
#endif

namespace ff::abp {

namespace {
template <class R>
std::unique_ptr<Stage> make(const ParamValues& v, const RunInfo& info, Backend b) {
  const auto p = IntegrateParams::from(v);
#ifdef FLIPFLOW_HAVE_CUDA
  if (b == Backend::cuda) return std::make_unique<Integrate<R>>(p, info.seed, Where::device, cuda_loops<R>());
#endif
  (void)b;
  return std::make_unique<Integrate<R>>(p, info.seed, Where::host, cpu_loops<R>());
}

StageFactory factory(Backend b) {
  return [b](const ParamValues& v, const RunInfo& info) {
    return info.precision == Precision::f32 ? make<float>(v, info, b) : make<double>(v, info, b);
  };
}
}  // namespace

void register_integrate(Registry& r) {
  r.declare({"abp.integrate",
             "active Brownian particles: x += v0 e(θ)Δt + sqrt(2DΔt)ξ, θ += sqrt(2D_rΔt)η (2D; unit vector in 3D)",
             IntegrateParams::schema(), {2, 3}, false});
  r.implement("abp.integrate", Backend::cpu, factory(Backend::cpu));
#ifdef FLIPFLOW_HAVE_CUDA
  r.implement("abp.integrate", Backend::cuda, factory(Backend::cuda));
#endif
}

}  // namespace ff::abp
