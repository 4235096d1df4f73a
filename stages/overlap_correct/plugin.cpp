// The overlap_correct stage library: hard-core exclusion on the Delaunay triangulation.
#include "core/plugin_api.h"
#include "core/registry.h"
#include "stages/overlap_correct/cpu.h"
#ifdef FLIPFLOW_HAVE_CUDA
#include "stages/overlap_correct/cuda.cuh"
#endif

namespace ff::overlap {

namespace {
template <class R>
std::unique_ptr<Stage> make(const Params& p, Backend b) {
#ifdef FLIPFLOW_HAVE_CUDA
  if (b == Backend::cuda) return std::make_unique<OverlapCorrect<R>>(p, Where::device, cuda_ops<R>());
#endif
  (void)b;
  return std::make_unique<OverlapCorrect<R>>(p, Where::host, cpu_ops<R>());
}

StageFactory factory(Backend b) {
  return [b](const ParamValues& v, const RunInfo& info) {
    const auto p = Params::from(v);
    return info.precision == Precision::f32 ? make<float>(p, b) : make<double>(p, b);
  };
}

void register_overlap_correct(Registry& r) {
  r.declare({"overlap_correct",
             "push overlapping pairs apart along Delaunay edges (reflect or contact), iterated until none overlap",
             Params::schema(), {2}, false});
  r.implement("overlap_correct", Backend::cpu, factory(Backend::cpu));
#ifdef FLIPFLOW_HAVE_CUDA
  r.implement("overlap_correct", Backend::cuda, factory(Backend::cuda));
#endif
}
}  // namespace

}  // namespace ff::overlap

static void register_stage_overlap_correct(ff::Registry& r) { ff::overlap::register_overlap_correct(r); }

FLIPFLOW_PLUGIN(register_stage_overlap_correct)
