// The boids as a model (boids.forces + boids.integrate, and boids.polarisation's Φ):
//  - alignment only orders a flock: Φ = |Σ u_i|/N rises from O(N^-1/2) to ≥ 0.95 within 2000
//    steps (16 boids that all see each other, the spec's case; 256 at density 1 through
//    neighbors.verlet), and Φ = 1 is a fixed point (equal headings stay equal to 1e-12);
//  - two boids on a collision course, mirror images of each other under x ↔ y, turn away from each
//    other by separation alone and stay mirror images bit for bit at every step (without it they
//    meet on the mirror line);
//  - CPU and CUDA give the same bits over 200 steps of every rule, both updates.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>

#include "plugins/boids/polarisation/stage.h"
#include "plugins/boids/test_support.h"
#include "support/backends.h"

using namespace ff;
using namespace ff::boids;
using ff::test::values;

namespace {

const ff::test::ParamSettings kAlignmentOnly{{"separation", 0.0}, {"cohesion", 0.0}, {"view_angle", kPi}};

ff::test::ParamSettings update(const std::string& u) { return {{"update", u}}; }

// boids.polarisation's metric on s.
double phi_metric(State& s, Backend b) {
  auto obs = ff::test::make_stage(boids_test::registry(), "boids.polarisation", b, s.precision(), 2);
  obs->configure(s);
  ff::test::StageDriver d(b, s.precision(), 2);
  d.run(*obs, s);
  return d.metric("phi");
}

}  // namespace

TEST_CASE("boids: alignment orders 16 boids that all see each other, as in the reference program", "[boids]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  const std::string u = GENERATE(std::string("continuous"), std::string("discrete"));
  INFO(to_string(b) << ", update " << u);
  // Φ at step 50 printed by `boids_bruteforce 16 1 100 0 0 0.0938 3.14159265 SEED 50` (the same
  // initial state: random_boids draws as it does), whose map `update: discrete` is.
  const double reference_phi50[] = {0.9722, 0.7474, 0.9949};
  for (unsigned seed : {1u, 2u, 3u}) {
    auto s = boids_test::random_boids(Precision::f64, 16, 1.0, seed);  // everyone within 0.71 < r_v = 2
    boids_test::full_list(*s, 2.0);
    boids_test::Flock f(*s, b, kAlignmentOnly, update(u), 1.0);
    const double phi0 = f.phi();
    CHECK(phi_metric(*s, b) == phi0);
    int steps = 0;
    double phi50 = 0;
    while ((f.phi() < 0.999 || steps < 50) && steps < 2000) {
      f.step();
      if (++steps == 50) phi50 = f.phi();
    }
    INFO("seed " << seed << ": Φ = " << phi0 << " at the start, " << phi50 << " at step 50, ≥ 0.999 after " << steps
                  << " steps");
    CHECK(phi0 < 3 / std::sqrt(16.0));
    CHECK(steps <= 150);  // the reference program's map: 0.9998–1.0000 by step 100 (spec appendix A3)
    if (u == "discrete") CHECK(std::abs(phi50 - reference_phi50[seed - 1]) <= 0.6e-4);  // printed to 4 decimals
  }
}

TEST_CASE("boids: alignment orders 256 boids at density 1 through neighbors.verlet within 2000 steps", "[boids]") {
  const std::string u = GENERATE(std::string("continuous"), std::string("discrete"));
  INFO("update " << u);
  auto s = boids_test::random_boids(Precision::f64, 256, 16.0, 1);  // ~12 boids within r_v = 2 of each
  boids_test::Flock f(*s, Backend::cpu, kAlignmentOnly, update(u), 1.0, 2.0);
  const double phi0 = f.phi();
  for (int k = 0; k < 2000; ++k) f.step();
  INFO("Φ = " << phi0 << " at the start, " << f.phi() << " after 2000 steps");
  CHECK(phi0 < 3 / std::sqrt(256.0));  // random headings: Φ ~ N^(-1/2)
  CHECK(f.phi() >= 0.95);
}

