// The step graph and its scheduler: order, concurrency, conflicts, `every` and `at`, errors from stages.
#include <oneapi/tbb/global_control.h>

#include <catch2/catch.hpp>

#include <set>

#include "core/base/error.h"
#include "core/run/simulation.h"
#include "support/backends.h"
#include "support/spec.h"
#include "support/test_plugins.h"

using namespace ff;
using ff::test::dry;
using ff::test::entry;
using ff::test::EntryOptions;
using ff::test::metric;

TEST_CASE("independent stages run concurrently", "[scheduler]") {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 4);
  auto r = test::registry_with({}, {"testing"});
  // start -> {left, right} -> end: left and right have no path between them.
  auto s = test::spec(2, 64, 0.1, 3, 0.01,
                      {entry(*r, "testing.record", {}, {"start"}),
                       entry(*r, "testing.barrier", {{"group", std::int64_t(1)}}, {"left", {"start"}, true}),
                       entry(*r, "testing.barrier", {{"group", std::int64_t(1)}}, {"right", {"start"}, true}),
                       entry(*r, "testing.record", {}, {"end", {"left", "right"}, true})});
  Simulation sim(s, *r, dry());
  CHECK_FALSE(sim.graph().is_chain());
  for (int k = 0; k < 3; ++k) {
    sim.advance();
    CHECK(metric(sim, "left/overlapped") == 1);
    CHECK(metric(sim, "right/overlapped") == 1);
    CHECK(metric(sim, "start/order") < metric(sim, "end/order"));
  }
}

TEST_CASE("dependent stages run in declared order", "[scheduler]") {
  auto r = test::registry_with({}, {"testing"});
  auto s = test::spec(2, 16, 0.1, 5, 0.01,
                      {entry(*r, "testing.record", {}, {"a"}), entry(*r, "testing.record", {}, {"b"}),
                       entry(*r, "testing.record", {}, {"c"})});
  Simulation sim(s, *r, dry());
  CHECK(sim.graph().is_chain());
  for (int k = 0; k < 5; ++k) {
    sim.advance();
    CHECK(metric(sim, "a/order") + 1 == metric(sim, "b/order"));
    CHECK(metric(sim, "b/order") + 1 == metric(sim, "c/order"));
  }
}

TEST_CASE("after_step follows the whole step, in step order, and skips a rolled-back attempt", "[scheduler]") {
  auto r = test::registry_with({}, {"testing"});
  auto s = test::spec(2, 16, 0.1, 4, 0.01,
                      {entry(*r, "testing.record", {}, {"a"}), entry(*r, "testing.record", {}, {"b"}),
                       entry(*r, "testing.rollback", {{"steps", std::vector<double>{2}}}, {"fail"}),
                       entry(*r, "testing.record", {}, {"c"})});
  Simulation sim(s, *r, dry());
  double before = -1;
  for (int k = 0; k < 4; ++k) {
    sim.advance();
    // One step: a, b, c run (a, a + 1, a + 2 in one sequence), then after_step for a, b, c.
    const double a = metric(sim, "a/order");
    CHECK(metric(sim, "b/order") == a + 1);
    CHECK(metric(sim, "c/order") == a + 2);
    CHECK(metric(sim, "a/after") == a + 3);
    CHECK(metric(sim, "b/after") == a + 4);
    CHECK(metric(sim, "c/after") == a + 5);
    // Six a step; step 2's first attempt stops at `fail` after a and b ran, and calls no
    // after_step (two more, not four).
    if (k > 0) CHECK(a - before == (k == 2 ? 8 : 6));
    before = a;
  }
  CHECK(sim.stats().rollbacks == 1);
}

TEST_CASE("`after:` reorders, and a fork joins before its successor", "[scheduler]") {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
  auto r = test::registry_with({}, {"testing"});
  // c declared last but b waits for it.
  auto s = test::spec(2, 16, 0.1, 4, 0.01,
                      {entry(*r, "testing.record", {}, {"a"}),
                       entry(*r, "testing.record", {}, {"c", {"a"}, true}),
                       entry(*r, "testing.record", {}, {"b", {"a", "c"}, true})});
  Simulation sim(s, *r, dry());
  for (int k = 0; k < 4; ++k) {
    sim.advance();
    CHECK(metric(sim, "a/order") < metric(sim, "c/order"));
    CHECK(metric(sim, "c/order") < metric(sim, "b/order"));
  }
}

TEST_CASE("two unordered stages writing the same field are refused", "[scheduler]") {
  auto r = test::registry_with({}, {"testing"});
  auto s = test::spec(2, 16, 0.1, 1, 0.01,
                      {entry(*r, "testing.record", {}, {"a"}),
                       entry(*r, "testing.record", {{"writes", std::string("position")}}, {"w1", {"a"}, true}),
                       entry(*r, "testing.record", {{"reads", std::string("position")}}, {"r2", {"a"}, true})});
  CHECK_THROWS_WITH(Simulation(s, *r, dry()),
                    Catch::Contains("step 'r2' and step 'w1' both use field 'position' (w1 writes it)") &&
                        Catch::Contains("add `after: [w1]`"));
  // Reading the same field from both branches is fine.
  s.step[1].params.set("writes", std::string());
  s.step[1].params.set("reads", std::string("position"));
  CHECK_NOTHROW(Simulation(s, *r, dry()));
}

