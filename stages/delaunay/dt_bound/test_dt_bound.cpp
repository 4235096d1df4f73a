// delaunay.dt_bound (spec D3): the bound on hand-made states, h_i against brute force, and in
// runs of ideal Brownian points: every particle stays in its old Voronoi cell on every step,
// limited steps are reproducible (repeated, 1 vs 2 threads, CPU vs CUDA) and Δt regrows.
#include <oneapi/tbb/global_control.h>

#include <cmath>
#include <cstring>

#include "core/run/simulation.h"
#include "stages/delaunay/common/host.h"
#include "stages/delaunay/dt_bound/kernel.h"
#include "stages/delaunay/test_support.h"
#include "support/spec.h"

using namespace ff;
using namespace ff::test::dl;
using ff::delaunay::largest_dt;

namespace {

constexpr double kG = ff::kLargestGaussian;

// The bound of spec D3 as written there: √Δt = (−b + √(b² + 4ac)) / (2a), a = 0: (c/b)².
double textbook_dt(double a, double b, double c) {
  if (a == 0) return (c / b) * (c / b);
  const double s = (-b + std::sqrt(b * b + 4 * a * c)) / (2 * a);
  return s * s;
}

// Minimum-image vector from p to q (2D, box L).
std::array<double, 2> rel(const double* p, const double* q, const double* L) {
  std::array<double, 2> d{};
  for (int k = 0; k < 2; ++k) d[k] = (q[k] - p[k]) - L[k] * std::rint((q[k] - p[k]) / L[k]);
  return d;
}
double norm(const std::array<double, 2>& d) { return std::sqrt(d[0] * d[0] + d[1] * d[1]); }

// The Delaunay neighbours of every vertex, from the half-edges.
std::vector<std::vector<int>> neighbours(const Topo& t, std::size_t n) {
  std::vector<std::vector<int>> nb(n);
  for (std::size_t h = 0; h < t.he.size() / 2; ++h) nb[std::size_t(t.he[2 * h])].push_back(t.he[2 * (h ^ 1)]);
  return nb;
}

// A 6 x 6 triangular lattice (spacing 1) with particle 0 moved 0.4 toward particle 1: h_0 =
// h_1 = 0.6, every other particle's nearest neighbour at 1 (or 0.87 for the two beside 0).
std::unique_ptr<State> squeezed_lattice() {
  auto xy = triangular_lattice(6, 6, 1.0);
  xy[0] += 0.4;
  return make_state(xy, 6.0, 6 * std::sqrt(3.0) / 2);
}

}  // namespace

TEST_CASE("largest_dt solves a·Δt + b·√Δt = c as the spec's formula does", "[dt_bound]") {
  for (double a : {0.0, 1e-9, 0.3, 5.0, 1e4})
    for (double b : {0.0, 1e-6, 0.5, 6.08, 100.0})
      for (double c : {1e-4, 0.15, 2.0}) {
        if (a == 0 && b == 0) {
          CHECK(std::isinf(largest_dt(a, b, c)));
          continue;
        }
        const double dt = largest_dt(a, b, c);
        INFO("a " << a << " b " << b << " c " << c << " dt " << dt);
        // The root itself: the displacement bound at Δt is c.
        CHECK(a * dt + b * std::sqrt(dt) == Approx(c).epsilon(1e-12));
        if (a * c < 1e-3 * b * b) continue;  // (the textbook form cancels there)
        CHECK(dt == Approx(textbook_dt(a, b, c)).epsilon(1e-12));
      }
  CHECK(largest_dt(1.0, 1.0, 0.0) == 0.0);  // a neighbour on top: Δt 0 (the run stops)
  CHECK(largest_dt(NAN, 1.0, 1.0) == 0.0);
}

TEST_CASE("h_i is the distance to the nearest particle, for every particle", "[dt_bound]") {
  for (int which = 0; which < 2; ++which) {
    auto s = which ? make_state(random_points(500, 20.0, 25.0, 7), 20.0, 25.0) : squeezed_lattice();
    auto bound = make_stage("delaunay.dt_bound", Backend::cpu);
    bound->configure(*s);
    Runner r(*s, Backend::cpu);
    r.run(*bound);  // builds the triangulation
    require_valid(*s);
    const std::size_t n = s->n();
    std::vector<std::uint64_t> nearest2(n, ~std::uint64_t(0) >> 1), key(n);
    std::vector<double> nearest(n);
    const delaunay::EdgeNearest<double> e{delaunay::mesh_view(*s, Where::host),
                                          delaunay::points_view<double>(*s, fields::position, Where::host),
                                          nearest2.data()};
    for (std::size_t k = 0; k < 3 * n; ++k) e(k);
    delaunay::ParticleDtBound<double> f{};
    f.noise[0] = 1;
    f.fraction = 0.25;
    f.nearest2 = nearest2.data();
    f.key = key.data();
    f.nearest = nearest.data();
    const auto xy = positions(*s);
    for (std::size_t i = 0; i < n; ++i) {
      f(i);
      double brute = INFINITY;
      for (std::size_t j = 0; j < n; ++j)
        if (j != i) brute = std::min(brute, norm(rel(&xy[2 * i], &xy[2 * j], s->box.L)));
      INFO("particle " << i);
      CHECK(nearest[i] == Approx(brute).epsilon(1e-14));
    }
  }
}

