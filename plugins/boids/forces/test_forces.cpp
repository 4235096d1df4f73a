// boids.forces against the rules of the reference program (../shared/specs/seed-gaps-code/
// boids_bruteforce.cpp, transcribed below: acos of the clamped cosine for the view angle, an O(N²)
// loop over every boid): the same steering on a small random state, across the periodic boundary,
// with boids hidden behind and beyond the view radius; the same bits from a neighbors.verlet list
// as from the list "every other boid" (rows ascending, so the source does not matter); CPU and CUDA
// give the same bits; a missing or too short list is an input error naming the key.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>

#include "plugins/boids/test_support.h"
#include "support/backends.h"

using namespace ff;
using namespace ff::boids;
using ff::test::values;

namespace {

struct Rules {
  double A = 0.0059, B = 0.0561, C = 0.0938, view_angle = 2.08, view_radius = 2.0;
};

struct Reference {
  std::vector<double> steering;  // N x 2: w − u of the reference program
  std::size_t seen = 0, behind = 0, across = 0;  // pairs seen; in range but behind; seen through the boundary
};

// boids_bruteforce.cpp's inner loop, its arithmetic kept: w − h = A s + [n > 0](C a/n + B c/n).
Reference reference(const std::vector<double>& x, const std::vector<double>& h, double L, const Rules& p) {
  const std::size_t N = x.size() / 2;
  auto mi = [&](double d) { return d - L * std::round(d / L); };
  Reference out;
  out.steering.assign(2 * N, 0.0);
  for (std::size_t i = 0; i < N; i++) {
    double sx = 0, sy = 0, ax = 0, ay = 0, cx = 0, cy = 0;
    int n = 0;
    for (std::size_t j = 0; j < N; j++) {
      if (j == i) continue;
      double dx = mi(x[2 * j] - x[2 * i]), dy = mi(x[2 * j + 1] - x[2 * i + 1]);
      double r = std::sqrt(dx * dx + dy * dy);
      if (r >= p.view_radius || r == 0) continue;
      double c = (dx * h[2 * i] + dy * h[2 * i + 1]) / r;
      if (c > 1) c = 1;
      if (c < -1) c = -1;
      if (std::acos(c) > p.view_angle) {
        ++out.behind;
        continue;
      }
      if (dx != x[2 * j] - x[2 * i] || dy != x[2 * j + 1] - x[2 * i + 1]) ++out.across;
      ++out.seen;
      n++;
      sx -= dx / r;
      sy -= dy / r;
      ax += h[2 * j];
      ay += h[2 * j + 1];
      cx += dx;
      cy += dy;
    }
    double wx = p.A * sx, wy = p.A * sy;
    if (n > 0) {
      wx += p.C * ax / n + p.B * cx / n;
      wy += p.C * ay / n + p.B * cy / n;
    }
    out.steering[2 * i] = wx;
    out.steering[2 * i + 1] = wy;
  }
  return out;
}

ff::test::ParamSettings settings(const Rules& p) {
  return {{"separation", p.A}, {"cohesion", p.B}, {"alignment", p.C}, {"view_angle", p.view_angle},
          {"view_radius", p.view_radius}};
}

// boids.forces once on s (its list already there), on backend b.
void steer(State& s, Backend b, const Rules& p) {
  auto forces = ff::test::make_stage(boids_test::registry(), "boids.forces", b, s.precision(), 2, settings(p));
  forces->configure(s);
  ff::test::StageDriver d(b, s.precision(), 2);
  REQUIRE_FALSE(d.run(*forces, s).rollback);
}

// boids.forces after neighbors.verlet (cutoff = view radius, skin 0.5).
void steer_verlet(State& s, Backend b, const Rules& p) {
  auto verlet = ff::test::make_stage(boids_test::registry(), "neighbors.verlet", b, s.precision(), 2,
                                     {{"cutoff", p.view_radius}, {"skin", 0.5}});
  verlet->configure(s);
  ff::test::StageDriver d(b, s.precision(), 2);
  REQUIRE_FALSE(d.run(*verlet, s).rollback);
  steer(s, b, p);
}

// 48 boids in a box of side 8 (about 8 in range each, a third of them behind).
std::unique_ptr<State> small_flock(Precision p) { return boids_test::random_boids(p, 48, 8.0, 3); }

}  // namespace

TEST_CASE("boids.forces: the reference program's steering on a small state, to 1e-12", "[boids]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  const Precision prec = GENERATE(Precision::f64, Precision::f32);
  INFO(to_string(b) << ", " << to_string(prec));
  for (const Rules& p : {Rules{}, Rules{0.3, 0.2, 0.5, 1.0, 1.5}, Rules{0.0059, 0.0561, 0.0938, kPi, 2.0}}) {
    auto s = small_flock(prec);
    boids_test::full_list(*s, p.view_radius);
    steer(*s, b, p);
    const auto want = reference(values(*s, fields::position), values(*s, kHeading), 8.0, p);
    const auto got = values(*s, kSteering);
    INFO("view angle " << p.view_angle << ": pairs seen " << want.seen << ", behind " << want.behind
                       << ", seen across the boundary " << want.across);
    CHECK(want.seen > s->n());                                // more than one neighbour each on average
    CHECK(want.across > 10);                                  // the periodic boundary matters
    CHECK((p.view_angle >= kPi) == (want.behind == 0));       // the blind sector matters
    const double tol = prec == Precision::f64 ? 1e-12 : 2e-6;
    double largest = 0;
    for (std::size_t k = 0; k < got.size(); ++k) {
      CHECK(std::abs(got[k] - want.steering[k]) <= tol);
      largest = std::max(largest, std::abs(want.steering[k]));
    }
    CHECK(largest > 0.01);  // not all zero
  }
}

TEST_CASE("boids.forces: a neighbors.verlet list gives the same bits as the list of every other boid", "[boids]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  INFO(to_string(b));
  auto full = small_flock(Precision::f64), verlet = small_flock(Precision::f64);
  boids_test::full_list(*full, 2.0);
  steer(*full, b, Rules{});
  steer_verlet(*verlet, b, Rules{});
  const auto a = values(*full, kSteering), c = values(*verlet, kSteering);
  CHECK(std::memcmp(a.data(), c.data(), a.size() * sizeof(double)) == 0);
}

TEST_CASE("boids.forces: CPU and CUDA give the same bits", "[boids][cuda]") {
  if (!ff::test::have_cuda("boids.forces CPU vs CUDA")) return;
  const Precision prec = GENERATE(Precision::f64, Precision::f32);
  auto cpu = small_flock(prec), cuda = small_flock(prec);
  steer_verlet(*cpu, Backend::cpu, Rules{});
  steer_verlet(*cuda, Backend::cuda, Rules{});
  const auto a = values(*cpu, kSteering), c = values(*cuda, kSteering);
  CHECK(std::memcmp(a.data(), c.data(), a.size() * sizeof(double)) == 0);
}

TEST_CASE("boids.forces: a missing or too short neighbour list is an input error naming the key", "[boids]") {
  auto s = small_flock(Precision::f64);
  auto forces = ff::test::make_stage(boids_test::registry(), "boids.forces", Backend::cpu, Precision::f64, 2);
  CHECK_THROWS_WITH(forces->configure(*s), Catch::Contains("neighbors.verlet"));
  boids_test::full_list(*s, 1.5);
  CHECK_THROWS_WITH(forces->configure(*s), Catch::Contains("raise the list's cutoff") && Catch::Contains("view_radius"));
}
