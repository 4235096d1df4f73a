// A stage may limit Δt (Outcome::limit_dt, spec G5): the dyadic Δt the core takes, the step
// run again with the same attempt number, what is restored, the counters, regrowth, giving up.
#include <catch2/catch.hpp>
#include <cstring>
#include <vector>

#include "core/base/error.h"
#include "core/run/simulation.h"
#include "support/spec.h"
#include "support/test_plugins.h"

using namespace ff;
using ff::test::dry;
using ff::test::entry;

namespace {
std::vector<double> positions(Simulation& s) {
  Field& f = s.state().field(fields::position);
  f.acquire(Where::host, Mode::read);
  return std::vector<double>(f.host<double>(), f.host<double>() + f.size());
}

StepEntry limiter(const Registry& r, std::vector<double> steps, double dt_max) {
  return entry(r, "testing.limit_dt", {{"steps", std::move(steps)}, {"dt_max", dt_max}});
}
}  // namespace

TEST_CASE("DtController: a limit gives the largest run.dt/2^k within it, and regrowth follows the limit",
          "[dt_limit]") {
  DtController dt(0.01, 0.01 / 1024, 3);
  CHECK(dt.dt() == 0.01);
  REQUIRE(dt.limit_to(0.003));  // 0.01 -> 0.005 -> 0.0025
  CHECK(dt.dt() == 0.0025);
  CHECK(dt.current() == 0.01);  // the rollback policy's Δt is untouched
  REQUIRE(dt.limit_to(0.0025));  // exactly dyadic: taken as is
  CHECK(dt.dt() == 0.0025);
  // Accepted while limited: the limit is the next step's first guess, the streak does not move.
  dt.accepted(dt.dt(), 0.0026);
  CHECK(dt.dt() == 0.0025);
  CHECK(dt.streak() == 0);
  // The limit grows: Δt follows it at once, up to the policy's Δt.
  dt.accepted(dt.dt(), 0.0051);
  CHECK(dt.dt() == 0.005);
  dt.accepted(dt.dt(), 1.0);
  CHECK(dt.dt() == 0.01);
  // A rollback at a limited Δt halves the Δt that failed, not the policy's.
  REQUIRE(dt.limit_to(0.004));
  CHECK(dt.dt() == 0.0025);
  REQUIRE(dt.halve());
  CHECK(dt.dt() == 0.00125);
  CHECK(dt.current() == 0.00125);
  // Below dt_min: give up.
  CHECK_FALSE(dt.limit_to(0.01 / 2048));
}

TEST_CASE("a limited step runs again at the dyadic Δt, counted apart from rollbacks, and Δt regrows", "[dt_limit]") {
  auto r = test::registry_with({"brownian"}, {"testing"});
  // The limiter first (it reads what the integrator writes): nothing before it to restore.
  auto s = test::spec(2, 64, 0.2, 6, 0.01, {limiter(*r, {2}, 0.003), entry(*r, "brownian.integrate", {{"D", 1.0}})});
  Simulation sim(s, *r, dry());
  CHECK(sim.snapshot_fields().empty());
  CHECK(sim.snapshot_on_demand_fields().empty());
  std::vector<double> dts;
  std::vector<std::uint64_t> limits;
  for (int k = 0; k < 6; ++k) {
    sim.advance();
    dts.push_back(sim.stats().dt);
    limits.push_back(sim.stats().step_dt_limits);
  }
  // Step 2 is limited to 0.003: tried at 0.01, run again at 0.0025. Step 3 starts from step 2's
  // limit (no second try: its limiter reports none), and Δt is back at run.dt from step 4 on.
  CHECK(dts == std::vector<double>{0.01, 0.01, 0.0025, 0.0025, 0.01, 0.01});
  CHECK(limits == std::vector<std::uint64_t>{0, 0, 1, 0, 0, 0});
  CHECK(sim.stats().dt_limits == 1);
  CHECK(sim.stats().rollbacks == 0);
  CHECK(sim.stats().metrics.at("testing.limit_dt/runs") == 7);  // 6 steps + the one run again
  CHECK(sim.state().time == Approx(4 * 0.01 + 2 * 0.0025));
}

