// boids.integrate against its formulas on hand-made steering: the continuous step turns u by
// exactly ω Δt = (u × F) Δt/τ and moves x by v0 Δt along the old heading; the discrete step is the
// reference program's map (u ← w/|w|, w = u + F; x += v0 u with the new u) to 1e-15; crossing the
// boundary wraps x and counts the image; the continuous flow converges at first order in Δt (the
// error halves with Δt), so a rollback's halved Δt is a finer step of the same motion; the discrete
// map refuses a Δt other than run.dt.
#include <catch2/catch.hpp>
#include <cmath>

#include "plugins/boids/test_support.h"
#include "support/backends.h"

using namespace ff;
using namespace ff::boids;
using ff::test::values;

namespace {

// boids.integrate once on s with steering F (n x 2), Δt = dt, run.dt = run_dt.
void integrate(State& s, Backend b, const std::vector<double>& F, const ff::test::ParamSettings& set, double dt,
               double run_dt) {
  if (!s.has_field(kSteering)) s.add_particle_field(kSteering, s.real(), 2);
  boids_test::set_real(s, kSteering, F);
  ParamValues v = ParamValues::defaults(boids_test::registry().get("boids.integrate").decl.params);
  for (auto& kv : set) v.set(kv.first, kv.second);
  RunInfo info;
  info.precision = s.precision();
  info.backend = b;
  info.dt = run_dt;
  info.stage_id = "boids.integrate";
  auto st = boids_test::registry().create("boids.integrate", b, v, info);
  st->configure(s);
  ff::test::StageDriver d(b, s.precision(), 2);
  const Outcome o = d.run(*st, s, 0, dt);  // outside a Catch macro: a throw reaches the caller
  REQUIRE_FALSE(o.rollback);
}

}  // namespace

TEST_CASE("boids.integrate: the continuous step turns u by (u × F) Δt/τ and moves along the old u", "[boids]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  INFO(to_string(b));
  const double c = std::cos(0.3), s = std::sin(0.3);
  // Boid 0: u = (1, 0), F = (0.2, 0.1): ω = 0.1/τ. Boid 1: u = (c, s), F ⟂ u turning right by 0.4/τ.
  auto st = boids_test::boids(Precision::f64, 10, {5, 5, 2, 3}, {1, 0, c, s});
  const double tau = 2, dt = 0.5, v0 = 0.25;
  integrate(*st, b, {0.2, 0.1, 0.4 * s, -0.4 * c}, {{"tau", tau}, {"v0", v0}}, dt, dt);
  const auto u = values(*st, kHeading), x = values(*st, fields::position);
  const double turn0 = 0.1 * dt / tau, turn1 = 0.3 - 0.4 * dt / tau;
  CHECK(u[0] == Approx(std::cos(turn0)).margin(1e-15));
  CHECK(u[1] == Approx(std::sin(turn0)).margin(1e-15));
  CHECK(u[2] == Approx(std::cos(turn1)).margin(1e-15));
  CHECK(u[3] == Approx(std::sin(turn1)).margin(1e-15));
  CHECK(x[0] == 5 + v0 * dt);  // along the heading at the start of the step
  CHECK(x[1] == 5);
  CHECK(x[2] == Approx(2 + v0 * dt * c).margin(1e-15));
  CHECK(x[3] == Approx(3 + v0 * dt * s).margin(1e-15));
  for (int i = 0; i < 2; ++i) CHECK(std::hypot(u[2 * i], u[2 * i + 1]) == Approx(1).margin(1e-15));
}

