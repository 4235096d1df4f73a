// overlap_correct: exact two-particle moves (reflect, contact, cap), no overlaps left after
// correcting random overlaps up to packing fraction 0.8, bounded iterations, errors, bit-identical
// results for 1/2/4 threads and CPU vs CUDA. Pipelines are built without YAML (support/spec.h):
// delaunay.build triangulates, overlap_correct corrects.
#include <oneapi/tbb/global_control.h>

#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "core/backend/device.h"
#include "core/base/error.h"
#include "core/input/init.h"
#include "core/physics/rng.h"
#include "core/run/simulation.h"
#include "stages/overlap_correct/kernel.h"
#include "stages/overlap_correct/params.h"
#include "stages/delaunay/common/fields.h"
#include "support/backends.h"
#include "support/cli.h"
#include "support/pipeline.h"
#include "support/spec.h"
#include "support/stage_driver.h"
#include "support/test_plugins.h"

using namespace ff;
using ff::test::dry;
using ff::test::entry;

namespace {

const Registry& registry() {
  static const auto r = test::registry_with({});
  return *r;
}

PipelineSpec correct_spec(std::uint64_t n, double eta, const std::map<std::string, ParamValue>& params = {},
                          Precision p = Precision::f64) {
  const Registry& r = registry();
  auto s = test::spec(2, n, eta, 1, 0.01, {entry(r, "delaunay.build"), entry(r, "overlap_correct", params)}, 3, p);
  s.system.init = "triangular_lattice_sample";
  return s;
}

template <class R>
std::vector<double> positions(State& s) {
  Field& f = s.field(fields::position);
  f.acquire(Where::host, Mode::read);
  return std::vector<double>(f.host<R>(), f.host<R>() + f.size());
}

std::vector<double> positions(State& s) {
  return s.precision() == Precision::f64 ? positions<double>(s) : positions<float>(s);
}

template <class R>
void set_positions(State& s, const std::vector<double>& xy) {
  Field& f = s.field(fields::position);
  f.acquire(Where::host, Mode::write);
  for (std::size_t i = 0; i < xy.size(); ++i) {
    const double L = s.box.L[i % 2];
    double x = xy[i] - L * std::floor(xy[i] / L);
    if (x >= L) x -= L;
    f.host<R>()[i] = R(x);
  }
}

void set_positions(State& s, const std::vector<double>& xy) {
  if (s.precision() == Precision::f64)
    set_positions<double>(s, xy);
  else
    set_positions<float>(s, xy);
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
  const auto xy = positions(s);
  const auto d = diameters(s);
  const double L0 = s.box.L[0], L1 = s.box.L[1];
  double worst = HUGE_VAL;
  for (std::size_t i = 0; i < s.n(); ++i)
    for (std::size_t j = i + 1; j < s.n(); ++j) {
      double dx = xy[2 * j] - xy[2 * i], dy = xy[2 * j + 1] - xy[2 * i + 1];
      dx -= L0 * std::rint(dx / L0);
      dy -= L1 * std::rint(dy / L1);
      worst = std::min(worst, std::sqrt(dx * dx + dy * dy) / (0.5 * (d[i] + d[j])));
    }
  return worst;
}

// Every particle displaced by a Gaussian of `amplitude` per component (seeded): random overlaps.
void jiggle(State& s, double amplitude, std::uint64_t seed) {
  auto xy = positions(s);
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> g(0.0, amplitude);
  for (auto& x : xy) x += g(gen);
  set_positions(s, xy);
}

// Uniform random positions: an ideal gas, overlapping everywhere.
void scatter(State& s, std::uint64_t seed) {
  std::vector<double> xy(2 * s.n());
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (std::size_t i = 0; i < xy.size(); ++i) xy[i] = u(gen) * s.box.L[i % 2];
  set_positions(s, xy);
}

double metric(const Simulation& sim, const std::string& m) {
  auto it = sim.stats().metrics.find("overlap_correct/" + m);
  REQUIRE(it != sim.stats().metrics.end());
  return it->second;
}

// A triangulated state: the lattice sample of correct_spec, `before` applied to it, then
// delaunay.build run once, then `after` applied.
template <class Before, class After>
std::unique_ptr<Simulation> triangulated(std::uint64_t n, double eta, Before before, After after) {
  const Registry& r = registry();
  auto s = test::spec(2, n, eta, 1, 0.01, {entry(r, "delaunay.build")}, 3);
  s.system.init = "triangular_lattice_sample";
  auto state = make_initial_state(s.system, s.run.precision, s.run.seed);
  before(*state);
  auto sim = std::make_unique<Simulation>(s, r, dry(), std::move(state));
  sim->advance();
  after(sim->state());
  return sim;
}

// overlap_correct driven alone on a triangulated state, as the scheduler would.
test::StageDriver corrector(State& s, Backend b, const std::map<std::string, ParamValue>& params = {}) {
  auto v = ParamValues::defaults(registry().get("overlap_correct").decl.params);
  for (auto& kv : params) v.set(kv.first, kv.second);
  test::StageDriver d(registry(), "overlap_correct", b, Precision::f64, 2, v, 1);
  d.stage->configure(s);
  return d;
}

// The stage's definition, naively: every iteration gathers every particle (Overlaps::gather, the
// fan walk in fan order), then applies every displacement, until no pair overlaps beyond the
// tolerance. The stage's loops (edge passes, work lists, GPU) must give these bits.
struct Reference {
  std::vector<double> xy;
  double iterations = 0, pairs = 0;
};
// unit: the stage's length unit, the largest diameter when it was configured (0: the largest now).
Reference reference(State& s, double factor, double cap, double tol, double unit = 0) {
  const std::size_t n = s.n();
  Reference out{positions(s)};
  Field& img = s.field(fields::image);
  img.acquire(Where::host, Mode::read);
  std::vector<std::int32_t> image(img.host<std::int32_t>(), img.host<std::int32_t>() + 2 * n);
  for (const char* f : {fields::diameter, delaunay::fields::halfedge, delaunay::fields::vertex_edge})
    s.field(f).acquire(Where::host, Mode::read);
  const auto diam = diameters(s);
  const double dmax = *std::max_element(diam.begin(), diam.end());
  if (unit == 0) unit = dmax;
  const overlap::Overlaps<double> m{{PeriodicBox<double>::make(s.box.L), factor, cap, tol, 1.0 / unit},
                                    out.xy.data(),
                                    s.field(fields::diameter).host<double>(),
                                    s.field(delaunay::fields::halfedge).host<std::int32_t>(),
                                    s.field(delaunay::fields::vertex_edge).host<std::int32_t>(),
                                    std::int32_t(n),
                                    dmax * dmax};
  std::vector<double> d(2 * n);
  for (;;) {
    std::uint64_t bad = 0, pairs = 0, broken = 0;
    for (std::size_t v = 0; v < n; ++v) {
      const auto q = m.gather(int(v));
      broken += q.broken;
      d[2 * v] = q.dx;
      d[2 * v + 1] = q.dy;
      bad += q.bad;
      pairs += q.pairs;
    }
    REQUIRE(broken == 0);
    if (!bad) return out;
    out.pairs += double(pairs);
    ++out.iterations;
    for (std::size_t v = 0; v < n; ++v)
      overlap::apply_one(out.xy.data(), image.data(), m.box, v, d[2 * v], d[2 * v + 1]);
  }
}

// Particles whose fan has more than `degree` neighbours (host copy of the triangulation).
std::size_t vertices_with_degree_above(State& s, int degree) {
  for (const char* f : {fields::position, fields::diameter, delaunay::fields::halfedge, delaunay::fields::vertex_edge})
    s.field(f).acquire(Where::host, Mode::read);
  const std::size_t n = s.n();
  const overlap::Overlaps<double> m{{PeriodicBox<double>::make(s.box.L), 1.0, 0.25, 1e-6, 1.0},
                                    s.field(fields::position).host<double>(),
                                    s.field(fields::diameter).host<double>(),
                                    s.field(delaunay::fields::halfedge).host<std::int32_t>(),
                                    s.field(delaunay::fields::vertex_edge).host<std::int32_t>(),
                                    std::int32_t(n),
                                    1.0};
  std::size_t count = 0;
  for (std::size_t v = 0; v < n; ++v) {
    int k = 0;
    REQUIRE(m.for_each_neighbor(int(v), [&](int, int) { ++k; }));
    count += k > degree;
  }
  return count;
}

}  // namespace

