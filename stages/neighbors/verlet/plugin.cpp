#include "core/registry.h"
#include "stages/neighbors/verlet/cpu.h"
#ifdef FLIPFLOW_HAVE_CUDA
#include "stages/neighbors/verlet/cuda.cuh"
#endif

namespace ff::neighbors {

namespace {
template <class R>
std::unique_ptr<Stage> make(const ParamValues& v, Backend b) {
  const auto p = VerletParams::from(v);
#ifdef FLIPFLOW_HAVE_CUDA
  if (b == Backend::cuda) return std::make_unique<Verlet<R>>(p, Where::device, cuda_loops<R>());
#endif
  (void)b;
  return std::make_unique<Verlet<R>>(p, Where::host, cpu_loops<R>());
}

StageFactory factory(Backend b) {
  return [b](const ParamValues& v, const RunInfo& info) {
    return info.precision == Precision::f32 ? make<float>(v, b) : make<double>(v, b);
  };
}
}  // namespace

void register_verlet(Registry& r) {
  r.declare({"neighbors.verlet",
             "cell list + Verlet list (fields neighbors.list/count), rebuilt when a particle moved > skin/2",
             VerletParams::schema(), {2, 3}, false});
  r.implement("neighbors.verlet", Backend::cpu, factory(Backend::cpu));
#ifdef FLIPFLOW_HAVE_CUDA
  r.implement("neighbors.verlet", Backend::cuda, factory(Backend::cuda));
#endif
}

}  // namespace ff::neighbors
