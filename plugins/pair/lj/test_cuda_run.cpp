// A whole run of issue 16's step (neighbors.verlet, pair.lj, overdamped.integrate with max_step)
// gives the same bits on CUDA as on the CPU, step by step. On CUDA overdamped.integrate answers
// neighbors.verlet's rebuild test in its own kernel and neighbors.verlet takes that answer in the
// next step (neighbors.moved, stages/neighbors/list.h); what could go wrong there — an answer for
// positions that a later write or a rollback changed — shows as a rebuild on another step than
// the CPU's (the metric) or as other forces, and from there other positions. The run is made to
// roll back (Δt = 2e-4 moves a pair at contact by 0.2 σ > max_step = 0.1 σ) and to rebuild often.
#include <catch2/catch.hpp>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "core/run/simulation.h"
#include "support/backends.h"
#include "support/spec.h"
#include "support/test_plugins.h"
#include "stages/neighbors/verlet/kernel.h"

using namespace ff;
using test::entry;

namespace {

const Registry& registry() {
  static const auto r = test::registry_with({"pair"});
  return *r;
}

struct Trace {
  std::vector<std::map<std::string, double>> metrics;  // per step
  std::vector<double> dt;
  std::vector<std::uint64_t> rollbacks;
  std::map<std::string, std::vector<unsigned char>> fields;  // at the end
};

Trace run(Backend b) {
  auto spec = test::spec(3, 2000, 0.15, 1000, 2e-4,
                         {entry(registry(), "neighbors.verlet", {{"cutoff", 1.5}, {"skin", 0.3}}),
                          entry(registry(), "pair.lj",
                                {{"epsilon", std::vector<double>{14}}, {"n", std::int64_t(18)}, {"r_cut", 1.5},
                                 {"energy", true}}),
                          entry(registry(), "overdamped.integrate", {{"max_step", 0.1}})});
  Simulation sim(spec, registry(), test::dry(b));
  Trace t;
  for (std::uint64_t k = 0; k < spec.run.steps; ++k) {
    sim.advance();
    t.metrics.push_back(sim.stats().metrics);
    t.dt.push_back(sim.stats().dt);
    t.rollbacks.push_back(sim.stats().rollbacks);
  }
  sim.synchronize();
  for (const char* name : {fields::position, fields::image, "force", "pair.energy", "neighbors.list",
                           "neighbors.position_at_build"}) {
    Field& f = sim.state().field(name);
    f.acquire(Where::host, Mode::read);
    const auto* p = static_cast<const unsigned char*>(f.host_raw());
    t.fields[name].assign(p, p + f.bytes());
  }
  return t;
}

}  // namespace

TEST_CASE("pair.lj with neighbors.verlet and max_step: CUDA gives the CPU's bits every step, rebuilds and rollbacks "
          "included",
          "[pair][cuda][rollback]") {
  const Trace c = run(Backend::cpu);
  // What the run goes through (else the comparison proves little).
  double rebuilds = 0;
  for (const auto& m : c.metrics) rebuilds += m.at("neighbors.verlet/rebuilds");
  INFO("rebuilds " << rebuilds << ", rollbacks " << c.rollbacks.back());
  CHECK(rebuilds >= 10);
  CHECK(c.rollbacks.back() >= 1);
  if (!test::have_cuda("the lj step's CPU vs CUDA run")) return;
  const Trace g = run(Backend::cuda);
  REQUIRE(c.metrics.size() == g.metrics.size());
  for (std::size_t k = 0; k < c.metrics.size(); ++k) {
    INFO("step " << k);
    REQUIRE(c.metrics[k] == g.metrics[k]);
    REQUIRE(c.dt[k] == g.dt[k]);
    REQUIRE(c.rollbacks[k] == g.rollbacks[k]);
  }
  for (const auto& kv : c.fields) {
    INFO(kv.first);
    const auto& other = g.fields.at(kv.first);
    REQUIRE(kv.second.size() == other.size());
    CHECK(std::memcmp(kv.second.data(), other.data(), other.size()) == 0);
  }
}

// On either backend overdamped.integrate (with max_step) answers neighbors.verlet's rebuild test
// for the positions it wrote (neighbors.moved), and neighbors.verlet takes that answer instead
// of testing itself. Checked against the test made here, after every accepted step, on the
// fields themselves (neighbors.verlet's own functor on position and position_at_build): the
// next step rebuilds exactly when some particle is then farther than skin/2 from its position
// at the build — rolled-back attempts included, which must not leave their answer behind.
TEST_CASE("overdamped.integrate's answer to the Verlet rebuild test is the test made on the accepted positions",
          "[pair][verlet][rollback]") {
  const Backend b = GENERATE(from_range(test::backends()));
  INFO(to_string(b));
  const double skin = 0.3;
  auto spec = test::spec(3, 2000, 0.15, 600, 2e-4,
                         {entry(registry(), "neighbors.verlet", {{"cutoff", 1.5}, {"skin", skin}}),
                          entry(registry(), "pair.lj",
                                {{"epsilon", std::vector<double>{14}}, {"n", std::int64_t(18)}, {"r_cut", 1.5}}),
                          entry(registry(), "overdamped.integrate", {{"max_step", 0.1}})});
  Simulation sim(spec, registry(), test::dry(b));
  auto host = [&](const char* name) {
    Field& f = sim.state().field(name);
    f.acquire(Where::host, Mode::read);
    return f.host<double>();
  };
  int expected = -1, rebuilds = 0, agreed = 0;
  std::uint64_t rollbacks = 0;
  for (std::uint64_t k = 0; k < spec.run.steps; ++k) {
    sim.advance();
    sim.synchronize();
    const int rebuilt = int(sim.stats().metrics.at("neighbors.verlet/rebuilds"));
    INFO("step " << k);
    if (expected >= 0) {
      REQUIRE(rebuilt == expected);
      ++agreed;
    }
    rebuilds += rebuilt;
    const neighbors::MovedTooFar<double, 3> test{host(fields::position), host("neighbors.position_at_build"),
                                                  PeriodicBox<double>::make(sim.state().box.L),
                                                  (0.5 * skin) * (0.5 * skin)};
    expected = 0;
    for (std::size_t i = 0; i < sim.state().n(); ++i) expected |= int(test(i));
    rollbacks = sim.stats().rollbacks;
  }
  // What the run went through (else the agreement proves little).
  INFO("rebuilds " << rebuilds << ", rollbacks " << rollbacks);
  CHECK(rebuilds >= 5);
  CHECK(rollbacks >= 1);
  CHECK(agreed == int(spec.run.steps) - 1);
}
