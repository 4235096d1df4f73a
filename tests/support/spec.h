// Build PipelineSpecs in tests without YAML.
#pragma once
#include <catch2/catch.hpp>

#include <map>
#include <string>
#include <vector>

#include "core/input/pipeline_spec.h"
#include "core/stage/registry.h"
#include "core/run/simulation.h"

namespace ff::test {

// Options for a Simulation that writes no files (tests drive it step by step).
inline RunOptions dry(Backend b = Backend::cpu) {
  RunOptions o;
  o.dry_run = true;
  o.backend = b;
  return o;
}

struct EntryOptions {
  std::string id;                          // default: the stage name
  std::vector<std::string> after;          // with after_given
  bool after_given = false;
  std::uint64_t every = 1;
};

inline StepEntry entry(const Registry& r, const std::string& stage, const std::map<std::string, ParamValue>& params = {},
                       EntryOptions o = {}) {
  StepEntry e;
  e.stage = stage;
  e.id = o.id.empty() ? stage : o.id;
  e.params = ParamValues::defaults(r.get(stage).decl.params);
  for (auto& kv : params) e.params.set(kv.first, kv.second);
  e.after = o.after;
  e.after_given = o.after_given;
  e.schedule.every = o.every;
  e.where = Location{"test", 1, 1};
  return e;
}

inline PipelineSpec spec(int dim, std::uint64_t n, double packing_fraction, std::uint64_t steps, double dt,
                         std::vector<StepEntry> step, std::uint64_t seed = 1, Precision p = Precision::f64) {
  PipelineSpec s;
  s.file = "test";
  s.system.dimensions = dim;
  s.system.N = n;
  s.system.packing_fraction = packing_fraction;
  s.run.steps = steps;
  s.run.dt = dt;
  s.run.dt_min = dt / 1024;
  s.run.seed = seed;
  s.run.precision = p;
  s.step = std::move(step);
  return s;
}

// A metric the last step reported ("stage_id/name"); the test fails if there is none.
inline double metric(const Simulation& sim, const std::string& key) {
  const auto& m = sim.stats().metrics;
  const auto it = m.find(key);
  REQUIRE(it != m.end());
  return it->second;
}

// The slot of stage `id` (its last run's metrics, whether it ran); the test fails if there is none.
inline const StageSlot& slot(const Simulation& sim, const std::string& id) {
  for (const StageSlot& s : sim.slots())
    if (s.info.stage_id == id) return s;
  FAIL("no stage " << id);
  return sim.slots().front();
}

}  // namespace ff::test
