// Drives one stage on a hand-made State the way the scheduler would, without YAML or a
// Simulation: create it from a registry, then per step acquire its declared fields and call
// run() with a filled StepContext. Shared by the single-stage tests (abp, phoretic, neighbors),
// which each had their own copy. (The delaunay tests keep their Runner in
// test_delaunay_support.h: it owns a CUDA stream and drives several stages on one State.)
#pragma once
#include <catch2/catch.hpp>
#include <cstdint>
#include <memory>
#include <string>

#include "core/stage/registry.h"
#include "core/physics/rng.h"
#include "core/stage/stage.h"
#include "core/stage/state.h"
#include "core/stage/step_params.h"
#ifdef FLIPFLOW_HAVE_CUDA
#include "core/run/cuda/graph.h"
#endif

namespace ff::test {

struct StageDriver {
  RunInfo info;
  RunStats stats;
  Metrics metrics;
  StepParams params{};
  std::unique_ptr<Stage> stage;

  StageDriver(const Registry& registry, const std::string& name, Backend b, Precision p, int dim,
              const ParamValues& v, std::uint64_t seed) {
    info.dim = dim;
    info.precision = p;
    info.backend = b;
    info.seed = seed;
    info.stage_id = name;
    stage = registry.create(name, b, v, info);
  }

  // Step k (time k·dt, first attempt, default stream); the stage must not ask for a rollback.
  void step(State& s, std::uint64_t k, double dt) { REQUIRE_FALSE(run(s, k, dt).rollback); }

  // The same, returning the stage's outcome. ctx.params points to the step's StepParams on the
  // stage's side: a host block on the CPU, a device copy on CUDA (as the core keeps one).
  Outcome run(State& s, std::uint64_t k, double dt) {
    for (auto& a : stage->accesses()) s.field(a.field).acquire(a.where, a.mode, nullptr);
    metrics.clear();
    params = StepParams{k, 0, dt, k * dt};
    StepContext ctx{s, info, stats, k, 0, dt, k * dt, info.backend, nullptr,
                    make_rng_key(info.seed, info.stage_id.c_str()), metrics};
    ctx.params = &params;
#ifdef FLIPFLOW_HAVE_CUDA
    if (info.backend == Backend::cuda) {
      if (!device_params) device_params = std::make_unique<DeviceStepParams>();
      device_params->set(params, nullptr);
      ctx.params = device_params->device();
    }
#endif
    return stage->run(ctx);
  }
#ifdef FLIPFLOW_HAVE_CUDA
  std::unique_ptr<DeviceStepParams> device_params;  // on first use (CUDA runs only)
#endif

  double metric(const char* name) const { return metrics.values().at(name); }
};

}  // namespace ff::test
