// pair.lj on hand-made states (neighbors.verlet builds the list, 2D and 3D, float and double):
// the force is −dU/dr of the energy it reports, the minimum is −ε at 2^{1/n} σ, the sum of all
// forces vanishes (Newton's third law), a jittered lattice equals a direct O(N²) sum, mixing
// rules and explicit matrices on two types, the energy shift, the skin does not change a bit,
// overlapping pairs stay finite, and input errors name the key. The CPU loop's vector lanes:
// test_lj_lanes.cpp; CPU vs CUDA: test_lj_cpu_cuda.cpp (helpers: test_support.h).
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "plugins/pair/lj/test_support.h"
#include "support/backends.h"
#include "support/fields.h"

using namespace ff;
using namespace ff::lj_test;
using test::values;

namespace {

double total(const std::vector<double>& v) {
  double t = 0;
  for (double x : v) t += x;
  return t;
}

// U(r) = 4ε[(σ/r)^{2n} − (σ/r)^n] and F(r) = −U'(r), in double.
double U(double r, double eps, double sigma, int n) {
  const double q = std::pow(sigma / r, n);
  return 4 * eps * (q * q - q);
}
double F(double r, double eps, double sigma, int n) {
  const double q = std::pow(sigma / r, n);
  return 4 * n * eps * (2 * q * q - q) / r;
}

// Two particles at distance r along the direction u (unit, dim entries), box 10; returns the
// force on particle 0 along u and the pair energy (the two halves summed).
struct Pair { double f, u; std::vector<double> force; };
Pair two(int dim, Precision p, Backend b, double r, const LJ& q, std::vector<double> u = {}) {
  if (u.empty()) u.assign(dim, 0.0), u[0] = 1;
  std::vector<double> x(2 * dim, 5.0);
  for (int c = 0; c < dim; ++c) x[dim + c] = 5.0 - r * u[c];  // d = x0 − x1 = r u
  auto s = state(dim, p, 10, x);
  run(*s, b, q);
  const auto f = values(*s, "force");
  double along = 0;
  for (int c = 0; c < dim; ++c) along += f[c] * u[c];
  return {along, total(values(*s, "pair.energy")), f};
}

// Direct O(N²) forces and total energy in double (minimum image), per-type ε/σ matrices.
struct Direct { std::vector<double> force; double energy = 0, virial = 0; };
Direct direct(State& s, const std::vector<double>& eps, const std::vector<double>& sig, int T, int n, double r_cut) {
  const auto x = values(s, fields::position);
  Field& tf = s.field(fields::type);
  tf.acquire(Where::host, Mode::read);
  const std::int32_t* t = tf.host<std::int32_t>();
  const int D = s.dim();
  Direct out;
  out.force.assign(x.size(), 0.0);
  for (std::size_t i = 0; i < s.n(); ++i)
    for (std::size_t j = 0; j < s.n(); ++j) {
      if (j == i) continue;
      double d[3], r2 = 0;
      for (int c = 0; c < D; ++c) {
        d[c] = x[i * D + c] - x[j * D + c];
        d[c] -= s.box.L[c] * std::rint(d[c] / s.box.L[c]);
        r2 += d[c] * d[c];
      }
      const int ab = T == 1 ? 0 : t[i] * T + t[j];
      const double r = std::sqrt(r2);
      if (r >= r_cut * sig[ab]) continue;
      out.energy += 0.5 * U(r, eps[ab], sig[ab], n);
      out.virial += 0.5 * r * F(r, eps[ab], sig[ab], n);
      for (int c = 0; c < D; ++c) out.force[i * D + c] += F(r, eps[ab], sig[ab], n) * d[c] / r;
    }
  return out;
}

double relative_error(const std::vector<double>& got, const std::vector<double>& want) {
  double err2 = 0, norm2 = 0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    err2 += (got[i] - want[i]) * (got[i] - want[i]);
    norm2 += want[i] * want[i];
  }
  return std::sqrt(err2 / norm2);
}

}  // namespace

