#include "core/registry.h"
#include "plugins/phoretic/forces/cpu.h"
#ifdef FLIPFLOW_HAVE_CUDA
#include "plugins/phoretic/forces/cuda.cuh"
#endif

namespace ff::phoretic {

namespace {
template <class R>
std::unique_ptr<Stage> make(const ParamValues& v, Backend b) {
  auto p = ForcesParams::from(v);
#ifdef FLIPFLOW_HAVE_CUDA
  if (b == Backend::cuda) return std::make_unique<Forces<R>>(std::move(p), Where::device, cuda_forces_loops<R>());
#endif
  (void)b;
  return std::make_unique<Forces<R>>(std::move(p), Where::host, cpu_forces_loops<R>());
}

StageFactory factory(Backend b) {
  return [b](const ParamValues& v, const RunInfo& info) {
    return info.precision == Precision::f32 ? make<float>(v, b) : make<double>(v, b);
  };
}
}  // namespace

void register_forces(Registry& r) {
  r.declare({"phoretic.forces",
             "phoretic pair velocities v_i = Σ_k μ_i α_k f(r_ik) into `velocity` (long: r/r³ all pairs; short: "
             "r/r⁷ via Verlet list)",
             ForcesParams::schema(), {2, 3}, false});
  r.implement("phoretic.forces", Backend::cpu, factory(Backend::cpu));
#ifdef FLIPFLOW_HAVE_CUDA
  r.implement("phoretic.forces", Backend::cuda, factory(Backend::cuda));
#endif
}

}  // namespace ff::phoretic
