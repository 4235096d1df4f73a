// Rollback stress: pipelines/abp.yaml (N = 4096, φ = 0.4) with strong drives and large steps,
// where the first steps need rollbacks and the overlap correction leaves triangulations that no
// single flip repairs. Every run completes (issue 22: runs with v0 = 100 used to stop at step 1
// whatever Δt). Where Δt may not shrink enough (dt_min), the run stops and says how far the
// particles it names moved.
#include <catch2/catch.hpp>
#include <string>

#include "core/base/error.h"
#include "core/input/pipeline_loader.h"
#include "core/run/simulation.h"
#include "support/backends.h"
#include "support/cli.h"
#include "support/pipeline.h"
#include "support/spec.h"
#include "support/test_plugins.h"

using namespace ff;

namespace {
using Loaded = test::LoadedPipeline;
// abp.yaml without observers; without delaunay.sort when !sorted.
Loaded abp(const std::vector<std::string>& overrides, bool sorted) {
  Loaded l = test::load_compute_steps(test::repo_file("pipelines/abp.yaml").string(), overrides);
  std::vector<StepEntry> kept;
  for (auto& e : l.spec.step)
    if (sorted || e.stage != "delaunay.sort") kept.push_back(e);
  l.spec.step = kept;
  return l;
}
std::string str(double x) {
  std::ostringstream os;
  os << x;
  return os.str();
}
}  // namespace

TEST_CASE("rollback stress: ABP with v0 up to 300 and Δt up to 0.02 completes", "[rollback][stress]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const bool sorted = GENERATE(true, false);
  std::uint64_t rollbacks = 0, runs = 0;
  for (double v0 : {10.0, 30.0, 100.0, 300.0})
    for (double dt : {0.005, 0.01, 0.02})
      for (int seed : {42, 43, 44}) {
        INFO("v0 = " << v0 << ", dt = " << dt << ", seed = " << seed << ", delaunay.sort " << (sorted ? "on" : "off")
                     << ", " << to_string(b));
        Loaded l = abp({"step.abp.integrate.v0=" + str(v0), "run.dt=" + str(dt), "run.seed=" + std::to_string(seed),
                        "run.steps=100"},
                       sorted);
        Simulation sim(l.spec, *l.registry, test::dry(b));
        for (std::uint64_t k = 0; k < l.spec.run.steps; ++k) REQUIRE_NOTHROW(sim.advance());
        rollbacks += sim.stats().rollbacks;
        ++runs;
      }
  INFO(runs << " runs, " << rollbacks << " rollbacks");
  CHECK(runs == 36);
  CHECK(rollbacks > 36);  // the drives are strong enough to need them
}

TEST_CASE("rollback stress: below dt_min the run stops naming what moved how far", "[rollback][stress]") {
  const Backend b = GENERATE(from_range(test::backends()));
  // 300 σ/τ for 0.02 τ: 6 diameters a step, and Δt may halve once only.
  Loaded l = abp({"step.abp.integrate.v0=300", "run.dt=0.02", "run.dt_min=0.01", "run.steps=5"}, true);
  Simulation sim(l.spec, *l.registry, test::dry(b));
  try {
    for (int k = 0; k < 5; ++k) sim.advance();
    FAIL("the run should stop below dt_min");
  } catch (const RunError& e) {
    const std::string m = e.what();
    INFO(m);
    CHECK(m.find("delaunay.detect_inversion") != std::string::npos);
    CHECK(m.find("they moved by") != std::string::npos);
    CHECK(m.find("(Δt = 0.01)") != std::string::npos);
    CHECK(m.find("dt_min") != std::string::npos);
  }
}