TEST_CASE("pair.lj: the force is −dU/dr of the reported energy, and both follow the formula", "[pair]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  const int n = GENERATE(18, 6, 7);
  INFO(to_string(b) << ", " << dim << "D, n = " << n);
  LJ q;
  q.epsilon = 14;
  q.n = n;
  std::vector<double> u(dim, 0.0);  // an off-axis direction
  u[0] = 0.6;
  u[1] = 0.8;
  for (int k = 0; k < 20; ++k) {  // 20 separations in [0.95, 1.5) σ
    const double r = 0.95 + 0.55 * (k + 0.5) / 20, h = 1e-6;
    INFO("r = " << r);
    const Pair at = two(dim, Precision::f64, b, r, q, u);
    const double dUdr = (two(dim, Precision::f64, b, r + h, q, u).u - two(dim, Precision::f64, b, r - h, q, u).u) / (2 * h);
    CHECK(at.f == Approx(-dUdr).epsilon(1e-6).margin(1e-6));
    CHECK(at.f == Approx(F(r, 14, 1, n)).epsilon(1e-12));
    CHECK(at.u == Approx(U(r, 14, 1, n)).epsilon(1e-12).margin(1e-13));
    for (int c = 0; c < dim; ++c) CHECK(at.force[dim + c] == -at.force[c]);  // Newton's third law, exactly
    // float: within its rounding of the terms (4nε(2q² − q)/r cancels near the minimum)
    const Pair single = two(dim, Precision::f32, b, r, q, u);
    CHECK(std::fabs(single.f - at.f) <= 1e-5 * (std::fabs(at.f) + 4 * n * 14));
    CHECK(std::fabs(single.u - at.u) <= 1e-5 * (std::fabs(at.u) + 4 * 14));
  }
}

TEST_CASE("pair.lj: the minimum is −ε at r = 2^{1/n} σ with no force", "[pair]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  const int n = GENERATE(18, 6, 7);
  INFO(to_string(b) << ", " << dim << "D, n = " << n);
  LJ q;
  q.epsilon = 14;
  q.n = n;
  const double rm = std::pow(2.0, 1.0 / n);
  const Pair at = two(dim, Precision::f64, b, rm, q);
  CHECK(at.u == Approx(-14).epsilon(1e-13));
  CHECK(std::fabs(at.f) < 1e-11 * 4 * n * 14);  // 2q² − q = 0 up to the rounding of q = 1/2
  // Either side: repulsive inside, attractive outside, both above −ε.
  const Pair in = two(dim, Precision::f64, b, rm * 0.99, q), out = two(dim, Precision::f64, b, rm * 1.01, q);
  CHECK(in.f > 0);
  CHECK(out.f < 0);
  CHECK(in.u > at.u);
  CHECK(out.u > at.u);
  // Tran's numbers (../shared/specs/seed-gaps.md T1): V(σ) = 0, F(σ) = 72ε/σ at n = 18.
  if (n == 18) {
    const Pair contact = two(dim, Precision::f64, b, 1.0, q);
    CHECK(contact.u == Approx(0).margin(1e-12));
    CHECK(contact.f == Approx(1008).epsilon(1e-13));
    CHECK(two(dim, Precision::f64, b, 1.1, q).u == Approx(-8.26).epsilon(2e-3));
  }
}

TEST_CASE("pair.lj: the forces of a jittered lattice sum to zero and equal the direct sum", "[pair]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  INFO(to_string(b) << ", " << dim << "D, " << to_string(p));
  auto s = lattice(dim, p);
  LJ q;
  q.epsilon = 14;
  run(*s, b, q);
  const Direct want = direct(*s, {14}, {1}, 1, 18, 1.5);
  const auto got = values(*s, "force");
  const double tol = p == Precision::f64 ? 1e-12 : 1e-5;
  CHECK(relative_error(got, want.force) <= tol);
  CHECK(total(values(*s, "pair.energy")) == Approx(want.energy).epsilon(tol));
  CHECK(total(values(*s, "pair.virial")) == Approx(want.virial).epsilon(tol));
  double sum[3] = {0, 0, 0}, magnitude = 0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    sum[i % dim] += got[i];
    magnitude += std::fabs(got[i]);
  }
  INFO("Σ|F| = " << magnitude);
  CHECK(magnitude > 100.0 * s->n());  // the lattice is compressed enough for large forces
  for (int c = 0; c < dim; ++c) CHECK(std::fabs(sum[c]) <= (p == Precision::f64 ? 1e-13 : 1e-6) * magnitude);
}

