// overdamped.integrate: per-type diffusion (MSD = 2·d·D_t·t per type), drift from `force`
// (μ_t F Δt per step) and from `velocity` + `force`, the max_step guard, and that the
// brownian.integrate and phoretic.integrate aliases are this stage; `noise: clamp` (Carter's
// clamped Gaussians, seed-gaps C2).
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "core/run/simulation.h"
#include "support/backends.h"
#include "support/spec.h"
#include "support/stage_driver.h"
#include "support/test_plugins.h"
#include "support/fields.h"

using namespace ff;

namespace {

// A state of n particles spread over a box, two types (even i: type 0, odd: type 1), and a
// constant field `name` = value per component (the force or velocity a model would write).
std::unique_ptr<State> state(int dim, std::size_t n, std::vector<std::pair<const char*, double>> constant) {
  auto s = std::make_unique<State>(dim, Precision::f64, n);
  for (int k = 0; k < dim; ++k) s->box.L[k] = 100;
  s->species = {"A", "B"};
  Field& x = s->field(fields::position);
  Field& t = s->field(fields::type);
  x.acquire(Where::host, Mode::write);
  t.acquire(Where::host, Mode::write);
  for (std::size_t i = 0; i < n; ++i) {
    t.host<std::int32_t>()[i] = std::int32_t(i % 2);
    for (int k = 0; k < dim; ++k) x.host<double>()[i * dim + k] = double((i * 7919 + k * 104729) % 10000) / 100.0;
  }
  for (auto& [name, value] : constant) {
    Field& f = s->add_particle_field(name, DType::f64, dim);
    f.acquire(Where::host, Mode::write);
    for (std::size_t i = 0; i < f.size(); ++i) f.host<double>()[i] = value;
  }
  return s;
}

const Registry& registry() {
  static const auto r = test::registry_with({"brownian", "phoretic"});
  return *r;
}

ParamValues params(std::map<std::string, ParamValue> set) {
  ParamValues v = ParamValues::defaults(registry().get("overdamped.integrate").decl.params);
  for (auto& kv : set) v.set(kv.first, kv.second);
  return v;
}

}  // namespace

TEST_CASE("overdamped.integrate: each type diffuses with its own D (MSD = 2·d·D_t·t within 3 standard errors)",
          "[overdamped][physics]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  INFO(to_string(b) << ", " << dim << "D");
  const std::size_t n = 1u << 14;
  const double D[2] = {0.25, 1.0}, dt = 0.01;
  const int steps = 40;
  auto s = state(dim, n, {});
  test::StageDriver drive(registry(), "overdamped.integrate", b, Precision::f64, dim,
                          params({{"D", std::vector<double>{D[0], D[1]}}}), 11);
  drive.stage->configure(*s);
  const auto u0 = test::unwrapped<double>(*s);
  for (int k = 0; k < steps; ++k) drive.step(*s, std::uint64_t(k), dt);
  const auto u1 = test::unwrapped<double>(*s);
  for (int type = 0; type < 2; ++type) {
    double m = 0, m2 = 0;
    std::size_t count = 0;
    for (std::size_t i = std::size_t(type); i < n; i += 2, ++count) {
      double d2 = 0;
      for (int k = 0; k < dim; ++k) d2 += std::pow(u1[i * dim + k] - u0[i * dim + k], 2);
      m += d2;
      m2 += d2 * d2;
    }
    m /= double(count);
    const double se = std::sqrt((m2 / double(count) - m * m) / double(count));
    const double want = 2 * dim * D[type] * steps * dt;
    INFO("type " << type << ": MSD " << m << " ± " << se << ", want " << want);
    CHECK(std::fabs(m - want) < 3 * se);
  }
}

TEST_CASE("overdamped.integrate: the drift is (v + μ_t F) Δt per step", "[overdamped]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = 2;
  const std::size_t n = 1000;
  const double mu[2] = {0.5, 2.0}, F = 0.3, v = -0.1, dt = 0.01;
  const int steps = 25;
  for (const char* drift : {"force", "velocity+force", "auto"}) {
    INFO(to_string(b) << ", drift: " << drift);
    const bool with_v = std::string(drift) != "force";
    auto s = with_v ? state(dim, n, {{"force", F}, {"velocity", v}}) : state(dim, n, {{"force", F}});
    test::StageDriver drive(registry(), "overdamped.integrate", b, Precision::f64, dim,
                            params({{"D", 0.0}, {"mobility", std::vector<double>{mu[0], mu[1]}},
                                    {"drift", std::string(drift)}}),
                            3);
    drive.stage->configure(*s);
    const auto u0 = test::unwrapped<double>(*s);
    for (int k = 0; k < steps; ++k) drive.step(*s, std::uint64_t(k), dt);
    const auto u1 = test::unwrapped<double>(*s);
    for (std::size_t i = 0; i < n; ++i)
      for (int k = 0; k < dim; ++k) {
        const double want = steps * ((with_v ? v : 0.0) + mu[i % 2] * F) * dt;
        REQUIRE(u1[i * dim + k] - u0[i * dim + k] == Approx(want).margin(1e-9));
      }
  }
}

// One step of noise alone in 2D with `noise` and max_step (0: the plain loop; > 0: the general
// one); the positions after it.
static std::vector<double> one_noise_step(Backend b, const char* noise, double max_step, std::size_t n, double D, double dt) {
  auto s = state(2, n, {});
  test::StageDriver drive(registry(), "overdamped.integrate", b, Precision::f64, 2,
                          params({{"D", D}, {"noise", std::string(noise)}, {"max_step", max_step}}), 21);
  drive.stage->configure(*s);
  drive.step(*s, 4, dt);
  return test::unwrapped<double>(*s);
}

