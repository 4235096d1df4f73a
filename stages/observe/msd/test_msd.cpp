// observe.msd alone: the same bits for any thread count (its value against the H5MD file, with a
// hand-computed case, is in stages/observe/h5md/test_h5md.cpp). Its time origin: step 0 whatever
// the schedule, or the first call at or after from_step (NaN before), checked against the
// displacements computed here from the run's own states; the origin survives a checkpoint (and
// one written before from_step existed still resumes).
#include <oneapi/tbb/global_control.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <map>

#include "core/run/simulation.h"
#include "core/stage/state.h"
#include "stages/observe/msd/stage.h"
#include "support/backends.h"
#include "support/spec.h"
#include "support/stage_driver.h"
#include "support/test_plugins.h"

using namespace ff;

namespace {

// Unwrapped positions of `s` (position + image·L), n x dim, computed here, not by the stage.
std::vector<double> unwrapped(State& s) {
  Field& x = s.field(fields::position);
  Field& im = s.field(fields::image);
  x.acquire(Where::host, Mode::read);
  im.acquire(Where::host, Mode::read);
  const std::size_t d = std::size_t(s.dim());
  std::vector<double> out(s.n() * d);
  for (std::size_t i = 0; i < out.size(); ++i) {
    const double p = s.precision() == Precision::f32 ? double(x.host<float>()[i]) : x.host<double>()[i];
    out[i] = p + double(im.host<std::int32_t>()[i]) * s.box.L[i % d];
  }
  return out;
}

double mean_squared(const std::vector<double>& a, const std::vector<double>& b, std::size_t n) {
  double sum = 0;
  for (std::size_t i = 0; i < a.size(); ++i) sum += (a[i] - b[i]) * (a[i] - b[i]);
  return sum / double(n);
}

// Brownian disks (D = 1, Δt = 0.01, no interactions) for `steps` steps with observe.msd at the
// log schedule first 10, factor 2 (steps 10, 20, 40, 80, ... and the last); returns msd by step
// and checks each value against the displacement from the state at step `origin` (computed from
// the run's states). Before `origin` msd must be NaN.
std::map<std::uint64_t, double> run_log_schedule(Backend b, std::int64_t from_step, std::uint64_t origin,
                                                 std::uint64_t steps) {
  auto reg = test::registry_with({"brownian"});
  StepEntry msd = test::entry(*reg, "observe.msd", {{"from_step", ParamValue(from_step)}});
  msd.schedule.log = true;
  msd.schedule.first = 10;
  msd.schedule.factor = 2;
  auto spec = test::spec(2, 400, 0.05, steps, 0.01,
                         {test::entry(*reg, "brownian.integrate", {{"D", 1.0}}), msd}, 7);
  spec.system.init = "random";
  Simulation sim(spec, *reg, test::dry(b));
  const std::size_t n = sim.state().n();
  std::vector<double> reference;
  if (origin == 0) reference = unwrapped(sim.state());
  std::map<std::uint64_t, double> got;
  std::uint64_t calls = 0;
  for (std::uint64_t k = 0; k < steps; ++k) {
    sim.advance();
    const std::uint64_t step = sim.state().step;
    if (step == origin && origin > 0) reference = unwrapped(sim.state());
    if (test::slot(sim, "observe.msd").calls == calls) continue;
    calls = test::slot(sim, "observe.msd").calls;
    const double m = test::metric(sim, "observe.msd/msd");
    got[step] = m;
    INFO("step " << step);
    if (step < origin) {
      CHECK(std::isnan(m));
    } else {
      REQUIRE(reference.size() == 2 * n);
      CHECK(m == Approx(mean_squared(unwrapped(sim.state()), reference, n)).epsilon(1e-12).margin(1e-15));
    }
  }
  sim.finish(true);
  return got;
}

}  // namespace

TEST_CASE("observe.msd gives the same bits for any thread count", "[observe][msd]") {
  const std::size_t n = 200000;
  State s(3, Precision::f64, n);
  s.box.L[0] = s.box.L[1] = s.box.L[2] = 50.0;
  std::uint64_t r = 12345;
  auto next = [&] {
    r = r * 6364136223846793005ull + 1442695040888963407ull;
    return double(r >> 11) / double(1ull << 53);
  };
  double* x = s.field(fields::position).host<double>();
  std::int32_t* im = s.field(fields::image).host<std::int32_t>();
  for (std::size_t i = 0; i < 3 * n; ++i) x[i] = 50.0 * next();
  auto value = [&](int threads) {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
    observe::Msd msd;
    test::StageDriver driver(Backend::cpu, Precision::f64, 3);
    for (std::size_t i = 0; i < 3 * n; ++i) im[i] = 0;
    driver.run(msd, s, 0);
    for (std::size_t i = 0; i < 3 * n; ++i) im[i] = std::int32_t(i % 5) - 2;
    driver.run(msd, s, 1);
    return driver.metric("msd");
  };
  const double one = value(1);
  // Every image is i % 5 - 2 along each axis: MSD = L² Σ_k (i_k)² averaged = 2500 · 3 · 2 = 15000.
  CHECK(one == Approx(15000.0).epsilon(1e-3));
  CHECK(value(4) == one);
  CHECK(value(2) == one);
}