TEST_CASE("boids: equal headings stay equal (Φ = 1 is a fixed point of alignment)", "[boids]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  const std::string u = GENERATE(std::string("continuous"), std::string("discrete"));
  INFO(to_string(b) << ", update " << u);
  auto s = boids_test::random_boids(Precision::f64, 256, 16.0, 2);
  std::vector<double> same(2 * s->n());
  for (std::size_t i = 0; i < s->n(); ++i) {
    same[2 * i] = std::cos(0.7);
    same[2 * i + 1] = std::sin(0.7);
  }
  boids_test::set_real(*s, kHeading, same);
  boids_test::Flock f(*s, b, kAlignmentOnly, update(u), 1.0, 2.0);
  for (int k = 0; k < 1000; ++k) f.step();
  const auto h = values(*s, kHeading);
  double worst = 0;
  for (std::size_t k = 0; k < h.size(); ++k) worst = std::max(worst, std::abs(h[k] - same[k]));
  INFO("largest change of a heading component over 1000 steps: " << worst);
  CHECK(worst <= 1e-12);
  CHECK(f.phi() >= 1 - 1e-12);
}

TEST_CASE("boids: two boids on a collision course turn away from each other, mirror images bit for bit", "[boids]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  const std::string u = GENERATE(std::string("continuous"), std::string("discrete"));
  INFO(to_string(b) << ", update " << u);
  // Boid 0 at (3, 5) heading −35°, boid 1 at its mirror image (5, 3) heading 125°: their straight
  // paths meet on the mirror line y = x at the same time, 20° off head-on. Separation only (A = 0.3:
  // the turn rate A sin(angle between u and −d) starts at 0.05 rad per step).
  const double a = -35 * kPi / 180;
  auto run = [&](double A, double& closest) {
    auto s = boids_test::boids(Precision::f64, 8, {3, 5, 5, 3}, {std::cos(a), std::sin(a), std::sin(a), std::cos(a)});
    boids_test::full_list(*s, 2.0);
    boids_test::Flock f(*s, b, {{"separation", A}, {"alignment", 0.0}, {"cohesion", 0.0}}, update(u), 1.0);
    closest = 1e9;
    for (int k = 0; k < 100; ++k) {
      f.step();
      const auto x = values(*s, fields::position), h = values(*s, kHeading);
      // x ↔ y maps each boid onto the other, bit for bit.
      REQUIRE(std::memcmp(&x[0], &x[3], sizeof(double)) == 0);
      REQUIRE(std::memcmp(&x[1], &x[2], sizeof(double)) == 0);
      REQUIRE(std::memcmp(&h[0], &h[3], sizeof(double)) == 0);
      REQUIRE(std::memcmp(&h[1], &h[2], sizeof(double)) == 0);
      closest = std::min(closest, std::hypot(x[2] - x[0], x[3] - x[1]));
    }
    const auto h = values(*s, kHeading);
    return std::atan2(h[1], h[0]);  // boid 0's final heading
  };
  double closest_free, closest_steered;
  const double straight = run(0.0, closest_free);
  const double turned = run(0.3, closest_steered);
  INFO("boid 0's heading: " << straight * 180 / kPi << "° without separation, " << turned * 180 / kPi
                            << "° with; closest approach " << closest_free << " without, " << closest_steered
                            << " with");
  CHECK(straight == Approx(a).margin(1e-15));  // nothing steers
  CHECK(closest_free < 0.1);                   // they meet on the mirror line
  CHECK(turned > kPi / 4);  // boid 0 turned left, away from boid 1 (on its right), past the mirror line's direction
  CHECK(closest_steered > 0.5);
}

TEST_CASE("boids: CPU and CUDA give the same bits over 200 steps", "[boids][cuda]") {
  if (!ff::test::have_cuda("boids CPU vs CUDA")) return;
  const Precision prec = GENERATE(Precision::f64, Precision::f32);
  const std::string u = GENERATE(std::string("continuous"), std::string("discrete"));
  INFO(to_string(prec) << ", update " << u);
  auto cpu = boids_test::random_boids(prec, 512, 16.0, 4), cuda = boids_test::random_boids(prec, 512, 16.0, 4);
  boids_test::Flock a(*cpu, Backend::cpu, {}, update(u), 1.0, 2.0), c(*cuda, Backend::cuda, {}, update(u), 1.0, 2.0);
  for (int k = 0; k < 200; ++k) {
    a.step();
    c.step();
  }
  for (const char* name : {fields::position, kHeading}) {
    const auto x = values(*cpu, name), y = values(*cuda, name);
    INFO(name);
    CHECK(std::memcmp(x.data(), y.data(), x.size() * sizeof(double)) == 0);
  }
  CHECK(phi_metric(*cpu, Backend::cpu) == phi_metric(*cuda, Backend::cuda));
}
