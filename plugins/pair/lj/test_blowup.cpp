// Robustness of a stiff soft potential (seed-gaps.md T1 test 2, issue 16 item 6): a reference BD
// of Tran's 36–18 potential went to NaN after a rare deep approach at Δt = 2e-5 τ_B. Here two
// particles are placed too close on purpose, through a whole Simulation (neighbors.verlet, pair.lj
// with ε = 14, n = 18, overdamped.integrate with max_step = 0.1), on every backend:
//   - at r = 0.9 σ (F = 9.2·10⁴ k_BT/σ) and Δt = 1e-5 the drift step is 0.92 σ: the step is
//     rolled back four times, until Δt/16 makes it 0.058 σ, and the pair separates;
//   - at r = 0.8 σ (F = 7.7·10⁶) no Δt above dt_min = Δt/1024 is short enough: the run stops
//     naming the stage, the step and the particle;
//   - a force that is not finite (ε = 10³⁰⁷: 4nε overflows) stops the run at once, naming the
//     stage, the step, the particle and the field, without rolling back (a smaller Δt cannot
//     mend it); so does a position that is NaN at the start of a step.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <string>

#include "core/base/error.h"
#include "core/run/simulation.h"
#include "support/backends.h"
#include "support/fields.h"
#include "support/spec.h"
#include "support/test_plugins.h"

using namespace ff;
using test::entry;

namespace {

const Registry& registry() {
  static const auto r = test::registry_with({"pair"});
  return *r;
}

// Two particles in a 3D box of side 10, at (5, 5, 5) and (5 − r, 5, 5); Tran's potential unless
// `epsilon` says otherwise; max_step = 0.1.
PipelineSpec pair_spec(double dt, double epsilon = 14) {
  auto s = test::spec(3, 2, 0.01, 1, dt,
                      {entry(registry(), "neighbors.verlet", {{"cutoff", 1.5}, {"skin", 0.3}}),
                       entry(registry(), "pair.lj", {{"epsilon", std::vector<double>{epsilon}}, {"n", std::int64_t(18)},
                                                     {"r_cut", 1.5}}),
                       entry(registry(), "overdamped.integrate", {{"max_step", 0.1}})});
  s.system.box = {10, 10, 10};
  return s;
}

void place(Simulation& sim, double r, double x0 = 5) {
  Field& x = sim.state().field(fields::position);
  x.acquire(Where::host, Mode::write);
  const double at[6] = {x0, 5, 5, 5 - r, 5, 5};
  for (int k = 0; k < 6; ++k) x.host<double>()[k] = at[k];
}

double separation(Simulation& sim) {
  const auto x = test::values(sim.state(), fields::position);
  double r2 = 0;
  for (int k = 0; k < 3; ++k) r2 += (x[k] - x[3 + k]) * (x[k] - x[3 + k]);
  return std::sqrt(r2);
}

// The message of the RunError that sim.run() throws ("" when it throws none).
std::string run_error(Simulation& sim) {
  try {
    sim.run();
  } catch (const RunError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("blow-up guard: a close pair halves Δt until the step is shorter than max_step", "[pair][rollback]") {
  const Backend b = GENERATE(from_range(test::backends()));
  INFO(to_string(b));
  Simulation sim(pair_spec(1e-5), registry(), test::dry(b));
  place(sim, 0.9);
  sim.advance();
  // F(0.9 σ) Δt = 0.92, 0.46, 0.23, 0.115 σ: rolled back; 0.058 σ at Δt/16: accepted.
  CHECK(sim.stats().rollbacks == 4);
  CHECK(sim.stats().dt == Approx(1e-5 / 16).epsilon(1e-12));
  // Both move apart by F Δt/16 = 0.058 σ, give or take the noise (sqrt(2 Δt/16) = 1.1e-3 σ).
  const double F = 72 * 14 / 0.9 * (2 * std::pow(0.9, -36) - std::pow(0.9, -18));
  CHECK(separation(sim) == Approx(0.9 + 2 * F * 1e-5 / 16).margin(0.01));
}

TEST_CASE("blow-up guard: an overlap no Δt above dt_min can resolve stops the run naming stage, step and particle",
          "[pair][rollback]") {
  const Backend b = GENERATE(from_range(test::backends()));
  INFO(to_string(b));
  Simulation sim(pair_spec(1e-3), registry(), test::dry(b));
  place(sim, 0.8);
  const std::string what = run_error(sim);
  INFO(what);
  CHECK_THAT(what, Catch::Contains("step 0: stage 'overdamped.integrate' requested a rollback") &&
                       Catch::Contains("farther than max_step") && Catch::Contains("dt_min") &&
                       Catch::Contains("particles involved: 0"));
  CHECK(sim.stats().rollbacks == 11);  // Δt/2 ... Δt/1024, then Δt/2048 would be below dt_min
}

TEST_CASE("blow-up guard: a non-finite force stops the run at once, naming stage, step, particle and field",
          "[pair][rollback]") {
  const Backend b = GENERATE(from_range(test::backends()));
  INFO(to_string(b));
  // ε = 10³⁰⁷: the prefactor 4nε = 7.2·10³⁰⁸ overflows to inf; along x inf·(2q² − q) = −inf, and
  // inf·0 = NaN across, so the force on either particle is (∓inf, NaN, NaN).
  Simulation sim(pair_spec(1e-5, 1e307), registry(), test::dry(b));
  place(sim, 1.2);
  const std::string what = run_error(sim);
  INFO(what);
  CHECK_THAT(what, Catch::Contains("stage 'overdamped.integrate' (overdamped.integrate), step 0: particle 0 has a "
                                   "non-finite `force` field") &&
                       Catch::Contains("nan") && Catch::Contains("1 other particle(s) too") &&
                       Catch::Contains("cannot mend"));
  CHECK(sim.stats().rollbacks == 0);
}

TEST_CASE("blow-up guard: a NaN position at the start of a step stops the run naming the particle", "[pair][rollback]") {
  const Backend b = GENERATE(from_range(test::backends()));
  INFO(to_string(b));
  // The integrator alone (a force stage would read the NaN first): particle 0 at x = NaN.
  auto s = test::spec(3, 2, 0.01, 3, 1e-5, {entry(registry(), "overdamped.integrate", {{"max_step", 0.1}})});
  s.system.box = {10, 10, 10};
  Simulation sim(s, registry(), test::dry(b));
  place(sim, 1.2, std::numeric_limits<double>::quiet_NaN());
  const std::string what = run_error(sim);
  INFO(what);
  CHECK_THAT(what, Catch::Contains("step 0: particle 0 has a non-finite position"));
  CHECK_THAT(what, !Catch::Contains("other particle"));
}