TEST_CASE("overlap_correct: the same bits as gathering every particle in every iteration",
          "[overlap][determinism]") {
  // Dense jiggles (edge passes, then work lists), and an ideal gas (many particles with three
  // or more overlapping edges, whose sum needs the fan order).
  const Backend backend = GENERATE(from_range(test::backends()));
  struct Case {
    double eta, amplitude;  // amplitude 0: uniform random positions
    const char* mode;
    double cap;
  };
  const Case cases[] = {{0.75, 0.1, "reflect", 0.25}, {0.5, 0.15, "reflect", 0.25}, {0.8, 0.1, "contact", 0.25},
                        {0.7, 0.1, "reflect", 1.0},   {0.5, 0.0, "reflect", 0.25}, {0.3, 0.0, "contact", 0.25}};
  for (const Case& c : cases) {
    INFO(to_string(backend) << ": η " << c.eta << " jiggle " << c.amplitude << " " << c.mode << " cap " << c.cap);
    auto sim = triangulated(
        20000, c.eta,
        [&](State& s) {
          if (c.amplitude > 0)
            jiggle(s, c.amplitude, 7);
          else
            scatter(s, 8);
        },
        [](State&) {});
    State& s = sim->state();
    const Reference ref = reference(s, std::string(c.mode) == "contact" ? 0.5 : 1.0, c.cap, 1e-6);
    if (c.amplitude == 0) {
      // The CUDA loop keeps up to 8 neighbours a particle in a per-step list and walks the fan of
      // any particle with more (cuda.cu): the ideal gas must have such particles, so that this
      // test compares that path too.
      const std::size_t many = vertices_with_degree_above(s, 8);
      INFO(many << " particles with more than 8 neighbours");
      CHECK(many > 0);
    }
    auto d = corrector(s, backend, {{"mode", std::string(c.mode)}, {"cap", c.cap}});
    d.step(s, 0, 0.01);
    const auto xy = positions(s);
    INFO("iterations " << ref.iterations << ", pairs " << ref.pairs);
    CHECK(ref.iterations >= 3);
    CHECK(d.metric("iterations") == ref.iterations);
    CHECK(d.metric("pairs") == ref.pairs);
    CHECK(std::memcmp(xy.data(), ref.xy.data(), xy.size() * sizeof(double)) == 0);
  }
}