TEST_CASE("overdamped.integrate noise: clamp is Carter's clamped Gaussian: |ξ| ≤ 3 with point masses at ±3, "
          "variance 0.99501; CPU = CUDA",
          "[overdamped]") {
  const std::size_t n = 1u << 18;
  const double D = 0.5, dt = 0.01, a = std::sqrt(2 * D * dt);  // amplitude 0.1
  const auto x0 = test::unwrapped<double>(*state(2, n, {}));
  for (double max_step : {0.0, 10.0}) {
    INFO("max_step " << max_step << (max_step > 0 ? " (general loop)" : " (plain loop)"));
    const auto x = one_noise_step(Backend::cpu, "clamp", max_step, n, D, dt);
    const auto r = one_noise_step(Backend::cpu, "rescaled", max_step, n, D, dt);
    double m2 = 0, largest = 0, largest_rescaled = 0;
    std::size_t at_edge = 0;
    for (std::size_t j = 0; j < x.size(); ++j) {
      const double z = (x[j] - x0[j]) / a;
      m2 += z * z;
      largest = std::max(largest, std::fabs(z));
      largest_rescaled = std::max(largest_rescaled, std::fabs(r[j] - x0[j]) / a);
      at_edge += std::fabs(std::fabs(z) - 3) < 1e-9;
    }
    m2 /= double(x.size());
    CHECK(largest < 3 + 1e-9);
    CHECK(largest_rescaled > 3.01);  // the rescaled variant reaches 3·1.0136
    // P(|ξ| > 3) = 0.0027 (about 1400 of 2^19: 3 % standard error); variance within 5 standard errors.
    CHECK(double(at_edge) / double(x.size()) == Approx(0.0026998).epsilon(0.15));
    CHECK(std::fabs(m2 - 0.995007) < 5 * std::sqrt(1.9 / double(x.size())));
    if (test::have_cuda("overdamped.integrate noise: clamp, CPU = CUDA bits")) {
      const auto g = one_noise_step(Backend::cuda, "clamp", max_step, n, D, dt);
      std::size_t differ = 0;
      for (std::size_t j = 0; j < x.size(); ++j) differ += std::memcmp(&x[j], &g[j], sizeof(double)) != 0;
      CHECK(differ == 0);
    }
  }
}

TEST_CASE("overdamped.integrate: a step longer than max_step asks for a rollback naming the particle",
          "[overdamped]") {
  const Backend b = GENERATE(from_range(test::backends()));
  auto s = state(2, 500, {{"force", 0.0}});
  // Particle 0's force is large: it alone moves 2 σ in a step of 0.01.
  Field& f = s->field("force");
  f.acquire(Where::host, Mode::write);
  f.host<double>()[0] = 200.0;
  test::StageDriver drive(registry(), "overdamped.integrate", b, Precision::f64, 2,
                          params({{"D", 0.0}, {"max_step", 0.5}}), 3);
  drive.stage->configure(*s);
  CHECK(drive.stage->scheduling().may_request_rollback);
  CHECK_FALSE(drive.stage->scheduling().graph_capturable);
  const Outcome o = drive.run(*s, 0, 0.01);
  REQUIRE(o.rollback);
  CHECK(o.reason.find("max_step") != std::string::npos);
  REQUIRE(o.particles.size() == 1);
  CHECK(o.particles[0] == 0);
  // At a quarter of the time step particle 0 moves 0.5 σ, which does not exceed max_step.
  CHECK_FALSE(drive.run(*s, 0, 0.0025).rollback);
}

TEST_CASE("brownian.integrate and phoretic.integrate are overdamped.integrate configurations", "[overdamped]") {
  const auto& r = registry();
  CHECK(r.get("brownian.integrate").decl.summary.find("= overdamped.integrate with drift: none") != std::string::npos);
  CHECK(r.get("phoretic.integrate").decl.summary.find("drift: velocity") != std::string::npos);
  // phoretic.integrate keeps its old default D = 0.01; drift is fixed, not a parameter.
  for (auto& p : r.get("phoretic.integrate").decl.params) {
    CHECK(p.name != "drift");
    if (p.name == "D") CHECK(std::get<std::vector<double>>(*p.default_value) == std::vector<double>{0.01});
  }
}

TEST_CASE("overdamped.integrate: max_step in a run rolls steps back until they are short enough",
          "[overdamped][rollback]") {
  // Through the core (its StepParams on each backend, the rollback snapshot): sqrt(2 D Δt) = 0.32
  // per component at Δt = 0.05, so max_step = 0.3 needs a smaller Δt on most steps.
  const Backend b = GENERATE(from_range(test::backends()));
  INFO(to_string(b));
  const auto& r = registry();
  auto s = test::spec(2, 1024, 0.1, 20, 0.05,
                      {test::entry(r, "overdamped.integrate", {{"D", 1.0}, {"max_step", 0.3}})}, 5);
  s.run.dt_min = 1e-6;
  Simulation sim(s, r, test::dry(b));
  const auto u0 = test::unwrapped<double>(sim.state());
  for (int k = 0; k < 20; ++k) sim.advance();
  const auto u1 = test::unwrapped<double>(sim.state());
  CHECK(sim.stats().rollbacks > 0);
  CHECK(sim.state().time < 20 * 0.05);
  double longest = 0;
  for (std::size_t i = 0; i + 1 < u0.size(); i += 2)
    longest = std::max(longest, std::hypot(u1[i] - u0[i], u1[i + 1] - u0[i + 1]));
  CHECK(longest > 0);
}
