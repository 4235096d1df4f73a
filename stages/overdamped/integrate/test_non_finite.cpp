// overdamped.integrate's non-finite check without max_step (issue 19, item 6; finite_check.h): the
// plain Brownian step and the general one (per-type D) stop the run when a position is not finite
// after the step, naming the stage, the step, the lowest particle and the count; with max_step
// the guard's own check (test_blowup in plugins/pair/lj) says the same earlier, before the move.
// On CUDA without max_step the stage is replayed from a CUDA graph, and the check is read back
// there without a host wait: the run stops within 2 × NonFiniteCheck::kPace steps, naming the
// step the device recorded.
#include <catch2/catch.hpp>
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
  static const auto r = test::registry_with({});
  return *r;
}

// `general`: two species with their own D, so the stage takes its general step.
PipelineSpec spec(int dim, bool general, std::uint64_t steps) {
  std::map<std::string, ParamValue> p;
  if (general) p["D"] = std::vector<double>{1.0, 0.5};
  auto s = test::spec(dim, 100, 0.2, steps, 0.001, {entry(registry(), "overdamped.integrate", p)}, 5);
  if (general) s.system.types = {SpeciesSpec{"A", 0.5, 1.0}, SpeciesSpec{"B", 0.5, 1.0}};
  return s;
}

}  // namespace

TEST_CASE("overdamped.integrate without max_step: a NaN position stops the run naming step and particle",
          "[overdamped][non_finite]") {
  test::have_cuda("overdamped.integrate's non-finite check on CUDA (replayed graph, no host wait)");
  const Backend b = GENERATE(from_range(test::backends()));
  const bool general = GENERATE(false, true);
  const int dim = GENERATE(2, 3);
  INFO(to_string(b) << (general ? ", general" : ", plain") << ", " << dim << "D");
  Simulation sim(spec(dim, general, 1000), registry(), test::dry(b));
  // At the start of the run.
  {
    Simulation first(spec(dim, general, 10), registry(), test::dry(b));
    test::put(first, fields::position, 61, dim - 1, std::numeric_limits<double>::quiet_NaN());
    test::put(first, fields::position, 17, 0, std::numeric_limits<double>::infinity());
    const std::string what = test::advance_until_error(first, 10);
    INFO(what);
    CHECK_THAT(what, Catch::Contains("stage 'overdamped.integrate' (overdamped.integrate), step 0: particle 17 has a "
                                     "non-finite position") &&
                         Catch::Contains("(1 other particle(s) too)") && Catch::Contains("cannot mend"));
  }
  // Mid-run, after the CUDA step became a replayed graph.
  REQUIRE(test::advance_until_error(sim, 200) == "");
  test::put(sim, fields::position, 42, 1, -std::numeric_limits<double>::infinity());
  const std::string what = test::advance_until_error(sim, 800);
  INFO(what);
  CHECK_THAT(what, Catch::Contains("step 200: particle 42 has a non-finite position"));
  CHECK_THAT(what, !Catch::Contains("other particle"));
  CHECK(sim.state().step <= 200 + 2 * overdamped::NonFiniteCheck::kPace);
  if (b == Backend::cpu) CHECK(sim.state().step == 200);
}
