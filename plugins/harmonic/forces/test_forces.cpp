// harmonic.forces against its formula (neighbors.verlet builds the list): one contact gives
// exactly ±k (σ_ij − r) r̂, across the periodic boundary too; nothing at or beyond σ_ij; in a dense
// random packing every force equals a direct O(N²) double-precision sum, the forces add up to zero
// (Newton's third law) and `pairs` counts the overlaps; CPU and CUDA give the same bits.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <random>

#include "core/stage/stage_registration.h"
#include "support/backends.h"
#include "support/fields.h"
#include "support/stage_driver.h"
#include "support/test_plugins.h"

using namespace ff;
using test::values;

namespace {

// Particles of diameters sigma at positions x (n x dim) in a periodic box of side L.
std::unique_ptr<State> state(int dim, Precision p, double L, std::vector<double> x, std::vector<double> sigma) {
  auto s = std::make_unique<State>(dim, p, sigma.size());
  for (int c = 0; c < dim; ++c) s->box.L[c] = L;
  for (auto [name, v] : {std::pair{fields::position, &x}, std::pair{fields::diameter, &sigma}}) {
    Field& f = s->field(name);
    f.acquire(Where::host, Mode::write);
    for (std::size_t i = 0; i < v->size(); ++i)
      if (p == Precision::f64) f.host<double>()[i] = (*v)[i];
      else f.host<float>()[i] = float((*v)[i]);
  }
  return s;
}

const Registry& registry() {
  static const auto r = test::registry_with({"harmonic"});
  return *r;
}

// neighbors.verlet (cutoff, skin 0.3), then harmonic.forces (k), once; returns the `pairs` metric.
double forces(State& s, Backend b, double k, double cutoff = 1.5) {
  test::StageDriver verlet(registry(), "neighbors.verlet", b, s.precision(), s.dim(),
                           param_values({{"cutoff", cutoff}, {"skin", 0.3}}), 1);
  test::StageDriver harmonic(registry(), "harmonic.forces", b, s.precision(), s.dim(), param_values({{"k", k}}), 1);
  verlet.stage->configure(s);
  harmonic.stage->configure(s);
  verlet.step(s, 0, 0.01);
  harmonic.step(s, 0, 0.01);
  return harmonic.metric("pairs");
}

// A dense random packing: diameters in [0.8, 1.2], packing fraction ~0.9.
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
  const double k = 100;
  struct Contact { double xi, xj; int axis; double si, sj, overlap; };  // x along `axis`, 4 elsewhere
  // r = 0.5 through the boundary (0.25 and 7.75), σ_ij = 1: F = 50; r = 0.5, σ_ij = 1.25: F = 75.
  for (const Contact& t : {Contact{0.25, 7.75, 0, 1.0, 1.0, 0.5}, Contact{4.5, 4.0, dim - 1, 1.0, 1.5, 0.75}}) {
    std::vector<double> x(2 * dim, 4.0);
    x[t.axis] = t.xi;
    x[dim + t.axis] = t.xj;
    auto s = state(dim, p, 8, x, {t.si, t.sj});
    CHECK(forces(*s, b, k) == 1);
    const auto f = values(*s, "force");
    for (int c = 0; c < dim; ++c) {
      CHECK(f[c] == (c == t.axis ? k * t.overlap : 0.0));  // dyadic numbers: exact in float too
      CHECK(f[dim + c] == -f[c]);                           // Newton's third law, bit for bit
    }
  }
  // Off axis: d = (0.3, 0.4[, 0]), r = 0.5, σ_ij = 1: F_i = k·0.5·(0.6, 0.8[, 0]).
  std::vector<double> x(2 * dim, 4.0);
  x[0] = 4.3;
  x[1] = 4.4;
  auto s = state(dim, p, 8, x, {1.0, 1.0});
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

TEST_CASE("harmonic.forces: a dense packing equals the direct O(N²) sum, and its forces add up to zero",
          "[harmonic]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  INFO(to_string(b) << ", " << dim << "D, " << to_string(p));
  auto s = dense(dim, p);
  const double listed_pairs = forces(*s, b, 100, 1.2);
  const auto x = values(*s, fields::position), sigma = values(*s, fields::diameter), got = values(*s, "force");
  std::vector<double> want(x.size(), 0.0), total(dim, 0.0);
  std::size_t pairs = 0;
  for (std::size_t i = 0; i < s->n(); ++i)  // F_i = Σ_{j ≠ i, r < σ_ij} k (σ_ij − r) d / r, minimum image
    for (std::size_t j = 0; j < s->n(); ++j) {
      double d[3], r2 = 0;
      for (int c = 0; c < dim; ++c) {
        d[c] = x[i * dim + c] - x[j * dim + c];
        d[c] -= s->box.L[c] * std::rint(d[c] / s->box.L[c]);
        r2 += d[c] * d[c];
      }
      const double r = std::sqrt(r2), sij = 0.5 * (sigma[i] + sigma[j]);
      if (j == i || r >= sij) continue;
      pairs += j > i;
      for (int c = 0; c < dim; ++c) want[i * dim + c] += 100 * (sij - r) * d[c] / r;
    }
  double err2 = 0, norm2 = 0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    err2 += (got[i] - want[i]) * (got[i] - want[i]);
    norm2 += want[i] * want[i];
    total[i % dim] += got[i];
  }
  const double tol = p == Precision::f64 ? 1e-12 : 1e-5;
  INFO("relative error " << std::sqrt(err2 / norm2) << ", overlapping pairs " << pairs);
  CHECK(pairs > s->n());  // dense: more contacts than particles
  CHECK(std::sqrt(err2 / norm2) <= tol);
  for (int c = 0; c < dim; ++c) CHECK(std::abs(total[c]) <= tol * std::sqrt(norm2));  // Σ_i F_i = 0
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
  test::StageDriver alone(registry(), "harmonic.forces", Backend::cpu, Precision::f64, 2, param_values({{"k", 100.0}}), 1);
  CHECK_THROWS_WITH(alone.stage->configure(*s), Catch::Contains("neighbors.verlet"));
  CHECK_THROWS_WITH(forces(*s, Backend::cpu, 100, 1.0), Catch::Contains("raise neighbors.verlet's `cutoff`"));
}