TEST_CASE("a stage that overwrites what an earlier stage wrote, unread, is refused", "[scheduler]") {
  // Two force stages each writing `force` would not add up: only the last would count.
  auto r = test::registry_with({}, {"testing"});
  auto s = test::spec(2, 16, 0.1, 1, 0.01,
                      {entry(*r, "testing.record", {{"writes", std::string("position")}}, {"first"}),
                       entry(*r, "testing.record", {{"overwrites", std::string("position")}}, {"second"})});
  CHECK_THROWS_WITH(Simulation(s, *r, dry()),
                    Catch::Contains("step 'second' overwrites field 'position', which step 'first' wrote") &&
                        Catch::Contains("only the last one counts"));
  // A stage in between that reads it (an integrator reading the force) makes both writes count.
  s.step.insert(s.step.begin() + 1, entry(*r, "testing.record", {{"reads", std::string("position")}}, {"reader"}));
  CHECK_NOTHROW(Simulation(s, *r, dry()));
  // So does a second writer that adds to it (reads it too: Mode::readwrite).
  s.step.erase(s.step.begin() + 1);
  s.step[1].params.set("overwrites", std::string());
  s.step[1].params.set("writes", std::string("position"));
  CHECK_NOTHROW(Simulation(s, *r, dry()));
}

TEST_CASE("`every: k` runs a stage only on multiples of k", "[scheduler]") {
  auto r = test::registry_with({}, {"testing"});
  auto s = test::spec(2, 16, 0.1, 7, 0.01,
                      {entry(*r, "testing.record", {}, {"always"}), entry(*r, "testing.record", {}, {"third", {}, false, 3})});
  Simulation sim(s, *r, dry());
  int ran_third = 0;
  for (int k = 0; k < 7; ++k) {
    sim.advance();
    ran_third += sim.slots()[1].ran ? 1 : 0;
    CHECK(sim.slots()[1].ran == (k % 3 == 0));
  }
  CHECK(ran_third == 3);  // steps 0, 3, 6
}

TEST_CASE("`at: {log: ...}` runs a stage on round(first*factor^k) and on the last step", "[scheduler]") {
  // Tran et al.'s kinetics span decades: first = 1, factor = 1.2 over 10^5 steps.
  constexpr std::uint64_t steps = 100000;
  std::set<std::uint64_t> expected;
  for (double s = 1; s < steps; s *= 1.2) expected.insert(std::uint64_t(s + 0.5));
  expected.insert(steps - 1);
  CHECK(expected.size() > 55);
  CHECK(expected.size() < 65);

  auto r = test::registry_with({}, {"testing"});
  StepEntry logged = entry(*r, "testing.record", {}, {"logged"});
  logged.schedule.log = true;
  logged.schedule.first = 1;
  logged.schedule.factor = 1.2;
  auto s = test::spec(2, 4, 0.1, steps, 0.01, {entry(*r, "testing.record", {}, {"always"}), logged});
  Simulation sim(s, *r, dry());
  std::set<std::uint64_t> ran;
  for (std::uint64_t k = 0; k < steps; ++k) {
    sim.advance();
    if (sim.slots()[1].ran) ran.insert(k);
  }
  CHECK(ran == expected);
  CHECK(ran.count(1) == 1);
  CHECK(ran.count(0) == 0);
}

TEST_CASE("a stage that uses a field nobody created is an input error", "[scheduler]") {
  auto r = test::registry_with({}, {"testing"});
  auto s = test::spec(2, 16, 0.1, 1, 0.01, {entry(*r, "testing.record", {{"reads", std::string("velocity")}})});
  CHECK_THROWS_WITH(Simulation(s, *r, dry()), Catch::Contains("uses field 'velocity', which no stage before it created"));
}

TEST_CASE("seven no-op stages make a chain the scheduler runs in order", "[scheduler]") {
  auto r = test::registry_with({});
  std::vector<StepEntry> steps;
  for (int k = 0; k < 7; ++k) steps.push_back(entry(*r, "core.noop", {}, {"noop" + std::to_string(k)}));
  auto s = test::spec(2, 16, 0.1, 100, 0.01, steps);
  Simulation sim(s, *r, dry());
  for (int k = 0; k < 100; ++k) sim.advance();
  CHECK(sim.state().step == 100);
  CHECK(sim.state().time == Approx(1.0));
  for (auto& slot : sim.slots()) CHECK(slot.calls == 100);
}

// On CUDA each branch of a fork gets its own stream, and a stage waits on the events of its
// direct predecessors on other streams. A predecessor skipped by `every` must still record its
// event after its own predecessors' work: here `check` (its own stream, after `skipped`) must see
// what `fill` (held on the main stream by a sleeping host function) wrote this step, also on the steps `skipped` does
// not run. Until session 33 a skipped stage recorded nothing, and `check` waited on its event of
// an earlier step: it read the bytes of the step before.
TEST_CASE("a stage skipped by every still orders its successors on other streams (CUDA)", "[scheduler][cuda]") {
  if (!ff::test::have_cuda("the join of a stage skipped by every")) return;
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
  auto r = test::registry_with({}, {"testing"});
  auto s = test::spec(2, 64, 0.1, 4, 0.01,
                      {entry(*r, "testing.device_fill", {{"hold_ms", std::int64_t(150)}}, {"fill"}),
                       entry(*r, "testing.record", {}, {"skipped", {"fill"}, true, 2}),
                       entry(*r, "testing.record", {}, {"beside", {"skipped"}, true}),
                       entry(*r, "testing.device_check", {}, {"check", {"skipped"}, true})});
  Simulation sim(s, *r, dry(Backend::cuda));
  for (int k = 0; k < 4; ++k) {
    INFO("step " << k);
    sim.advance();
    CHECK(metric(sim, "check/stale") == 0);
  }
}