TEST_CASE("pair.lj: per-type ε and σ by mixing rule or explicit matrix", "[pair]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  INFO(to_string(b) << ", " << dim << "D");
  // Three isolated pairs AA, BB, AB (10 σ apart), each at 1.1 σ_ab; box 30.
  auto pairs = [&](const LJ& q, const double sig[3]) {
    std::vector<double> x;
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 2; ++a)
        for (int c = 0; c < dim; ++c) x.push_back(c == 0 ? 5.0 + 10 * k + a * 1.1 * sig[k] : 5.0);
    auto s = state(dim, Precision::f64, 30, x, {0, 0, 1, 1, 0, 1}, {}, {"A", "B"});
    run(*s, b, q);
    return s;
  };
  const double mixed_sigma[2][3] = {{1, 2, 1.5}, {1, 2, std::sqrt(2.0)}};  // lorentz-berthelot, geometric
  for (int rule = 0; rule < 2; ++rule) {
    LJ q;
    q.eps_list = {1, 4};
    q.sigma = {1, 2};
    q.mixing = rule == 0 ? "lorentz-berthelot" : "geometric";
    q.cutoff = 3.2;  // r_cut · σ_BB = 3
    const double* sig = mixed_sigma[rule];
    const double eps[3] = {1, 4, 2};
    auto s = pairs(q, sig);
    const auto f = values(*s, "force"), e = values(*s, "pair.energy");
    for (int k = 0; k < 3; ++k) {
      INFO(q.mixing << ", pair " << k);
      // particle 2k sits at −x of particle 2k + 1: its force along x is −F(r)
      CHECK(f[2 * k * dim] == Approx(-F(1.1 * sig[k], eps[k], sig[k], 18)).epsilon(1e-12));
      CHECK(e[2 * k] + e[2 * k + 1] == Approx(U(1.1 * sig[k], eps[k], sig[k], 18)).epsilon(1e-12));
    }
  }
  // The explicit matrix: ε_AB = 3, σ_AB = 1.2 (no rule gives these).
  LJ q;
  q.eps_list = {1, 3, 3, 4};
  q.sigma = {1, 1.2, 1.2, 2};
  q.cutoff = 3.2;
  const double sig[3] = {1, 2, 1.2}, eps[3] = {1, 4, 3};
  auto s = pairs(q, sig);
  const auto e = values(*s, "pair.energy");
  for (int k = 0; k < 3; ++k)
    CHECK(e[2 * k] + e[2 * k + 1] == Approx(U(1.1 * sig[k], eps[k], sig[k], 18)).epsilon(1e-12));
  // A two-type lattice against the direct sum.
  auto lat = lattice(dim, Precision::f64, {0, 1, 1});
  LJ m;
  m.eps_list = {14, 7, 7, 3};
  m.sigma = {1, 0.95, 0.95, 0.9};
  run(*lat, b, m);
  const Direct want = direct(*lat, {14, 7, 7, 3}, {1, 0.95, 0.95, 0.9}, 2, 18, 1.5);
  CHECK(relative_error(values(*lat, "force"), want.force) <= 1e-12);
  CHECK(total(values(*lat, "pair.energy")) == Approx(want.energy).epsilon(1e-12));
}

TEST_CASE("pair.lj: σ from the diameters, arithmetic or geometric", "[pair]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  INFO(to_string(b) << ", " << dim << "D");
  for (const char* rule : {"lorentz-berthelot", "geometric"}) {
    const double sij = std::string(rule) == "geometric" ? std::sqrt(1.0 * 1.6) : 1.3;
    std::vector<double> x(2 * dim, 5.0);
    x[0] = 5.0 + 1.1 * sij;
    auto s = state(dim, Precision::f64, 10, x, {}, {1.0, 1.6});
    LJ q;
    q.mixing = rule;
    q.cutoff = 2.5;
    run(*s, b, q);
    INFO(rule);
    CHECK(values(*s, "force")[0] == Approx(F(1.1 * sij, 1, sij, 18)).epsilon(1e-12));
  }
}