TEST_CASE("observe.msd on a log schedule from step 10 measures from step 0, not from its first call",
          "[observe][msd]") {
  // The report: with first: 10 the curve started at 0 at step 10, and at step 1000 gave 39.87
  // (the displacement from step 10) where 4Dt = 40.
  const Backend b = GENERATE(from_range(test::backends()));
  INFO("backend " << to_string(b));
  const auto got = run_log_schedule(b, 0, 0, 161);
  REQUIRE(got.size() == 6);  // 10, 20, 40, 80, 160 and the last step, 161
  CHECK(got.begin()->first == 10);
  // 4Dt at t = 0.1 is 0.4; 400 disks average it within a few percent, far from 0.
  CHECK(got.at(10) == Approx(0.4).epsilon(0.2));
  CHECK(got.at(160) == Approx(6.4).epsilon(0.2));
}

TEST_CASE("observe.msd from_step: NaN before, then the displacement from the first call at or after it",
          "[observe][msd]") {
  const Backend b = GENERATE(from_range(test::backends()));
  INFO("backend " << to_string(b));
  // from_step 15 is between the calls at 10 and 20: the origin is step 20.
  const auto between = run_log_schedule(b, 15, 20, 81);
  CHECK(std::isnan(between.at(10)));
  CHECK(between.at(20) == 0.0);
  CHECK(between.at(40) > 0.0);
  // from_step 40 is a call: the origin is step 40.
  const auto at = run_log_schedule(b, 40, 40, 81);
  CHECK(std::isnan(at.at(20)));
  CHECK(at.at(40) == 0.0);
  CHECK(at.at(80) == Approx(4 * 0.4).epsilon(0.2));
}

TEST_CASE("observe.msd keeps its origin through a checkpoint, also one of the code before from_step",
          "[observe][msd]") {
  State s(2, Precision::f64, 2);
  s.box.L[0] = s.box.L[1] = 10.0;
  auto set = [&](std::vector<double> x, std::vector<std::int32_t> im) {
    for (std::size_t i = 0; i < x.size(); ++i) {
      s.field(fields::position).host<double>()[i] = x[i];
      s.field(fields::image).host<std::int32_t>()[i] = im[i];
    }
  };
  test::StageDriver driver(Backend::cpu, Precision::f64, 2);
  set({1, 1, 5, 5}, {0, 0, 0, 0});
  observe::Msd first;
  first.configure(s);  // step 0: the origin
  set({2, 1, 5, 8}, {0, 0, 0, 0});
  driver.run(first, s, 10);
  CHECK(driver.metric("msd") == (1.0 + 9.0) / 2);
  StageState saved;
  first.save_state(saved);

  // The continuation configures on the checkpoint's state (step 10), then restores the origin.
  s.step = 10;
  observe::Msd resumed;
  resumed.configure(s);
  resumed.restore_state(saved, s);
  set({2, 1, 5, 8}, {1, 0, 0, -1});  // p0 crossed +x, p1 crossed -y: (12, 1), (5, -2)
  driver.run(resumed, s, 20);
  CHECK(driver.metric("msd") == (121.0 + 49.0) / 2);

  // A checkpoint taken before from_step was reached: no origin yet, it is taken at from_step.
  observe::MsdParams late;
  late.from_step = 30;
  observe::Msd waiting(late, RunInfo{});
  waiting.configure(s);
  driver.run(waiting, s, 20);
  CHECK(std::isnan(driver.metric("msd")));
  StageState before;
  waiting.save_state(before);
  observe::Msd waiting_resumed(late, RunInfo{});
  waiting_resumed.configure(s);
  waiting_resumed.restore_state(before, s);
  CHECK_FALSE(waiting_resumed.has_reference());
  driver.run(waiting_resumed, s, 30);
  CHECK(driver.metric("msd") == 0.0);
  set({3, 1, 5, 8}, {1, 0, 0, -1});
  driver.run(waiting_resumed, s, 40);
  CHECK(driver.metric("msd") == 0.5);

  // The old format: "reference" alone, the unwrapped positions of the stage's first call.
  StageState old;
  old.put("reference", std::vector<double>{1, 1, 5, 5});
  observe::Msd from_old;
  from_old.configure(s);
  from_old.restore_state(old, s);
  driver.run(from_old, s, 50);
  CHECK(driver.metric("msd") == (144.0 + 49.0) / 2);
  // ... empty when the old run had not called it yet: at step 0 the state is the origin.
  StageState old_empty;
  old_empty.put("reference", std::vector<double>{});
  s.step = 0;
  observe::Msd from_old_empty;
  from_old_empty.restore_state(old_empty, s);
  CHECK(from_old_empty.has_reference());
  driver.run(from_old_empty, s, 0);
  CHECK(driver.metric("msd") == 0.0);
}
