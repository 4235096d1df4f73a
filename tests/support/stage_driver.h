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

#include "core/registry.h"
#include "core/rng.h"
#include "core/stage.h"
#include "core/state.h"
#include "core/step_params.h"

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
  // ctx.params points to a host StepParams on the CPU. On CUDA it stays null: the core gives
  // graph-capturable stages a device copy (DeviceStepParams), which this driver does not set up;
  // none of its users drives a stage that reads params (brownian.integrate does).
  void step(State& s, std::uint64_t k, double dt) {
    for (auto& a : stage->accesses()) s.field(a.field).acquire(a.where, a.mode, nullptr);
    metrics.clear();
    params = StepParams{k, 0, dt, k * dt};
    StepContext ctx{s, info, stats, k, 0, dt, k * dt, info.backend, nullptr,
                    make_rng_key(info.seed, info.stage_id.c_str()), metrics};
    ctx.params = info.backend == Backend::cpu ? &params : nullptr;
    REQUIRE_FALSE(stage->run(ctx).rollback);
  }

  double metric(const char* name) const { return metrics.values().at(name); }
};

}  // namespace ff::test
