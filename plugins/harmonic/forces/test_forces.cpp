// harmonic.forces on hand-made states (neighbors.verlet builds the list): a single contact
// gives exactly ±k (σ_ij − r) r̂ (across the periodic boundary too), nothing beyond σ_ij, a dense
// random packing equals a direct O(N²) double-precision sum, CPU and CUDA give the same bits.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <random>

#include "core/base/error.h"
#include "support/backends.h"
#include "support/fields.h"
#include "support/stage_driver.h"
#include "support/test_plugins.h"

using namespace ff;

namespace {

const Registry& registry() {
  static const auto r = test::registry_with({"harmonic"});
  return *r;
}

// n particles in a box of side L: positions x (n x dim) and diameters sigma.
std::unique_ptr<State> state(int dim, Precision p, double L, const std::vector<double>& x,
                             const std::vector<double>& sigma) {
  auto s = std::make_unique<State>(dim, p, sigma.size());
  for (int c = 0; c < dim; ++c) s->box.L[c] = L;
  Field& fx = s->field(fields::position);
  Field& fd = s->field(fields::diameter);
  fx.acquire(Where::host, Mode::write);
  fd.acquire(Where::host, Mode::write);
  auto put = [p](Field& f, std::size_t i, double v) {
    if (p == Precision::f64) f.host<double>()[i] = v;
    else f.host<float>()[i] = float(v);
  };
  for (std::size_t i = 0; i < x.size(); ++i) put(fx, i, x[i]);
  for (std::size_t i = 0; i < sigma.size(); ++i) put(fd, i, sigma[i]);
  return s;
}

using test::values;

// Runs neighbors.verlet then harmonic.forces once; returns the `pairs` metric.
double forces(State& s, Backend b, double k, double cutoff = 1.5) {
  ParamValues verlet_p, forces_p;
  verlet_p.set("cutoff", cutoff);
  verlet_p.set("skin", 0.3);
  forces_p.set("k", k);
  test::StageDriver verlet(registry(), "neighbors.verlet", b, s.precision(), s.dim(), verlet_p, 1);
  test::StageDriver harmonic(registry(), "harmonic.forces", b, s.precision(), s.dim(), forces_p, 1);
  verlet.stage->configure(s);
  harmonic.stage->configure(s);
  verlet.step(s, 0, 0.01);
  harmonic.step(s, 0, 0.01);
  return harmonic.metric("pairs");
}

// Σ_j k (σ_ij − r) r̂_ij over all j ≠ i with r < σ_ij, in double (minimum image); counts pairs.
std::vector<double> direct_sum(State& s, double k, std::size_t& pairs) {
  const auto x = values(s, fields::position), sigma = values(s, fields::diameter);
  const int D = s.dim();
  std::vector<double> f(x.size(), 0.0);
  pairs = 0;
  for (std::size_t i = 0; i < s.n(); ++i)
    for (std::size_t j = 0; j < s.n(); ++j) {
      if (j == i) continue;
      double d[3], r2 = 0;
      for (int c = 0; c < D; ++c) {
        d[c] = x[i * D + c] - x[j * D + c];
        d[c] -= s.box.L[c] * std::rint(d[c] / s.box.L[c]);
        r2 += d[c] * d[c];
      }
      const double r = std::sqrt(r2), sij = 0.5 * (sigma[i] + sigma[j]);
      if (r >= sij) continue;
      pairs += j > i;
      for (int c = 0; c < D; ++c) f[i * D + c] += k * (sij - r) * d[c] / r;
    }
  return f;
}

// A dense random packing: uniform positions, diameters in [0.8, 1.2], packing fraction ~0.9.
std::unique_ptr<State> dense(int dim, Precision p) {
  const std::size_t n = dim == 2 ? 600 : 500;
  const double L = dim == 2 ? std::sqrt(n * 0.785 / 0.9) : std::cbrt(n * 0.524 / 0.9);
  std::mt19937_64 gen(7);
  std::uniform_real_distribution<double> u(0, L), size(0.8, 1.2);
  std::vector<double> x(n * dim), sigma(n);
  for (auto& v : x) v = u(gen);
  for (auto& v : sigma) v = size(gen);
  return state(dim, p, L, x, sigma);
}

}  // namespace