TEST_CASE("the bound on a hand-made state: noise, drift, speed, the particle named", "[dt_bound]") {
  const Backend b = GENERATE(from_range(test::backends()));
  INFO("backend " << to_string(b));
  const double c = 0.25 * 0.6;             // a quarter of h_0 = h_1 = 0.6
  const double noise = kG * std::sqrt(2.0);  // G √d √(2D) at D = 0.5
  SECTION("noise only: (c / b)²") {
    auto s = squeezed_lattice();
    auto bound = make_stage("delaunay.dt_bound", b, Precision::f64, {{"D", 0.5}});
    bound->configure(*s);
    Runner r(*s, b);
    const double want = textbook_dt(0, noise, c);
    Outcome o = r.run(*bound, 0, 1.0);
    CHECK(o.dt_limit == Approx(want).epsilon(1e-14));
    CHECK_FALSE(o.rollback);
    CHECK(o.particles == std::vector<std::uint64_t>{0});  // 0 and 1 tie: the lowest is named
    CHECK_THAT(o.reason, Catch::Contains("particle 0 is 0.6 from its nearest Delaunay neighbour"));
    // Within the limit: the same limit, nobody named (no extra work).
    o = r.run(*bound, 1, want / 2);
    CHECK(o.dt_limit == Approx(want).epsilon(1e-14));
    CHECK(o.particles.empty());
    CHECK(r.metric("dt_max") == o.dt_limit);
  }
  SECTION("a drift velocity on particle 0: the quadratic in √Δt") {
    auto s = squeezed_lattice();
    Field& v = s->add_field("velocity", DType::f64, 2, s->n());
    v.host<double>()[0] = 3;
    v.host<double>()[1] = -4;  // |v_0| = 5
    v.mark_written(Where::host);
    auto bound = make_stage("delaunay.dt_bound", b, Precision::f64, {{"D", 0.5}});
    bound->configure(*s);
    Runner r(*s, b);
    const Outcome o = r.run(*bound, 0, 1.0);
    CHECK(o.dt_limit == Approx(textbook_dt(5.0, noise, c)).epsilon(1e-12));
    CHECK(o.dt_limit < textbook_dt(0, noise, c));
    CHECK(o.particles == std::vector<std::uint64_t>{0});
  }
  SECTION("no noise: a constant speed (boids) plus mobility times force, c / |v|") {
    auto s = squeezed_lattice();
    Field& F = s->add_field("force", DType::f64, 2, s->n());
    F.host<double>()[2 * 1 + 1] = 10;  // particle 1: |μF| = 0.5 · 10 = 5
    F.mark_written(Where::host);
    auto bound = make_stage("delaunay.dt_bound", b, Precision::f64,
                            {{"D", 0.0}, {"speed", 2.0}, {"mobility", 0.5}, {"drift", std::string("force")}});
    bound->configure(*s);
    Runner r(*s, b);
    const Outcome o = r.run(*bound, 0, 1.0);
    CHECK(o.dt_limit == Approx(c / (2.0 + 5.0)).epsilon(1e-14));
    CHECK(o.particles == std::vector<std::uint64_t>{1});
  }
}