TEST_CASE("overlap_correct: unequal diameters, also when they change between steps", "[overlap][determinism]") {
  // Diameters 0.7-1.3σ; then every diameter grows by 10 % (a write to the field) and the next
  // step must see the new ones (the edge passes look no farther than the largest diameter).
  const Backend backend = GENERATE(from_range(test::backends()));
  INFO(to_string(backend));
  auto set_diameters = [](State& s, double scale) {
    Field& f = s.field(fields::diameter);
    f.acquire(Where::host, Mode::readwrite);
    std::mt19937_64 gen(9);
    std::uniform_real_distribution<double> u(0.7, 1.3);
    for (std::size_t i = 0; i < s.n(); ++i) f.host<double>()[i] = scale * u(gen);
  };
  auto sim = triangulated(
      20000, 0.6,
      [&](State& s) {
        set_diameters(s, 1.0);
        jiggle(s, 0.1, 3);
      },
      [](State&) {});
  State& s = sim->state();
  auto d = corrector(s, backend);
  const auto d0 = diameters(s);
  const double unit = *std::max_element(d0.begin(), d0.end());
  for (double scale : {1.0, 1.1}) {
    INFO("diameters x " << scale);
    set_diameters(s, scale);
    const Reference ref = reference(s, 1.0, 0.25, 1e-6, unit);
    d.step(s, scale == 1.0 ? 0 : 1, 0.01);
    const auto xy = positions(s);
    CHECK(ref.iterations >= 2);
    CHECK(d.metric("iterations") == ref.iterations);
    CHECK(d.metric("pairs") == ref.pairs);
    CHECK(std::memcmp(xy.data(), ref.xy.data(), xy.size() * sizeof(double)) == 0);
  }
}

TEST_CASE("overlap_correct: a corrupt triangulation is an error, also away from any overlap", "[overlap][errors]") {
  // A lattice at η = 0.3 has no overlaps; each corruption below is one half-edge record. The
  // CUDA loop (a walk around every particle in iteration 0, no edge pass) finds a corrupt mesh
  // by fans that do not close or indices out of range; a next pointer duplicated where every
  // walk still closes is found only by the CPU's edge pass (its permutation check).
  const Backend backend = GENERATE(from_range(test::backends()));
  struct Case {
    const char* what;
    int field;  // 0: origin, 1: next
    int value;  // -1: out of range; -2: the next of another half-edge; -3: the edge's other end
    bool cpu_only;
  };
  const Case cases[] = {{"origin out of range", 0, -1, false},
                        {"next out of range", 1, -1, false},
                        {"next not a permutation", 1, -2, true},
                        {"loop edge", 0, -3, false}};
  for (const Case& c : cases) {
    if (c.cpu_only && backend != Backend::cpu) continue;
    INFO(to_string(backend) << ": " << c.what);
    auto sim = triangulated(2000, 0.3, [](State&) {}, [&](State& s) {
      Field& f = s.field(delaunay::fields::halfedge);
      f.acquire(Where::host, Mode::readwrite);
      std::int32_t* he = f.host<std::int32_t>();
      const std::size_t h = 2 * 1234;  // edge 1234's first half-edge
      he[2 * h + c.field] = c.value == -1   ? std::int32_t(6 * s.n() + 5)
                            : c.value == -2 ? he[2 * (h + 10) + 1]
                                            : he[2 * (h + 1)];
    });
    State& s = sim->state();
    auto d = corrector(s, backend);
    try {
      d.run(s, 0, 0.01);  // returns the outcome; a throw propagates (step() would report it)
      FAIL("expected a RunError");
    } catch (const RunError& e) {
      const std::string m = e.what();
      INFO(m);
      CHECK(m.find("corrupt") != std::string::npos);
    }
  }
}