TEST_CASE("boids.integrate: the discrete step is the reference program's map", "[boids]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  INFO(to_string(b));
  const std::vector<double> x0{5, 5, 2, 3, 9.99, 0.01}, F{0.05, -0.02, -0.3, 0.1, 0.01, -0.04};
  const double c = std::cos(2.0), s = std::sin(2.0);
  const std::vector<double> u0{1, 0, c, s, 0.6, -0.8};
  auto st = boids_test::boids(Precision::f64, 10, x0, u0);
  integrate(*st, b, F, {{"update", std::string("discrete")}, {"v0", 0.06}}, 1.0, 1.0);
  const auto u = values(*st, kHeading), x = values(*st, fields::position);
  const auto img = [&] {
    Field& f = st->field(fields::image);
    f.acquire(Where::host, Mode::read);
    return std::vector<std::int32_t>(f.host<std::int32_t>(), f.host<std::int32_t>() + 6);
  }();
  for (int i = 0; i < 3; ++i) {  // boids_bruteforce.cpp: h = w/|w|; x += v0 h; x -= L floor(x/L)
    const double wx = u0[2 * i] + F[2 * i], wy = u0[2 * i + 1] + F[2 * i + 1], nn = std::sqrt(wx * wx + wy * wy);
    const double hx = wx / nn, hy = wy / nn;
    double px = x0[2 * i] + 0.06 * hx, py = x0[2 * i + 1] + 0.06 * hy;
    px -= 10 * std::floor(px / 10);
    py -= 10 * std::floor(py / 10);
    CHECK(u[2 * i] == Approx(hx).margin(1e-15));
    CHECK(u[2 * i + 1] == Approx(hy).margin(1e-15));
    CHECK(x[2 * i] == Approx(px).margin(1e-14));
    CHECK(x[2 * i + 1] == Approx(py).margin(1e-14));
  }
  // Boid 2 left through the corner: x past L (image +1), y below 0 (image −1).
  CHECK(img == std::vector<std::int32_t>{0, 0, 0, 0, 1, -1});
}

TEST_CASE("boids.integrate: the continuous flow converges at first order in Δt", "[boids]") {
  // Alignment only, 16 boids that all see each other (box side 1, full list): a smooth flow. The
  // state at t = 8 for Δt = 1, 1/2, 1/4, 1/8 against Δt = 1/64: each halving halves the error.
  auto at_t8 = [](double dt) {
    auto s = boids_test::random_boids(Precision::f64, 16, 1.0, 5);
    boids_test::full_list(*s, 2.0);
    boids_test::Flock f(*s, Backend::cpu, {{"separation", 0.0}, {"cohesion", 0.0}, {"view_angle", kPi}}, {}, dt);
    for (int k = 0; k < int(std::lround(8 / dt)); ++k) f.step();
    return values(*s, kHeading);
  };
  const auto fine = at_t8(1.0 / 64);
  std::vector<double> err;
  for (double dt : {1.0, 0.5, 0.25, 0.125}) {
    const auto u = at_t8(dt);
    double e = 0;
    for (std::size_t k = 0; k < u.size(); ++k) e = std::max(e, std::abs(u[k] - fine[k]));
    err.push_back(e);
  }
  INFO("max heading error at t = 8 for Δt = 1, 1/2, 1/4, 1/8: " << err[0] << ", " << err[1] << ", " << err[2] << ", "
                                                                 << err[3]);
  CHECK(err[0] > 1e-3);  // the flow turns the headings: there is something to converge
  for (std::size_t k = 1; k < err.size(); ++k) {
    // Against Δt = 1/64 the ratio of first order is (Δt − 1/64)/(Δt/2 − 1/64): 2.06 … 2.29.
    CHECK(err[k - 1] / err[k] > 1.8);
    CHECK(err[k - 1] / err[k] < 2.6);
  }
}

TEST_CASE("boids.integrate: the discrete map refuses a Δt other than run.dt (a rollback's)", "[boids]") {
  auto st = boids_test::boids(Precision::f64, 10, {5, 5}, {1, 0});
  CHECK_THROWS_WITH(integrate(*st, Backend::cpu, {0, 0}, {{"update", std::string("discrete")}}, 0.5, 1.0),
                    Catch::Contains("update: continuous"));
  auto nosteer = boids_test::boids(Precision::f64, 10, {5, 5}, {1, 0});
  auto alone = ff::test::make_stage(boids_test::registry(), "boids.integrate", Backend::cpu, Precision::f64, 2);
  CHECK_THROWS_WITH(alone->configure(*nosteer), Catch::Contains("boids.forces"));
}