TEST_CASE("pair.lj: shift makes U(r_cut σ) = 0 and leaves the force alone", "[pair]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  const int n = GENERATE(18, 6);
  INFO(to_string(b) << ", " << dim << "D, n = " << n);
  LJ plain, shifted;
  plain.n = shifted.n = n;
  plain.r_cut = shifted.r_cut = 1.4;
  shifted.shift = true;
  const double below = 1.4 * (1 - 1e-9);
  const Pair edge = two(dim, Precision::f64, b, below, shifted);
  CHECK(std::fabs(edge.u) <= 2e-9 * std::fabs(F(1.4, 1, 1, n)));  // |U'(r_cut)| · 1.4e-9 σ
  CHECK(two(dim, Precision::f64, b, below, plain).u == Approx(U(1.4, 1, 1, n)).epsilon(1e-7));
  CHECK(U(1.4, 1, 1, n) < -1e-4);  // the shift is not nothing
  for (double r : {1.0, 1.1, 1.3}) {
    const Pair a = two(dim, Precision::f64, b, r, plain), c = two(dim, Precision::f64, b, r, shifted);
    CHECK(c.f == a.f);
    CHECK(c.u == Approx(a.u - U(1.4, 1, 1, n)).epsilon(1e-12));
  }
  // At and beyond the cutoff: nothing.
  const Pair out = two(dim, Precision::f64, b, 1.4 + 1e-9, shifted);
  CHECK(out.f == 0);
  CHECK(out.u == 0);
}

TEST_CASE("pair.lj: the Verlet skin does not change a bit", "[pair]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  INFO(to_string(b) << ", " << dim << "D, " << to_string(p));
  auto thin = lattice(dim, p), thick = lattice(dim, p);
  LJ q;
  q.skin = 0.05;
  run(*thin, b, q);
  q.skin = 0.8;
  q.cutoff = 1.8;
  run(*thick, b, q);
  const auto a = values(*thin, "force"), c = values(*thick, "force");
  CHECK(std::memcmp(a.data(), c.data(), a.size() * sizeof(double)) == 0);
}

TEST_CASE("pair.lj: overlapping particles get a finite repulsive force", "[pair]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  INFO(to_string(b) << ", " << to_string(p));
  LJ q;
  q.epsilon = 14;
  for (double r : {0.4, 0.1, 1e-4}) {
    const Pair at = two(3, p, b, r, q);
    INFO("r = " << r << ": F = " << at.f);
    CHECK(std::isfinite(at.f));
    CHECK(std::isfinite(at.u));
    CHECK(at.f > 0);
  }
  // Coincident: no direction, no force (and no NaN).
  const Pair zero = two(3, p, b, 0.0, q);
  CHECK(zero.f == 0);
}

TEST_CASE("pair.lj: input errors name the key", "[pair]") {
  auto s = lattice(3, Precision::f64, {0, 1});
  ParamValues v;
  test::StageDriver alone(registry(), "pair.lj", Backend::cpu, Precision::f64, 3, v, 1);
  CHECK_THROWS_WITH(alone.stage->configure(*s), Catch::Contains("neighbors.verlet"));
  LJ q;
  q.r_cut = 2.0;  // 2.0 > the list's 1.5
  CHECK_THROWS_WITH(run(*lattice(3, Precision::f64), Backend::cpu, q),
                    Catch::Contains("r_cut") && Catch::Contains("neighbors.verlet's cutoff 1.5"));
  LJ wide;
  wide.sigma = {1, 1.2};  // r_cut · σ_BB = 1.8 > 1.5
  CHECK_THROWS_WITH(run(*lattice(3, Precision::f64, {0, 1}), Backend::cpu, wide), Catch::Contains("r_cut"));
  LJ three;
  three.eps_list = {1, 2, 3};
  CHECK_THROWS_WITH(run(*lattice(3, Precision::f64, {0, 1}), Backend::cpu, three),
                    Catch::Contains("epsilon has 3 values"));
  LJ skew;
  skew.eps_list = {1, 2, 3, 4};
  CHECK_THROWS_WITH(run(*lattice(3, Precision::f64, {0, 1}), Backend::cpu, skew),
                    Catch::Contains("epsilon matrix is not symmetric"));
}