TEST_CASE("overlap_correct: exact moves of an isolated overlapping pair", "[overlap]") {
  // 64 particles on a lattice at η = 0.05 (spacing ≈ 4.3σ); particle b is put next to particle
  // a along x, both on a grid of 1/64, so every number below is exact in double.
  struct Case {
    const char* mode;
    double cap, r;   // parameters; initial separation (σ = 1)
    double r_after;  // expected separation
    double iterations, pairs, correction;
  };
  const Case cases[] = {
      {"reflect", 0.25, 0.75, 1.25, 1, 1, 0.5},    // δ = σ − r = 0.25 each: r' = 2σ − r
      {"contact", 0.25, 0.75, 1.0, 1, 1, 0.25},    // δ/2 = 0.125 each: r' = σ
      {"reflect", 0.25, 0.25, 1.25, 2, 2, 1.0},    // 0.75 capped to 0.25: r = 0.75; then 0.25: 1.25
      {"contact", 0.25, 0.25, 1.0, 2, 2, 0.75},    // 0.375 capped to 0.25: r = 0.75; then 0.125: 1.0
      {"reflect", 1.0, 0.25, 1.75, 1, 1, 1.5},     // cap out of the way: r' = 2σ − r
      {"reflect", 0.125, 0.75, 1.0, 1, 1, 0.25},   // 0.25 capped to 0.125: r = 1.0, contact, done
      {"reflect", 0.125, 0.5, 1.0, 2, 2, 0.5},     // 0.5 -> 0.125: r = 0.75; 0.25 -> 0.125: r = 1.0
      {"contact", 0.25, 0.984375, 1.0, 1, 1, 0.015625},  // shallow overlap (1/64): one iteration
  };
  for (const Case& c : cases) {
    INFO("mode " << c.mode << ", cap " << c.cap << ", r " << c.r);
    const auto spec = correct_spec(64, 0.05, {{"mode", std::string(c.mode)}, {"cap", c.cap}});
    auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
    auto xy = positions(*state);
    const double L = state->box.L[0];
    std::size_t a = 0;
    while (!(xy[2 * a] > 2 && xy[2 * a] < L - 3 && xy[2 * a + 1] > 2 && xy[2 * a + 1] < L - 3)) ++a;
    const std::size_t b = a == 0 ? 1 : 0;
    const double x0 = std::round(xy[2 * a] * 64) / 64, y0 = std::round(xy[2 * a + 1] * 64) / 64;
    xy[2 * a] = x0;
    xy[2 * a + 1] = y0;
    xy[2 * b] = x0 + c.r;
    xy[2 * b + 1] = y0;
    set_positions(*state, xy);
    REQUIRE(min_gap(*state) == c.r);
    Simulation sim(spec, registry(), dry(), std::move(state));
    sim.advance();
    const auto after = positions(sim.state());
    CHECK(after[2 * b] - after[2 * a] == c.r_after);
    CHECK(after[2 * a] + after[2 * b] == 2 * x0 + c.r);  // symmetric moves
    CHECK(after[2 * a + 1] == y0);
    CHECK(after[2 * b + 1] == y0);
    CHECK(metric(sim, "iterations") == c.iterations);
    CHECK(metric(sim, "pairs") == c.pairs);
    CHECK(metric(sim, "correction") == Approx(c.correction).epsilon(1e-9));
    std::size_t moved = 0;
    for (std::size_t i = 0; i < after.size() / 2; ++i)
      if (i != a && i != b && (after[2 * i] != xy[2 * i] || after[2 * i + 1] != xy[2 * i + 1])) ++moved;
    CHECK(moved == 0);
  }
}

TEST_CASE("overlap_correct: oblique pair, unequal diameters, and coincident centres", "[overlap]") {
  SECTION("along (3, 4)/5 with σ_a = 1, σ_b = 2: σ_ab = 1.5, reflect gives r' = 2σ_ab − r") {
    const auto spec = correct_spec(64, 0.02, {{"cap", 1.0}});
    auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
    auto xy = positions(*state);
    const double L = state->box.L[0];
    std::size_t a = 0;
    while (!(xy[2 * a] > 3 && xy[2 * a] < L - 4 && xy[2 * a + 1] > 3 && xy[2 * a + 1] < L - 4)) ++a;
    const std::size_t b = a == 0 ? 1 : 0;
    xy[2 * b] = xy[2 * a] + 0.6;  // r = 1.0 along (0.6, 0.8)
    xy[2 * b + 1] = xy[2 * a + 1] + 0.8;
    set_positions(*state, xy);
    Field& d = state->field(fields::diameter);
    d.host<double>()[b] = 2.0;
    Simulation sim(spec, registry(), dry(), std::move(state));
    sim.advance();
    const auto after = positions(sim.state());
    const double dx = after[2 * b] - after[2 * a], dy = after[2 * b + 1] - after[2 * a + 1];
    CHECK(std::hypot(dx, dy) == Approx(2.0).epsilon(1e-14));  // 2·1.5 − 1.0
    CHECK(dx / dy == Approx(0.75).epsilon(1e-14));            // still along (3, 4)
    // Each moved by δ = 0.5 (cap = 1·σ_a is not reached).
    CHECK(std::hypot(after[2 * a] - xy[2 * a], after[2 * a + 1] - xy[2 * a + 1]) == Approx(0.5).epsilon(1e-13));
  }
  SECTION("coincident centres separate along x, the lower index towards −x") {
    double dxa = 0, dya = 0, dxb = 0, dyb = 0;
    CHECK(overlap::pair_push(0.0, 0.0, 1.0, 1.0, 1.0, 3, 7, dxa, dya) == 1.0);
    CHECK(overlap::pair_push(-0.0, 0.0, 1.0, 1.0, 1.0, 7, 3, dxb, dyb) == 1.0);
    CHECK(dxa == -1.0);
    CHECK(dxb == 1.0);
    CHECK(dya == 0.0);
    CHECK(dyb == 0.0);
    double dx = 0, dy = 0;
    CHECK(overlap::pair_push(1.0, 0.0, 1.0, 1.0, 1.0, 3, 7, dx, dy) < 0);  // contact is no overlap
    CHECK(dx == 0.0);
  }
}

