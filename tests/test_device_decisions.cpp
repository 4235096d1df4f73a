// Device decisions (StepContext::gate): a decider may leave its host decision to its kernels, so
// the stages after it in the chain launch gated on it before the host has read anything; the
// core takes the decision afterwards (Stage::decide) and runs the followers again, without the
// gate, when it was closed or refused. On CUDA delaunay.detect_inversion decides and delaunay.flip,
// delaunay.lawson and overlap_correct follow (test_cpu_cuda_bits compares the bits with and
// without); here the core's side with tests/plugins/testing_plugin.cpp's testing.decide and
// testing.follow, on the CPU, where the gate is a host word the stages write and read in run().
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

namespace {

double value(const Simulation& sim, const std::string& id, const std::string& name) {
  const auto& v = slot(sim, id).metrics.values();
  const auto it = v.find(name);
  if (it == v.end()) FAIL("stage " << id << " has no metric " << name);
  return it->second;
}

ParamValue steps(std::vector<double> s) { return ParamValue(std::move(s)); }

// testing.decide, then followers a and b (each adds 1 to its own field per step it counts).
PipelineSpec pipeline(const Registry& r, std::uint64_t n_steps, std::map<std::string, ParamValue> decide,
                      std::map<std::string, ParamValue> a = {}, std::map<std::string, ParamValue> b = {}) {
  test::EntryOptions ia, ib;
  ia.id = "a";
  ib.id = "b";
  a["field"] = ParamValue(std::string("testing.a"));
  b["field"] = ParamValue(std::string("testing.b"));
  return test::spec(2, 32, 0.2, n_steps, 0.01,
                    {entry(r, "testing.decide", decide), entry(r, "testing.follow", a, ia),
                     entry(r, "testing.follow", b, ib)});
}

}  // namespace

TEST_CASE("a gated step: the followers' work counts once, whatever the decision", "[gate]") {
  auto r = test::registry_with({}, {"testing"});

  SECTION("the gate open on every step: one run each, no re-run") {
    Simulation sim(pipeline(*r, 5, {}), *r, dry());
    for (int k = 0; k < 5; ++k) {
      sim.advance();
      CHECK(value(sim, "testing.decide", "gated") == 1.0);
      CHECK(value(sim, "a", "gated") == 1.0);
      CHECK(value(sim, "b", "gated") == 1.0);
    }
    CHECK(value(sim, "testing.decide", "decided") == 5);
    CHECK(value(sim, "a", "runs") == 5);
    CHECK(value(sim, "a", "value") == 5);
    CHECK(value(sim, "b", "value") == 5);
  }
  SECTION("closed on steps 1 and 3: the followers run again without the gate, and count once") {
    Simulation sim(pipeline(*r, 5, {{"closed", steps({1, 3})}}), *r, dry());
    for (std::uint64_t k = 0; k < 5; ++k) {
      sim.advance();
      INFO("step " << k);
      const double regated = (k == 1 || k == 3) ? 0.0 : 1.0;  // the last run of a closed step has no gate
      CHECK(value(sim, "a", "gated") == regated);
      CHECK(value(sim, "b", "gated") == regated);
      CHECK(value(sim, "a", "value") == double(k + 1));
      CHECK(value(sim, "b", "value") == double(k + 1));
    }
    CHECK(value(sim, "a", "runs") == 7);
    CHECK(value(sim, "b", "runs") == 7);
    CHECK(sim.stats().rollbacks == 0);
  }
  SECTION("a rollback decided by decide(): the step runs again, and counts once") {
    Simulation sim(pipeline(*r, 4, {{"rollback", steps({2})}}), *r, dry());
    for (int k = 0; k < 4; ++k) sim.advance();
    CHECK(sim.stats().rollbacks == 1);
    CHECK(value(sim, "a", "value") == 4);
    CHECK(value(sim, "b", "value") == 4);
    CHECK(value(sim, "a", "runs") == 5);  // step 2: gated (closed), then the retry's gated run
    CHECK(value(sim, "testing.decide", "decided") == 5);
  }
  SECTION("a follower refuses with the gate open: it and those after it run again, not those before") {
    Simulation sim(pipeline(*r, 4, {}, {}, {{"refuse", steps({1})}}), *r, dry());
    for (int k = 0; k < 4; ++k) sim.advance();
    CHECK(value(sim, "a", "runs") == 4);
    CHECK(value(sim, "b", "runs") == 5);
    CHECK(value(sim, "a", "value") == 4);
    CHECK(value(sim, "b", "value") == 4);
  }
  SECTION("the first follower refuses: the core closes the gate for the second, and runs both again") {
    Simulation sim(pipeline(*r, 4, {}, {{"refuse", steps({2})}}), *r, dry());
    for (int k = 0; k < 4; ++k) sim.advance();
    CHECK(value(sim, "a", "runs") == 5);
    CHECK(value(sim, "b", "runs") == 5);
    CHECK(value(sim, "a", "value") == 4);
    CHECK(value(sim, "b", "value") == 4);
  }
}

TEST_CASE("no gate where the core cannot gate", "[gate]") {
  auto r = test::registry_with({}, {"testing"});
  SECTION("a stage after the decider does not follow gates") {
    Simulation sim(pipeline(*r, 2, {}, {}, {{"follows", false}}), *r, dry());
    sim.advance();
    CHECK(value(sim, "testing.decide", "gated") == 0.0);
    CHECK(value(sim, "a", "gated") == 0.0);
    CHECK(value(sim, "a", "value") == 1);
  }
  SECTION("FLIPFLOW_DEVICE_DECISIONS=0") {
    ::setenv("FLIPFLOW_DEVICE_DECISIONS", "0", 1);
    Simulation sim(pipeline(*r, 2, {{"closed", steps({0})}}), *r, dry());
    ::unsetenv("FLIPFLOW_DEVICE_DECISIONS");
    sim.advance();
    CHECK(value(sim, "testing.decide", "gated") == 0.0);
    CHECK(value(sim, "a", "runs") == 1);
    CHECK(value(sim, "testing.decide", "decided") == 0);
  }
  SECTION("profiling (per-stage times on CUDA)") {
    Simulation sim(pipeline(*r, 2, {}), *r, dry());
    sim.scheduler().set_profiling(true);
    sim.advance();
    CHECK(value(sim, "testing.decide", "gated") == 0.0);
  }
}

TEST_CASE("an error in a gated step is thrown by advance(), and leaves no gate behind", "[gate]") {
  auto r = test::registry_with({}, {"testing"});
  SECTION("in the host's decision") {
    Simulation sim(pipeline(*r, 4, {{"fail_at", std::int64_t(1)}}), *r, dry());
    sim.advance();
    CHECK_THROWS_WITH(sim.advance(), Contains("the decision of step 1 reports an error"));
  }
  SECTION("in a follower's gated run: the next attempt, without a gate offered, gives none") {
    Simulation sim(pipeline(*r, 4, {}, {{"fail_at", std::int64_t(1)}}), *r, dry());
    sim.advance();
    CHECK_THROWS_WITH(sim.advance(), Contains("the gated run of step 1 fails"));
    sim.scheduler().set_profiling(true);  // (no gate is offered while profiling)
    sim.advance();
    CHECK(value(sim, "testing.decide", "gated") == 0.0);
    CHECK(value(sim, "a", "gated") == 0.0);
    CHECK(value(sim, "b", "gated") == 0.0);
  }
}