TEST_CASE("harmonic.forces: one contact gives exactly ±k (σ_ij − r) r̂, across the boundary too", "[harmonic]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  INFO(to_string(b) << ", " << dim << "D, " << to_string(p));
  const double L = 8, k = 100;
  struct Contact { double xi, xj; int axis; double si, sj, overlap; };  // x along `axis`, 4 elsewhere
  // r = 0.5 through the boundary (0.25 and 7.75), σ_ij = 1: F = 50; r = 0.5, σ_ij = 1.25: F = 75.
  for (const Contact& t : {Contact{0.25, 7.75, 0, 1.0, 1.0, 0.5}, Contact{4.5, 4.0, dim - 1, 1.0, 1.5, 0.75}}) {
    std::vector<double> x(2 * dim, 4.0);
    x[t.axis] = t.xi;
    x[dim + t.axis] = t.xj;
    auto s = state(dim, p, L, x, {t.si, t.sj});
    CHECK(forces(*s, b, k) == 1);
    const auto f = values(*s, "force");
    for (int c = 0; c < dim; ++c) {
      CHECK(f[c] == (c == t.axis ? k * t.overlap : 0.0));  // +x̂ (or +ẑ): i is pushed away from j
      CHECK(f[dim + c] == -f[c]);                           // Newton's third law
    }
  }
  // Off-axis: d = (0.3, 0.4[, 0]), r = 0.5, σ = 1: F_i = k·0.5·(0.6, 0.8[, 0]).
  std::vector<double> x(2 * dim, 4.0);
  x[0] = 4.3;
  x[1] = 4.4;
  auto s = state(dim, p, L, x, {1.0, 1.0});
  forces(*s, b, k);
  const auto f = values(*s, "force");
  const double tol = p == Precision::f64 ? 1e-12 : 1e-5;
  CHECK(f[0] == Approx(30).epsilon(tol));
  CHECK(f[1] == Approx(40).epsilon(tol));
  for (int c = 0; c < dim; ++c) CHECK(f[dim + c] == -f[c]);
}

TEST_CASE("harmonic.forces: no force at or beyond σ_ij", "[harmonic]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  INFO(to_string(b) << ", " << dim << "D");
  for (double r : {1.0, 1.001, 1.4}) {  // listed (Verlet cutoff 1.5 + skin), but not touching
    std::vector<double> x(2 * dim, 4.0);
    x[dim] = 4.0 + r;
    auto s = state(dim, Precision::f64, 8, x, {1.0, 1.0});
    CHECK(forces(*s, b, 100) == 0);
    for (double v : values(*s, "force")) CHECK(v == 0.0);
  }
}

TEST_CASE("harmonic.forces: a dense random packing equals the direct O(N²) sum", "[harmonic]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  INFO(to_string(b) << ", " << dim << "D, " << to_string(p));
  auto s = dense(dim, p);
  const double listed_pairs = forces(*s, b, 100, 1.2);
  std::size_t pairs = 0;
  const auto want = direct_sum(*s, 100, pairs);
  const auto got = values(*s, "force");
  double err2 = 0, norm2 = 0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    err2 += (got[i] - want[i]) * (got[i] - want[i]);
    norm2 += want[i] * want[i];
  }
  INFO("relative error " << std::sqrt(err2 / norm2) << ", overlapping pairs " << pairs);
  CHECK(pairs > s->n());  // dense: more contacts than particles
  CHECK(std::sqrt(err2 / norm2) <= (p == Precision::f64 ? 1e-12 : 1e-5));
  if (p == Precision::f64) CHECK(listed_pairs == double(pairs));
}

TEST_CASE("harmonic.forces: CPU and CUDA give the same bits", "[harmonic][cuda]") {
  if (!test::have_cuda("harmonic.forces CPU vs CUDA")) return;
  const int dim = GENERATE(2, 3);
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  INFO(dim << "D, " << to_string(p));
  auto cpu = dense(dim, p), cuda = dense(dim, p);
  CHECK(forces(*cpu, Backend::cpu, 100, 1.2) == forces(*cuda, Backend::cuda, 100, 1.2));
  const auto a = values(*cpu, "force"), c = values(*cuda, "force");
  CHECK(std::memcmp(a.data(), c.data(), a.size() * sizeof(double)) == 0);
}

TEST_CASE("harmonic.forces: a missing or too short Verlet list is an input error naming the key", "[harmonic]") {
  auto s = dense(2, Precision::f64);
  ParamValues v;
  v.set("k", 100.0);
  test::StageDriver alone(registry(), "harmonic.forces", Backend::cpu, Precision::f64, 2, v, 1);
  CHECK_THROWS_WITH(alone.stage->configure(*s), Catch::Contains("neighbors.verlet"));
  CHECK_THROWS_WITH(forces(*s, Backend::cpu, 100, 1.0), Catch::Contains("raise neighbors.verlet's `cutoff`"));
}