TEST_CASE("overlap_correct: random overlaps up to η = 0.8 are removed in a bounded number of iterations",
          "[overlap][physics]") {
  // A lattice sample (no overlaps) jiggled by a Gaussian of `amplitude`·σ per component: the
  // overlaps one large time step makes. Iteration bounds are ~2.5x what this seed needs.
  struct Case {
    double eta, amplitude;
    const char* mode;
    double max_iterations;
  };
  const Case cases[] = {{0.3, 0.3, "reflect", 5},   {0.5, 0.15, "reflect", 8},  {0.7, 0.05, "reflect", 5},
                        {0.7, 0.1, "reflect", 10},  {0.8, 0.05, "reflect", 12}, {0.8, 0.1, "reflect", 18},
                        {0.3, 0.3, "contact", 40},  {0.7, 0.1, "contact", 50},  {0.8, 0.1, "contact", 200}};
  for (const Case& c : cases) {
    const auto spec = correct_spec(2000, c.eta, {{"mode", std::string(c.mode)}});
    auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
    jiggle(*state, c.amplitude, 11);
    const double before = min_gap(*state);
    Simulation sim(spec, registry(), dry(), std::move(state));
    sim.advance();
    const double after = min_gap(sim.state());
    INFO("η " << c.eta << " jiggle " << c.amplitude << " " << c.mode << ": min r/σ " << before << " -> " << after
              << ", iterations " << metric(sim, "iterations") << ", pairs " << metric(sim, "pairs")
              << ", correction " << metric(sim, "correction"));
    REQUIRE(before < 0.9);
    CHECK(after >= 1 - 1e-6);
    CHECK(metric(sim, "iterations") >= 1);
    CHECK(metric(sim, "iterations") <= c.max_iterations);
    CHECK(metric(sim, "pairs") >= 1);
  }
}

TEST_CASE("overlap_correct: an ideal gas is pushed apart by repeated triangulate + correct steps", "[overlap][physics]") {
  // Uniform random points overlap everywhere; corrections this large outrun the triangulation
  // (it is no longer Delaunay for the moved points, and some overlapping pairs are not edges),
  // so a step of rebuild + correct is repeated until none is left.
  for (const char* mode : {"reflect", "contact"})
    for (double eta : {0.3, 0.5}) {
      const auto spec = correct_spec(2000, eta, {{"mode", std::string(mode)}});
      auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
      scatter(*state, 12);
      Simulation sim(spec, registry(), dry(), std::move(state));
      int steps = 0;
      double gap = 0, its = 0;
      std::string trace;
      while (steps < 50) {
        sim.advance();
        ++steps;
        gap = min_gap(sim.state());
        its += metric(sim, "iterations");
        trace += " " + std::to_string(gap);
        if (gap >= 1 - 1e-6) break;
      }
      INFO(mode << " η " << eta << ": " << steps << " steps, " << its << " iterations; min r/σ after each:" << trace);
      CHECK(gap >= 1 - 1e-6);
      CHECK(steps <= 5);
    }
}

TEST_CASE("overlap_correct: float runs end within the float tolerance", "[overlap]") {
  const auto spec = correct_spec(2000, 0.7, {}, Precision::f32);
  auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
  jiggle(*state, 0.1, 11);
  Simulation sim(spec, registry(), dry(), std::move(state));
  sim.advance();
  // 4·ε_f32·L/σ: the position resolution (L ≈ 47 here, so ≈ 2.2e-5).
  const double tol = 4 * 1.1920929e-7 * sim.state().box.L[0];
  INFO("min r/σ " << min_gap(sim.state()) << ", tolerance " << tol);
  CHECK(min_gap(sim.state()) >= 1 - tol);
  CHECK(metric(sim, "iterations") <= 10);
}

