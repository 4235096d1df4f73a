// Drives stages alone on a hand-made State the way the scheduler would, without YAML or a
// Simulation, on either backend: per step acquire each stage's declared fields, call run() with a
// filled StepContext, then after_step() unless the stage asked for a rollback. Every stage test
// drives its stages through this header (the delaunay tests add their mesh helpers,
// stages/delaunay/test_support.h). Installed with flipflow (cmake/install.cmake), so the test of a
// model built outside this repository includes it by the same name, "support/stage_driver.h".
#pragma once
#include <catch2/catch.hpp>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/physics/rng.h"
#include "core/stage/registry.h"
#include "core/stage/stage.h"
#include "core/stage/state.h"
#include "core/stage/step_params.h"
#ifdef FLIPFLOW_HAVE_CUDA
#include <cuda_runtime.h>

#include "core/run/cuda/graph.h"
#endif

namespace ff::test {

// The stream every driven stage runs on: on CUDA one non-blocking stream for the whole test
// binary (the scheduler's streams are non-blocking too), shared so that stages driven one after
// another on a State, by one driver or several, are ordered as a step orders them; nullptr on
// the CPU. Never destroyed (it lives as long as the process).
inline CUstream_st* stage_stream(Backend b) {
#ifdef FLIPFLOW_HAVE_CUDA
  if (b == Backend::cuda) {
    static CUstream_st* const stream = [] {
      cudaStream_t s = nullptr;
      if (cudaStreamCreateWithFlags(&s, cudaStreamNonBlocking) != cudaSuccess)
        throw std::runtime_error("stage_driver.h: cannot create a CUDA stream");
      return s;
    }();
    return stream;
  }
#endif
  (void)b;
  return nullptr;
}

using ParamSettings = std::vector<std::pair<std::string, ParamValue>>;

// Stage `name` of `registry` made as the core makes it for a run of `dim` dimensions at
// precision p on backend b: its declared defaults, then `set`. Run it with StageDriver::run.
inline std::unique_ptr<Stage> make_stage(const Registry& registry, const std::string& name, Backend b,
                                         Precision p, int dim, const ParamSettings& set = {}) {
  ParamValues v = ParamValues::defaults(registry.get(name).decl.params);
  for (auto& kv : set) v.set(kv.first, kv.second);
  RunInfo info;
  info.dim = dim;
  info.precision = p;
  info.backend = b;
  info.stage_id = name;
  return registry.create(name, b, v, info);
}

// The core's side of steps on one backend: the records a StepContext points to (RunInfo,
// RunStats, Metrics), the step's StepParams and the stream. Drives the stage it was made with
// (step/run(State&, ...)) or any stage (run(Stage&, State&, ...)).
class StageDriver {
 public:
  // Drives stage `name` of `registry` with parameters `v` (`stage` owns it).
  StageDriver(const Registry& registry, const std::string& name, Backend b, Precision p, int dim,
              const ParamValues& v, std::uint64_t seed)
      : StageDriver(b, p, dim, seed) {
    info.stage_id = name;
    stage = registry.create(name, b, v, info);
  }
  // Drives stages made elsewhere (make_stage) through run(Stage&, State&, ...).
  StageDriver(Backend b, Precision p, int dim, std::uint64_t seed = 1) : stream_(stage_stream(b)) {
    info.dim = dim;
    info.precision = p;
    info.backend = b;
    info.seed = seed;
  }
  StageDriver(StageDriver&&) = default;
  // The work it enqueued ends before what it points to (StepParams, the stage) goes.
  ~StageDriver() {
#ifdef FLIPFLOW_HAVE_CUDA
    if (stream_) cudaStreamSynchronize(stream_);
#endif
  }

  // Step k (time k·dt, first attempt) of the driver's stage; it must not ask for a rollback.
  void step(State& s, std::uint64_t k, double dt) { REQUIRE_FALSE(run(s, k, dt).rollback); }
  Outcome run(State& s, std::uint64_t k, double dt) { return run(*stage, s, k, dt); }

  // Step k of `st` on `s`, returning its outcome; a throw from the stage propagates. ctx.params
  // points to the step's StepParams on the stage's side: a host block on the CPU, a device copy
  // on CUDA (as the core keeps one). RNG key: (seed, stage_id).
  Outcome run(Stage& st, State& s, std::uint64_t k = 0, double dt = 0.01) {
    for (auto& a : st.accesses()) s.field(a.field).acquire(a.where, a.mode, stream_);
    metrics.clear();
    params = StepParams{k, 0, dt, k * dt};
    StepContext ctx{s, info, stats, k, 0, dt, k * dt, info.backend, stream_,
                    make_rng_key(info.seed, info.stage_id.c_str()), metrics};
    ctx.params = &params;
#ifdef FLIPFLOW_HAVE_CUDA
    if (info.backend == Backend::cuda) {
      if (!device_params_) device_params_ = std::make_unique<DeviceStepParams>();
      device_params_->set(params, stream_);
      ctx.params = device_params_->device();
    }
#endif
    // As the core does for a step of this one stage (nothing can roll it back: no snapshot).
    const Outcome o = st.run(ctx);
    if (!o.rollback) st.after_step(ctx);
    return o;
  }

  // A metric the last run reported (a clear error when it reported none of that name).
  double metric(const std::string& name) const {
    const auto it = metrics.values().find(name);
    if (it == metrics.values().end()) throw std::out_of_range("the stage reported no metric '" + name + "'");
    return it->second;
  }
  CUstream_st* stream() const { return stream_; }

  RunInfo info;
  RunStats stats;
  Metrics metrics;
  StepParams params{};
  std::unique_ptr<Stage> stage;

 private:
  CUstream_st* stream_ = nullptr;
#ifdef FLIPFLOW_HAVE_CUDA
  std::unique_ptr<DeviceStepParams> device_params_;  // on first use (CUDA runs only)
#endif
};

}  // namespace ff::test