namespace {

// Ideal Brownian points (no hard core) with the bound on, the triangulation maintained.
PipelineSpec brownian_points(const Registry& r, std::uint64_t n, std::uint64_t steps, double dt) {
  using test::entry;
  auto s = test::spec(2, n, 0.2, steps, dt,
                      {entry(r, "delaunay.dt_bound", {{"D", 1.0}}), entry(r, "brownian.integrate", {{"D", 1.0}}),
                       entry(r, "delaunay.detect_inversion"), entry(r, "delaunay.flip"), entry(r, "delaunay.lawson")},
                      3);
  s.run.dt_min = dt / std::pow(2.0, 40);
  return s;
}

struct Trace {
  std::vector<double> dt;
  std::vector<double> position;
  std::uint64_t dt_limits = 0, rollbacks = 0;
};

Trace trace(const PipelineSpec& spec, const Registry& r, Backend b, int steps) {
  Simulation sim(spec, r, test::dry(b));
  Trace t;
  for (int k = 0; k < steps; ++k) {
    sim.advance();
    t.dt.push_back(sim.stats().dt);
  }
  t.position = positions(sim.state());
  t.dt_limits = sim.stats().dt_limits;
  t.rollbacks = sim.stats().rollbacks;
  return t;
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

}  // namespace

TEST_CASE("with the bound on, every particle stays in its old Voronoi cell on every step (10^4 steps)",
          "[dt_bound]") {
  auto r = test::registry_with({"brownian"});
  const int steps = 10000;
  Simulation sim(brownian_points(*r, 256, steps, 0.01), *r, test::dry());
  std::size_t outside = 0, beyond_quarter = 0, regrowths = 0, limited_steps = 0;
  double worst = 0;  // largest |Δr_i| / h_i seen
  for (int k = 0; k < steps; ++k) {
    State& s = sim.state();
    const auto old = positions(s);
    // The triangulation the step starts from: the maintained one, or before the first step
    // (which builds it) CGAL's of the same positions.
    const auto nb = neighbours(k ? topology(s) : cgal_reference(s), s.n());
    const double dt_before = sim.stats().dt;
    sim.advance();
    if (k > 0 && sim.stats().dt > dt_before) ++regrowths;
    if (sim.stats().dt < 0.01) ++limited_steps;
    const auto now = positions(s);
    for (std::size_t i = 0; i < s.n(); ++i) {
      const double moved = norm(rel(&old[2 * i], &now[2 * i], s.box.L));
      double h = INFINITY;
      for (int j : nb[i]) {
        h = std::min(h, norm(rel(&old[2 * i], &old[2 * std::size_t(j)], s.box.L)));
        // Voronoi: closer to its own old position than to any old neighbour's.
        if (!(moved < norm(rel(&old[2 * std::size_t(j)], &now[2 * i], s.box.L)))) ++outside;
      }
      worst = std::max(worst, moved / h);
      if (moved > 0.25 * h * (1 + 1e-9)) ++beyond_quarter;
    }
  }
  INFO("Δt-limited retries " << sim.stats().dt_limits << ", rollbacks " << sim.stats().rollbacks << ", regrowths "
                             << regrowths << ", largest move / h " << worst << ", last Δt " << sim.stats().dt);
  CHECK(outside == 0);
  CHECK(beyond_quarter == 0);
  CHECK(worst > 0.05);  // the bound is not vacuous: steps come within a factor ~5 of it
  CHECK(sim.stats().dt_limits > 0);
  CHECK(regrowths > 0);               // Δt grows back when the closest pair separates
  CHECK(limited_steps == std::size_t(steps));  // ideal points come close: the limit always binds
  WARN("10^4 steps of 256 ideal Brownian points with delaunay.dt_bound: "
       << sim.stats().dt_limits << " Δt-limited retries, " << sim.stats().rollbacks << " rollbacks, " << regrowths
       << " regrowths, largest |Δr|/h " << worst);
}

TEST_CASE("Δt-limited steps are bit-identical when repeated and on 1 or 2 threads", "[dt_bound]") {
  auto r = test::registry_with({"brownian"});
  // Large enough that the loops and reductions split across threads (oneTBB grains 2048, 4096).
  const auto spec = brownian_points(*r, 8192, 30, 0.01);
  Trace one, two, again;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = trace(spec, *r, Backend::cpu, 30);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = trace(spec, *r, Backend::cpu, 30);
    again = trace(spec, *r, Backend::cpu, 30);
  }
  REQUIRE(one.dt_limits > 0);
  CHECK(one.dt == two.dt);
  CHECK(one.dt_limits == two.dt_limits);
  CHECK(same_bits(one.position, two.position));
  CHECK(two.dt == again.dt);
  CHECK(same_bits(two.position, again.position));
}

TEST_CASE("CPU and CUDA take the same Δt-limited steps, bit for bit", "[dt_bound][cuda]") {
  if (!test::have_cuda("delaunay.dt_bound CPU vs CUDA")) return;
  auto r = test::registry_with({"brownian"});
  const auto spec = brownian_points(*r, 4096, 40, 0.01);
  const Trace cpu = trace(spec, *r, Backend::cpu, 40), cuda = trace(spec, *r, Backend::cuda, 40);
  REQUIRE(cpu.dt_limits > 0);
  CHECK(cpu.dt == cuda.dt);
  CHECK(cpu.dt_limits == cuda.dt_limits);
  CHECK(cpu.rollbacks == cuda.rollbacks);
  CHECK(same_bits(cpu.position, cuda.position));
}