TEST_CASE("overlap_correct: bit-identical results for 1, 2 and 4 threads", "[overlap][determinism]") {
  const auto spec = correct_spec(20000, 0.75, {});
  std::vector<std::vector<double>> results;
  std::vector<double> iterations, correction;
  for (int threads : {1, 2, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
    jiggle(*state, 0.1, 5);
    Simulation sim(spec, registry(), dry(), std::move(state));
    sim.advance();
    results.push_back(positions(sim.state()));
    iterations.push_back(metric(sim, "iterations"));
    correction.push_back(metric(sim, "correction"));
  }
  CHECK(iterations[0] >= 2);
  for (std::size_t k = 1; k < results.size(); ++k) {
    CHECK(std::memcmp(results[k].data(), results[0].data(), results[0].size() * sizeof(double)) == 0);
    CHECK(iterations[k] == iterations[0]);
    CHECK(correction[k] == correction[0]);
  }
}

namespace {

// One step of `spec` from its jiggled initial state on backend b: the positions after it and the
// step's iteration and pair counts.
struct OneStep {
  std::vector<double> xy;
  double iterations = 0, pairs = 0;
};
OneStep one_step(const PipelineSpec& spec, Backend b) {
  auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
  jiggle(*state, 0.1, 5);
  Simulation sim(spec, registry(), dry(b), std::move(state));
  sim.advance();
  sim.synchronize();
  return {positions(sim.state()), metric(sim, "iterations"), metric(sim, "pairs")};
}

}  // namespace

TEST_CASE("overlap_correct: CPU and CUDA give the same bits (double) and agree in float", "[overlap][cuda]") {
  if (!test::have_cuda("overlap_correct CPU-vs-CUDA")) return;
  for (Precision p : {Precision::f64, Precision::f32})
    for (const char* mode : {"reflect", "contact"}) {
      INFO(to_string(p) << " " << mode);
      const auto spec = correct_spec(20000, 0.75, {{"mode", std::string(mode)}}, p);
      const OneStep cpu = one_step(spec, Backend::cpu), cuda = one_step(spec, Backend::cuda);
      const std::vector<std::vector<double>> xy{cpu.xy, cuda.xy};
      CHECK(cpu.iterations == cuda.iterations);
      if (p == Precision::f64) {
        CHECK(std::memcmp(xy[0].data(), xy[1].data(), xy[0].size() * sizeof(double)) == 0);
      } else {
        double worst = 0;
        for (std::size_t i = 0; i < xy[0].size(); ++i) worst = std::max(worst, std::fabs(xy[0][i] - xy[1][i]));
        INFO("largest float difference " << worst);
        CHECK(worst <= 1e-4);
      }
    }
}

// One correction of n disks at area fraction 0.75 on each backend: the same iterations, pairs and
// position bits (a correction of at least 3 iterations, so the device loop really iterates).
static void check_cpu_equals_cuda(std::uint64_t n) {
  const auto spec = correct_spec(n, 0.75, {});
  const OneStep cpu = one_step(spec, Backend::cpu), cuda = one_step(spec, Backend::cuda);
  const std::vector<std::vector<double>> xy{cpu.xy, cuda.xy};
  CHECK(cpu.iterations >= 3);
  CHECK(cpu.iterations == cuda.iterations);
  CHECK(cpu.pairs == cuda.pairs);
  CHECK(std::memcmp(xy[0].data(), xy[1].data(), xy[0].size() * sizeof(double)) == 0);
}

TEST_CASE("overlap_correct: CPU and CUDA give the same bits on either device path (team and grid)",
          "[overlap][cuda]") {
  // cuda.cu runs small systems (n ≤ kClusterMaxN = 4096) in a thread-block cluster and larger
  // ones on the whole grid: sizes on both sides, and the threshold itself. (20000, the size of the
  // tests above, is the grid's.)
  if (!test::have_cuda("overlap_correct CPU-vs-CUDA by size")) return;
  for (std::uint64_t n : {3000u, 4096u, 65536u, 100000u}) {
    INFO("n " << n);
    check_cpu_equals_cuda(n);
  }
}

// Many steps of ABP at φ = 0.7 (abp.yaml's stages: integrate, Delaunay maintenance with flips
// every step, overlap_correct) on the grid path: the device keeps each particle's fan from one
// step to the next where the flips left it alone (neighbor_lists.cuh, kept_fan) and runs the
// late iterations of a step in one block; neither may change a bit. Positions, image counts and
// each step's iterations and pairs must equal the CPU's.
TEST_CASE("overlap_correct: CPU and CUDA give the same bits over many steps of ABP (kept fans)",
          "[overlap][cuda]") {
  if (!test::have_cuda("overlap_correct CPU-vs-CUDA over many steps")) return;
  for (std::uint64_t n : {20000u, 100000u}) {
    INFO("n " << n);
    const auto l = test::load_compute_steps(
        test::repo_file("pipelines/abp.yaml").string(),
        {"system.N=" + std::to_string(n), "system.packing_fraction=0.7", "system.init=triangular_lattice_sample",
         "run.steps=150"});
    struct Run {
      std::vector<double> xy, iterations, pairs;
      std::vector<std::int32_t> image;
    };
    auto run = [&](Backend b) {
      Simulation sim(l.spec, *l.registry, dry(b));
      Run r;
      for (std::uint64_t k = 0; k < l.spec.run.steps; ++k) {
        sim.advance();
        r.iterations.push_back(metric(sim, "iterations"));
        r.pairs.push_back(metric(sim, "pairs"));
      }
      sim.synchronize();
      r.xy = positions(sim.state());
      Field& img = sim.state().field(fields::image);
      img.acquire(Where::host, Mode::read);
      r.image.assign(img.host<std::int32_t>(), img.host<std::int32_t>() + 2 * n);
      return r;
    };
    const Run cpu = run(Backend::cpu), cuda = run(Backend::cuda);
    double most = 0;
    for (double it : cpu.iterations) most = std::max(most, it);
    CHECK(most >= 5);  // the late iterations (block 0's tail) do run
    CHECK(cpu.iterations == cuda.iterations);
    CHECK(cpu.pairs == cuda.pairs);
    CHECK(cpu.image == cuda.image);
    CHECK(std::memcmp(cpu.xy.data(), cuda.xy.data(), cpu.xy.size() * sizeof(double)) == 0);
  }
}

TEST_CASE("overlap_correct: CPU and CUDA give the same bits when runs share the GPU (smaller teams)",
          "[overlap][cuda]") {
  // On a GPU that many runs share (runs_sharing_gpu, `pipeline sweep`), team_for gives a run the
  // cluster of 16 blocks where a run alone takes the grid and K grids would not fit on the GPU
  // (an H100/H200's 132 SMs: 16384 holds 32 SMs, 65536 128; with 2 runs 16384 keeps the grid).
  if (!test::have_cuda("overlap_correct CPU-vs-CUDA with shared GPUs")) return;
  for (int sharing : {64, 2}) {
    ff::set_runs_sharing_gpu(sharing);
    for (std::uint64_t n : {3000u, 16384u, 65536u}) {
      INFO("runs sharing the GPU " << sharing << ", n " << n);
      check_cpu_equals_cuda(n);
    }
  }
  ff::set_runs_sharing_gpu(1);
}

TEST_CASE("overlap_correct: errors name what to change", "[overlap][errors]") {
  const Registry& r = registry();
  SECTION("no triangulation before it") {
    auto s = test::spec(2, 200, 0.3, 1, 0.01, {entry(r, "overlap_correct")});
    try {
      Simulation sim(s, r, dry());
      FAIL("expected an InputError");
    } catch (const InputError& e) {
      const std::string m = e.what();
      CHECK(m.find("delaunay") != std::string::npos);
      CHECK(m.find("before") != std::string::npos);
    }
  }
  SECTION("3D") {
    auto s = test::spec(3, 200, 0.3, 1, 0.01, {entry(r, "overlap_correct")});
    CHECK_THROWS_AS(Simulation(s, r, dry()), InputError);
  }
  SECTION("max_iterations reached: the step and the worst pair are named") {
    const auto spec = correct_spec(2000, 0.8, {{"max_iterations", std::int64_t(2)}});
    auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
    jiggle(*state, 0.1, 11);
    Simulation sim(spec, r, dry(), std::move(state));
    try {
      sim.advance();
      FAIL("expected a RunError");
    } catch (const RunError& e) {
      const std::string m = e.what();
      INFO(m);
      CHECK(m.find("step 0") != std::string::npos);
      CHECK(m.find("max_iterations = 2") != std::string::npos);
      CHECK(m.find("worst is particles") != std::string::npos);
    }
  }
}

namespace {

// 64 disks (σ = 1) on a square grid of spacing 4 in a 32 x 32 box: rows and columns at 2, 6, ..., 30.
std::vector<double> grid64() {
  std::vector<double> xy(2 * 64);
  for (std::size_t i = 0; i < 64; ++i) {
    xy[2 * i] = 2 + 4.0 * double(i % 8);
    xy[2 * i + 1] = 2 + 4.0 * double(i / 8);
  }
  return xy;
}

// One step of `steps` on the 64 disks at xy with the given diameters (1 where not listed).
std::unique_ptr<Simulation> hand_made(const std::vector<StepEntry>& steps, const std::vector<double>& xy,
                                      const std::map<std::size_t, double>& diameter, Backend b = Backend::cpu) {
  auto spec = test::spec(2, 64, 0.05, 1, 0.01, steps, 3);
  spec.system.box = {32.0, 32.0};
  auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
  set_positions(*state, xy);
  Field& d = state->field(fields::diameter);
  d.acquire(Where::host, Mode::readwrite);
  for (auto& kv : diameter) d.host<double>()[kv.first] = kv.second;
  return std::make_unique<Simulation>(spec, registry(), dry(b), std::move(state));
}

std::vector<StepEntry> variant_steps(const std::string& variant, const std::map<std::string, ParamValue>& params) {
  const Registry& r = registry();
  if (variant == "delaunay") return {entry(r, "delaunay.build"), entry(r, "overlap_correct", params)};
  return {entry(r, "neighbors.verlet", {{"cutoff", 1.0}, {"skin", 0.3}}), entry(r, "overlap_correct.verlet", params)};
}

}  // namespace

TEST_CASE("overlap_correct: the diameter-ratio limit σ_min/σ_max ≥ √2 − 1 (seed-gaps C5)", "[overlap][errors]") {
  // The motif: two large disks (σ = 1) overlapping at r = 0.99 about (16, 16), and two small ones
  // just inside the top and the bottom of their diametral circle (0.495·(1 − 10⁻³) from its
  // centre). Every circle through the two large centres holds a small one, so the large pair is no
  // Delaunay edge. Small disks of 0.3 overlap nothing (0.6997 from each large centre > 0.65): the
  // correction on Delaunay edges sees no overlap and leaves the large pair as it is. Small disks of
  // 0.42 do overlap the large ones (0.6997 < 0.71), and the correction leaves no overlap at all.
  auto motif = [] {
    auto xy = grid64();
    const double h = 0.495 * (1 - 1e-3);
    const double at[4][2] = {{16 - 0.495, 16}, {16 + 0.495, 16}, {16, 16 + h}, {16, 16 - h}};
    for (int i = 0; i < 4; ++i) {
      xy[2 * i] = at[i][0];
      xy[2 * i + 1] = at[i][1];
    }
    return xy;
  };
  auto pair_gap = [](Simulation& sim) {
    const auto xy = positions(sim.state());
    return std::hypot(xy[2] - xy[0], xy[3] - xy[1]);
  };
  SECTION("ratio 0.3 is refused, naming the bound, the Verlet variant and the opt-out") {
    for (double small : {0.3, 0.41}) {
      INFO("small " << small);
      try {
        hand_made(variant_steps("delaunay", {}), motif(), {{2, small}, {3, small}});
        FAIL("expected an InputError");
      } catch (const InputError& e) {
        const std::string m = e.what();
        INFO(m);
        CHECK(m.find("√2 − 1") != std::string::npos);
        CHECK(m.find("overlap_correct.verlet") != std::string::npos);
        CHECK(m.find("check_diameter_ratio: false") != std::string::npos);
      }
    }
  }
  SECTION("ratio 0.3 with the check off: the overlap survives; overlap_correct.verlet removes it") {
    auto sim = hand_made(variant_steps("delaunay", {{"check_diameter_ratio", false}}), motif(), {{2, 0.3}, {3, 0.3}});
    REQUIRE(min_gap(sim->state()) == Approx(0.99).epsilon(1e-12));
    sim->advance();
    CHECK(metric(*sim, "iterations") == 0);
    CHECK(pair_gap(*sim) == Approx(0.99).epsilon(1e-12));
    CHECK(min_gap(sim->state()) < 1 - 1e-6);
    auto verlet = hand_made(variant_steps("verlet", {}), motif(), {{2, 0.3}, {3, 0.3}});
    verlet->advance();
    CHECK(min_gap(verlet->state()) >= 1 - 1e-6);
  }
  SECTION("ratio 0.42 is accepted and leaves no overlap") {
    auto sim = hand_made(variant_steps("delaunay", {}), motif(), {{2, 0.42}, {3, 0.42}});
    REQUIRE(min_gap(sim->state()) < 0.99);
    sim->advance();
    INFO("iterations " << metric(*sim, "iterations") << ", large pair at " << pair_gap(*sim));
    CHECK(metric(*sim, "iterations") >= 1);
    CHECK(min_gap(sim->state()) >= 1 - 1e-6);
  }
}

TEST_CASE("overlap_correct: mark: true marks exactly the particles of overlapping pairs (both variants)",
          "[overlap][verlet][mark]") {
  // Two overlapping pairs on the grid (9 at 0.75 from 10, 20 at 0.9 from 21): the step marks those
  // four and no other; the next step (nothing overlaps any more) clears every mark.
  const Backend backend = GENERATE(from_range(test::backends()));
  for (const char* variant : {"delaunay", "verlet"}) {
    INFO(to_string(backend) << ": " << variant);
    auto xy = grid64();
    xy[2 * 9] = 9.25;
    xy[2 * 20] = 21.1;
    auto sim = hand_made(variant_steps(variant, {{"mark", true}}), xy, {}, backend);
    const std::string name = variant == std::string("delaunay") ? "overlap_correct/" : "overlap_correct.verlet/";
    auto marked = [&] {
      Field& f = sim->state().field(overlap::touched_field);
      f.acquire(Where::host, Mode::read);
      std::vector<std::size_t> who;
      for (std::size_t i = 0; i < 64; ++i)
        if (f.host<std::uint8_t>()[i]) who.push_back(i);
      return who;
    };
    sim->advance();
    CHECK(marked() == std::vector<std::size_t>{9, 10, 20, 21});
    CHECK(sim->stats().metrics.at(name + "touched") == 4);
    CHECK(sim->stats().metrics.at(name + "touched_fraction") == 4.0 / 64);
    CHECK(sim->stats().metrics.at(name + "iterations") == 1);
    sim->advance();
    CHECK(marked().empty());
    CHECK(sim->stats().metrics.at(name + "touched") == 0);
  }
}
