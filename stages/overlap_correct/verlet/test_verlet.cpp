// overlap_correct.verlet: no pair left closer than σ_ij(1 − tol) after the stage (brute force) in
// 2D up to η = 0.8 and 3D up to η = 0.5, equal and unequal diameters, with the list rebuilt
// within the step when the pushes moved a particle past skin/2; in 2D the same bits as
// overlap_correct (Delaunay) over 10³ steps of brownian hard disks; the same bits for 1 and 2
// threads and on CUDA; errors that name what to change. Pipelines are built without YAML
// (support/spec.h).
#include <oneapi/tbb/global_control.h>

#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "core/base/error.h"
#include "core/input/init.h"
#include "core/run/simulation.h"
#include "support/backends.h"
#include "support/fields.h"
#include "support/spec.h"
#include "support/test_plugins.h"

using namespace ff;
using ff::test::positions;
using ff::test::dry;
using ff::test::entry;

namespace {

const Registry& registry() {
  static const auto r = test::registry_with({"brownian"});
  return *r;
}

std::vector<double> diameters(State& s) {
  Field& f = s.field(fields::diameter);
  f.acquire(Where::host, Mode::read);
  std::vector<double> d(s.n());
  for (std::size_t i = 0; i < s.n(); ++i)
    d[i] = s.precision() == Precision::f64 ? f.host<double>()[i] : double(f.host<float>()[i]);
  return d;
}

// Smallest r_ij / σ_ij over all pairs (minimum image, brute force).
double min_gap(State& s) {
  const auto x = positions(s);
  const auto d = diameters(s);
  const int dim = s.dim();
  double worst = HUGE_VAL;
  for (std::size_t i = 0; i < s.n(); ++i)
    for (std::size_t j = i + 1; j < s.n(); ++j) {
      double r2 = 0;
      for (int k = 0; k < dim; ++k) {
        double dk = x[dim * j + k] - x[dim * i + k];
        dk -= s.box.L[k] * std::rint(dk / s.box.L[k]);
        r2 += dk * dk;
      }
      worst = std::min(worst, std::sqrt(r2) / (0.5 * (d[i] + d[j])));
    }
  return worst;
}

// Uniform random positions (seeded): an ideal gas, overlapping everywhere.
void scatter(State& s, std::uint64_t seed) {
  Field& f = s.field(fields::position);
  f.acquire(Where::host, Mode::write);
  std::mt19937_64 gen(seed);
  for (std::size_t i = 0; i < f.size(); ++i) {
    const double L = s.box.L[i % std::size_t(s.dim())];
    const double x = std::min(std::uniform_real_distribution<double>(0, L)(gen), std::nextafter(L, 0.0));
    if (s.precision() == Precision::f64)
      f.host<double>()[i] = x;
    else
      f.host<float>()[i] = std::min(float(x), std::nextafter(float(L), 0.0f));
  }
}

double metric(const Simulation& sim, const std::string& m) {
  auto it = sim.stats().metrics.find("overlap_correct.verlet/" + m);
  REQUIRE(it != sim.stats().metrics.end());
  return it->second;
}

// neighbors.verlet + overlap_correct.verlet (one step of the pair, no integrator).
PipelineSpec correct_spec(int dim, std::uint64_t n, double eta, double skin,
                          const std::map<std::string, ParamValue>& params = {}, Precision p = Precision::f64) {
  const Registry& r = registry();
  auto s = test::spec(dim, n, eta, 1, 0.01,
                      {entry(r, "neighbors.verlet", {{"cutoff", 1.0}, {"skin", skin}}),
                       entry(r, "overlap_correct.verlet", params)},
                      3, p);
  s.system.init = dim == 2 ? "triangular_lattice_sample" : "lattice_sample";  // scattered by the tests
  return s;
}

// Brownian hard disks or spheres: integrate, then the overlap correction of `variant`
// ("delaunay": the maintained triangulation and overlap_correct; "verlet": neighbors.verlet and
// overlap_correct.verlet).
PipelineSpec brownian_spec(int dim, std::uint64_t n, double eta, std::uint64_t steps, double dt,
                           const std::string& variant) {
  const Registry& r = registry();
  std::vector<StepEntry> step{entry(r, "brownian.integrate", {{"D", 1.0}})};
  if (variant == "delaunay") {
    for (const char* st : {"delaunay.detect_inversion", "delaunay.flip", "delaunay.lawson", "overlap_correct"})
      step.push_back(entry(r, st));
  } else {
    step.push_back(entry(r, "neighbors.verlet", {{"cutoff", 1.0}, {"skin", 0.3}}));
    step.push_back(entry(r, "overlap_correct.verlet"));
  }
  auto s = test::spec(dim, n, eta, steps, dt, std::move(step), 42);
  s.system.init = dim == 2 ? "triangular_lattice_sample" : "lattice_sample";
  return s;
}

}  // namespace