TEST_CASE("a limited step draws the noise of a run whose Δt was that small from the start", "[dt_limit]") {
  // Same stage ids (the noise key), same step and attempt: the limited step's positions equal,
  // bit for bit, those of a run at run.dt = 0.0025 that nothing limits.
  auto r = test::registry_with({"brownian"}, {"testing"});
  auto limited = test::spec(2, 128, 0.2, 1, 0.01, {limiter(*r, {0}, 0.003), entry(*r, "brownian.integrate", {{"D", 1.0}})});
  auto plain = test::spec(2, 128, 0.2, 1, 0.0025, {limiter(*r, {0}, 1.0), entry(*r, "brownian.integrate", {{"D", 1.0}})});
  Simulation a(limited, *r, dry()), b(plain, *r, dry());
  a.advance();
  b.advance();
  REQUIRE(a.stats().step_dt_limits == 1);
  REQUIRE(b.stats().step_dt_limits == 0);
  CHECK(a.stats().dt == b.stats().dt);
  const auto pa = positions(a), pb = positions(b);
  REQUIRE(pa.size() == pb.size());
  CHECK(std::memcmp(pa.data(), pb.data(), pa.size() * sizeof(double)) == 0);
}

TEST_CASE("what a stage before the limiter wrote is restored before the step runs again", "[dt_limit]") {
  auto r = test::registry_with({"brownian"}, {"testing"});
  auto lim = limiter(*r, {1}, 0.003);
  lim.after = {"testing.count"};
  lim.after_given = true;
  auto s = test::spec(2, 32, 0.2, 3, 0.01, {entry(*r, "testing.count"), lim, entry(*r, "brownian.integrate", {{"D", 1.0}})});
  RunOptions o = dry();
  o.check_rollbacks = true;  // and prove the restore complete
  Simulation sim(s, *r, o);
  CHECK(sim.snapshot_fields() == std::vector<std::string>{"testing.count"});
  for (int k = 0; k < 3; ++k) sim.advance();
  CHECK(sim.stats().dt_limits == 1);
  Field& c = sim.state().field("testing.count");
  for (std::size_t i = 0; i < c.size(); ++i) CHECK(c.host<double>()[i] == 3.0);  // one per accepted step
}

TEST_CASE("a limit and a rollback in one step: the limit keeps the attempt, the rollback moves it on", "[dt_limit]") {
  auto r = test::registry_with({"brownian"}, {"testing"});
  auto s = test::spec(2, 64, 0.2, 3, 0.01,
                      {limiter(*r, {2}, 0.006), entry(*r, "brownian.integrate", {{"D", 1.0}}),
                       entry(*r, "testing.rollback", {{"steps", std::vector<double>{2}}, {"fail_attempts", std::int64_t(1)}})});
  Simulation sim(s, *r, dry());
  for (int k = 0; k < 3; ++k) sim.advance();
  // Step 2: attempt 0 at 0.01 is limited (0.005, attempt 0 again), which the rollback stage
  // fails; attempt 1 passes at 0.0025.
  CHECK(sim.stats().step_dt_limits == 1);
  CHECK(sim.stats().step_rollbacks == 1);
  CHECK(sim.stats().dt == 0.0025);
  CHECK(sim.stats().metrics.at("testing.rollback/attempt") == 1);
  CHECK(sim.stats().metrics.at("testing.limit_dt/attempt") == 1);
}

TEST_CASE("a limit below dt_min stops the run naming the stage", "[dt_limit]") {
  auto r = test::registry_with({"brownian"}, {"testing"});
  auto s = test::spec(2, 64, 0.2, 3, 0.01, {limiter(*r, {1}, 1e-6), entry(*r, "brownian.integrate", {{"D", 1.0}})});
  Simulation sim(s, *r, dry());
  sim.advance();
  CHECK_THROWS_WITH(sim.advance(), Catch::Contains("stage 'testing.limit_dt' limits Δt to 1e-06") &&
                                       Catch::Contains("below dt_min") && Catch::Contains("particles involved: 2 7"));
}
