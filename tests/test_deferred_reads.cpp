// Reads left past the step (StepContext::may_defer_past_step): a stage may leave its result to
// its next run() or to Stage::settle_pending, and the core has it settled wherever the step is
// looked at: Simulation::stats() and synchronize(), the observers' steps, the end of the run. On
// CUDA overlap_correct does this (test_cpu_cuda_bits compares the bits both ways); here the core's
// side with tests/plugins/testing_plugin.cpp's testing.defer, on the CPU.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/run/simulation.h"
#include "support/spec.h"
#include "support/test_plugins.h"

using namespace ff;
using Catch::Matchers::Contains;
using ff::test::dry;
using ff::test::entry;
using ff::test::slot;
using ff::test::metric;

TEST_CASE("a result left past the step is the step's wherever it is read", "[deferred]") {
  auto r = test::registry_with({}, {"testing"});
  const auto spec = test::spec(2, 64, 0.2, 6, 0.01, {entry(*r, "testing.defer")});

  SECTION("stats() after every step: each step's own result") {
    Simulation sim(spec, *r, dry());
    for (std::uint64_t k = 0; k < 6; ++k) {
      sim.advance();
      CHECK(slot(sim, "testing.defer").metrics.values().at("deferred") == 1.0);  // the stage's own record
      CHECK(metric(sim, "testing.defer/step") == double(k));
    }
    CHECK(metric(sim, "testing.defer/settled_in_run") == 0);  // stats() settled each one first
  }
  SECTION("read only at the end: each run settles the one before, synchronize() the last") {
    Simulation sim(spec, *r, dry());
    for (int k = 0; k < 6; ++k) sim.advance();
    sim.synchronize();
    CHECK(metric(sim, "testing.defer/step") == 5);
    CHECK(metric(sim, "testing.defer/settled_in_run") == 5);
  }
  SECTION("FLIPFLOW_DEFERRED_READS=0: read within the step") {
    ::setenv("FLIPFLOW_DEFERRED_READS", "0", 1);
    Simulation sim(spec, *r, dry());
    ::unsetenv("FLIPFLOW_DEFERRED_READS");
    for (std::uint64_t k = 0; k < 6; ++k) {
      sim.advance();
      CHECK(slot(sim, "testing.defer").metrics.values().at("deferred") == 0.0);
      CHECK(metric(sim, "testing.defer/step") == double(k));
    }
  }
  SECTION("profiling (per-stage times on CUDA): read within the step") {
    Simulation sim(spec, *r, dry());
    sim.scheduler().set_profiling(true);
    sim.advance();
    CHECK(slot(sim, "testing.defer").metrics.values().at("deferred") == 0.0);
  }
}

TEST_CASE("observers see the step's result: the step before an observed one reads within it", "[deferred]") {
  auto r = test::registry_with({}, {"testing"});
  test::EntryOptions every3;
  every3.every = 3;
  const auto spec =
      test::spec(2, 64, 0.2, 9, 0.01, {entry(*r, "testing.defer"), entry(*r, "testing.watch", {}, every3)});
  Simulation sim(spec, *r, dry());
  int watched = 0;
  for (std::uint64_t k = 0; k < 9; ++k) {
    sim.advance();
    const StageSlot& watch = slot(sim, "testing.watch");
    const StageSlot& defer = slot(sim, "testing.defer");
    INFO("step " << k);
    if (!watch.ran) {
      CHECK(defer.metrics.values().at("deferred") == 1.0);
      continue;
    }
    ++watched;
    // The watch read RunStats while observing, before this test touched stats().
    CHECK(watch.metrics.values().at("seen") == double(k));
    CHECK(defer.metrics.values().at("deferred") == 0.0);
  }
  CHECK(watched == 3);
}

TEST_CASE("an error in a result left past the step is thrown where it is read", "[deferred]") {
  auto r = test::registry_with({}, {"testing"});
  const auto spec = test::spec(2, 64, 0.2, 6, 0.01, {entry(*r, "testing.defer", {{"fail_at", std::int64_t(2)}})});
  SECTION("by synchronize()") {
    Simulation sim(spec, *r, dry());
    for (int k = 0; k < 3; ++k) sim.advance();
    CHECK_THROWS_WITH(sim.synchronize(), Contains("the result of step 2 reports an error"));
  }
  SECTION("by the stage's next run, in the next step") {
    Simulation sim(spec, *r, dry());
    for (int k = 0; k < 3; ++k) sim.advance();
    CHECK_THROWS_WITH(sim.advance(), Contains("the result of step 2 reports an error"));
  }
  SECTION("by stats()") {
    Simulation sim(spec, *r, dry());
    for (int k = 0; k < 3; ++k) sim.advance();
    CHECK_THROWS_WITH(sim.stats(), Contains("the result of step 2 reports an error"));
  }
}
