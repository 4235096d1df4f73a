// abp.integrate's non-finite check (issue 19, item 6; stages/overdamped/integrate/finite_check.h),
// through a whole Simulation on every backend: a NaN or an infinity put into a particle's position
// or orientation stops the run with a RunError naming the stage, the step the value appeared in,
// the lowest particle and the field, and how many others; at the start of the run, mid-run, in
// 2D and 3D, in float and double. (A run whose values stay finite is never stopped: every other
// test of the plugin, and the shipped pipelines' outputs are the same bits as before the check.) On CUDA the check is read back without waiting for the device, so the run may
// go on a few steps before it stops: the message still names the step the device recorded, and
// the run stops within 2 × NonFiniteCheck::kPace steps (graph-replayed steps included).
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <string>

#include "core/base/error.h"
#include "core/run/simulation.h"
#include "stages/overdamped/integrate/finite_check.h"
#include "stages/overdamped/integrate/test_support.h"
#include "support/backends.h"
#include "support/spec.h"
#include "support/test_plugins.h"

using namespace ff;
using test::entry;

namespace {

const Registry& registry() {
  static const auto r = test::registry_with({"abp"});
  return *r;
}

PipelineSpec abp_spec(int dim, std::uint64_t steps, Precision p = Precision::f64) {
  return test::spec(dim, 64, 0.2, steps, 0.01,
                    {entry(registry(), "abp.integrate", {{"v0", 1.0}, {"Dr", 0.5}, {"D", 0.1}})}, 3, p);
}

bool warn_if_no_cuda() {
  return test::have_cuda("abp.integrate's non-finite check on CUDA (read back without a host wait)");
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace

TEST_CASE("abp.integrate: a NaN orientation at the start stops the run at step 0, naming particle and field",
          "[abp][non_finite]") {
  warn_if_no_cuda();
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  INFO(to_string(b) << ", " << dim << "D");
  Simulation sim(abp_spec(dim, 50), registry(), test::dry(b));
  test::put(sim, "orientation", 5, dim == 2 ? 0 : 1, kNaN);
  const std::string what = test::advance_until_error(sim, 50);
  INFO(what);
  CHECK_THAT(what, Catch::Contains("stage 'abp.integrate' (abp.integrate), step 0: particle 5 has a non-finite "
                                   "orientation"));
  CHECK_THAT(what, Catch::Contains(dim == 2 ? "θ = nan (position (nan, nan))" : "e = (nan, nan, nan)"));
  CHECK_THAT(what, !Catch::Contains("other particle"));
  if (b == Backend::cpu) CHECK(sim.state().step == 0);  // stopped inside step 0
  CHECK(sim.state().step <= 2 * overdamped::NonFiniteCheck::kPace);
}

TEST_CASE("abp.integrate: non-finite positions stop the run naming the lowest particle and the count",
          "[abp][non_finite]") {
  warn_if_no_cuda();
  const Backend b = GENERATE(from_range(test::backends()));
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  INFO(to_string(b) << ", " << to_string(p));
  Simulation sim(abp_spec(2, 50, p), registry(), test::dry(b));
  test::put(sim, fields::position, 40, 1, kInf);  // inf wraps to NaN: x - floor(x/L)·L = inf - inf
  test::put(sim, fields::position, 7, 0, -kInf);
  test::put(sim, fields::position, 23, 0, kNaN);
  const std::string what = test::advance_until_error(sim, 50);
  INFO(what);
  CHECK_THAT(what, Catch::Contains("stage 'abp.integrate' (abp.integrate), step 0: particle 7 has a non-finite "
                                   "position (nan, "));
  CHECK_THAT(what, Catch::Contains("(2 other particle(s) too)"));
  CHECK_THAT(what, Catch::Contains("system.init"));
}

TEST_CASE("abp.integrate: a value that turns non-finite mid-run stops the run at that step", "[abp][non_finite]") {
  warn_if_no_cuda();
  const Backend b = GENERATE(from_range(test::backends()));
  INFO(to_string(b));
  // 300 steps before: on CUDA the steady-state step is a replayed graph by then, whose after_step
  // is the only place the host looks.
  Simulation sim(abp_spec(2, 1000), registry(), test::dry(b));
  REQUIRE(test::advance_until_error(sim, 300) == "");
  REQUIRE(sim.state().step == 300);
  test::put(sim, "orientation", 12, 0, kInf);
  test::put(sim, "orientation", 30, 0, kNaN);
  const std::string what = test::advance_until_error(sim, 700);
  INFO(what);
  CHECK_THAT(what, Catch::Contains("step 300: particle 12 has a non-finite orientation θ = nan"));
  CHECK_THAT(what, Catch::Contains("(1 other particle(s) too)"));
  CHECK(sim.state().step >= 300);
  CHECK(sim.state().step <= 300 + 2 * overdamped::NonFiniteCheck::kPace);
  if (b == Backend::cpu) CHECK(sim.state().step == 300);
}
