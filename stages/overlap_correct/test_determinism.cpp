// overlap_correct gives the bits of its definition done naively (every particle gathered every
// iteration, the fan walk in fan order), on dense jiggles and an ideal gas, with unequal diameters
// and diameters that change between steps, on every backend; and the same bits for 1, 2 and 4
// threads.
#include <catch2/catch.hpp>
#include <oneapi/tbb/global_control.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "stages/delaunay/common/fields.h"
#include "stages/overlap_correct/kernel.h"
#include "stages/overlap_correct/test_support.h"
#include "support/backends.h"

using namespace ff;
using namespace ff::overlap_test;

namespace {

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
  const overlap::Overlaps<double> m{
      overlap::PushRule::make(PeriodicBox<double>::make(s.box.L), factor, cap, tol, 1.0 / unit),
      out.xy.data(),
      s.field(fields::diameter).host<double>(),
      s.field(delaunay::fields::halfedge).host<std::int32_t>(),
      s.field(delaunay::fields::vertex_edge).host<std::int32_t>(),
      std::int32_t(n),
      dmax * dmax};
  jacobi_reference(m, out.xy.data(), image.data(), n, out.iterations, out.pairs);
  return out;
}

// Particles whose fan has more than `degree` neighbours (host copy of the triangulation).
std::size_t vertices_with_degree_above(State& s, int degree) {
  for (const char* f : {fields::position, fields::diameter, delaunay::fields::halfedge, delaunay::fields::vertex_edge})
    s.field(f).acquire(Where::host, Mode::read);
  const std::size_t n = s.n();
  const overlap::Overlaps<double> m{overlap::PushRule::make(PeriodicBox<double>::make(s.box.L), 1.0, 0.25, 1e-6, 1.0),
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