TEST_CASE("overlap_correct.verlet: no pair closer than σ(1 − tol) after random starts, 2D η ≤ 0.8, 3D η ≤ 0.5",
          "[overlap][verlet][physics]") {
  // Uniform random positions overlap everywhere (most particles by more than half a diameter at
  // η = 0.5); the pushes move them much farther than skin/2, so the list is rebuilt within the
  // step and the loop runs again. Bidisperse: diameters 0.8σ and 1.2σ, half each (the cutoff is
  // the largest diameter).
  struct Case {
    int dim;
    double eta;
    bool bidisperse;
    const char* mode;
  };
  const Case cases[] = {{2, 0.5, false, "reflect"}, {2, 0.8, false, "reflect"}, {2, 0.6, true, "reflect"},
                        {2, 0.5, false, "contact"}, {3, 0.3, false, "reflect"}, {3, 0.5, false, "reflect"},
                        {3, 0.4, true, "reflect"}, {3, 0.3, false, "contact"}};
  const Backend backend = GENERATE(from_range(test::backends()));
  for (const Case& c : cases) {
    auto spec = correct_spec(c.dim, c.dim == 2 ? 2000 : 3000, c.eta, 0.3,
                             {{"mode", std::string(c.mode)}, {"max_iterations", std::int64_t(100000)}});
    if (c.bidisperse) {
      spec.system.types = {SpeciesSpec{"A", 0.5, 0.8}, SpeciesSpec{"B", 0.5, 1.2}};
      spec.step[0].params.set("cutoff", 1.2);
    }
    auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
    scatter(*state, 5);
    const double before = min_gap(*state);
    Simulation sim(spec, registry(), dry(backend), std::move(state));
    sim.advance();
    const double after = min_gap(sim.state());
    INFO(to_string(backend) << ", " << c.dim << "D η " << c.eta << (c.bidisperse ? " bidisperse " : " ") << c.mode
                            << ": min r/σ_ij " << before << " -> " << after << ", iterations "
                            << metric(sim, "iterations") << ", list rebuilds " << metric(sim, "list_rebuilds"));
    REQUIRE(before < 0.2);
    CHECK(after >= 1 - 1e-6);
    CHECK(metric(sim, "list_rebuilds") >= 1);
    CHECK(metric(sim, "pairs") >= 1);
  }
}

TEST_CASE("overlap_correct.verlet: 2D brownian hard disks give the same bits as overlap_correct (Delaunay)",
          "[overlap][verlet][determinism]") {
  // 10³ steps at η = 0.5 from a lattice sample (no overlaps), Δt = 3e-4: every overlap a step
  // makes is far below 0.29σ, so every overlapping pair is a Gabriel edge of the triangulation
  // (Delaunay for the positions before the correction) and both variants push the same pairs
  // by the same bits (fixed-point sums). A rolled-back step would change Δt in one run only.
  const Backend backend = GENERATE(from_range(test::backends()));
  INFO(to_string(backend));
  const std::uint64_t steps = 1000;
  auto run = [&](const std::string& variant, double& iterations) {
    Simulation sim(brownian_spec(2, 2000, 0.5, steps, 3e-4, variant), registry(), dry(backend));
    iterations = 0;
    for (std::uint64_t k = 0; k < steps; ++k) {
      sim.advance();
      const std::string name = variant == "delaunay" ? "overlap_correct/iterations" : "overlap_correct.verlet/iterations";
      iterations += sim.stats().metrics.at(name);
    }
    REQUIRE(sim.stats().rollbacks == 0);
    return positions(sim.state());
  };
  double it_delaunay = 0, it_verlet = 0;
  const auto a = run("delaunay", it_delaunay);
  const auto b = run("verlet", it_verlet);
  INFO("iterations over the run: Delaunay " << it_delaunay << ", Verlet " << it_verlet);
  CHECK(it_delaunay > steps / 2);  // the correction had work to do
  CHECK(it_verlet == it_delaunay);
  REQUIRE(a.size() == b.size());
  std::size_t first = a.size();
  for (std::size_t i = 0; i < a.size() && first == a.size(); ++i)
    if (std::memcmp(&a[i], &b[i], sizeof(double)) != 0) first = i;
  INFO("first differing coordinate: " << first << " of " << a.size());
  CHECK(first == a.size());
}

TEST_CASE("overlap_correct.verlet: bit-identical results for 1 and 2 threads, and CPU vs CUDA (double)",
          "[overlap][verlet][determinism]") {
  // 3D brownian hard spheres at η = 0.4 for 200 steps from a lattice sample.
  auto run = [](Backend b, int threads) {
    tbb::global_control gc(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
    Simulation sim(brownian_spec(3, 2000, 0.4, 200, 1e-3, "verlet"), registry(), dry(b));
    for (int k = 0; k < 200; ++k) sim.advance();
    return positions(sim.state());
  };
  const auto one = run(Backend::cpu, 1);
  const auto two = run(Backend::cpu, 2);
  REQUIRE(one.size() == two.size());
  CHECK(std::memcmp(one.data(), two.data(), one.size() * sizeof(double)) == 0);
  if (!test::have_cuda("overlap_correct.verlet CPU vs CUDA")) return;
  const auto gpu = run(Backend::cuda, 2);
  REQUIRE(gpu.size() == one.size());
  CHECK(std::memcmp(one.data(), gpu.data(), one.size() * sizeof(double)) == 0);
}

TEST_CASE("overlap_correct.verlet: errors name what to change", "[overlap][verlet][errors]") {
  const Registry& r = registry();
  SECTION("no Verlet list before it") {
    auto s = test::spec(3, 100, 0.3, 1, 0.01, {entry(r, "overlap_correct.verlet")});
    CHECK_THROWS_WITH(Simulation(s, r, dry()), Catch::Contains("put neighbors.verlet before it"));
  }
  SECTION("a cutoff below the largest diameter") {
    auto s = correct_spec(3, 100, 0.3, 0.3);
    s.step[0].params.set("cutoff", 0.9);
    CHECK_THROWS_WITH(Simulation(s, r, dry()), Catch::Contains("set its cutoff to at least 1"));
  }
  SECTION("max_iterations reached") {
    auto s = correct_spec(3, 1000, 0.5, 0.3, {{"max_iterations", std::int64_t(2)}});
    auto state = make_initial_state(s.system, s.run.precision, s.run.seed);
    scatter(*state, 5);
    Simulation sim(s, r, dry(), std::move(state));
    CHECK_THROWS_WITH(sim.advance(), Catch::Contains("after max_iterations = 2 iterations") &&
                                         Catch::Contains("Lower run.dt"));
  }
}
