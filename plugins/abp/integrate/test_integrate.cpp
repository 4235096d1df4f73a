// abp.integrate driven alone on hand-made states (no YAML, no other stage): the ABP mean-square
// displacement and orientation correlation against the formulas (2D and 3D, float and double),
// random initial orientations, bit-identical reruns, the `force` field ignored, CPU vs CUDA.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <memory>
#include <vector>

#include "core/base/error.h"
#include "core/stage/registry.h"
#include "core/stage/state.h"
#include "support/backends.h"
#include "support/fields.h"
#include "support/stage_driver.h"
#include "support/test_plugins.h"

using namespace ff;

namespace {

const Registry& registry() {
  static const std::unique_ptr<Registry> r = test::registry_of({}, {"abp"});
  return *r;
}

// abp.integrate with (v0, Dr, D), driven step by step (support/stage_driver.h).
struct Run : test::StageDriver {
  Run(Backend b, Precision p, int dim, std::uint64_t seed, double v0, double Dr, double D)
      : StageDriver(registry(), "abp.integrate", b, p, dim, params(v0, Dr, D), seed) {}
  static ParamValues params(double v0, double Dr, double D) {
    ParamValues v;
    v.set("v0", v0);
    v.set("Dr", Dr);
    v.set("D", D);
    return v;
  }
};

// N particles on a coarse grid in a box of edge L (positions only matter through unwrapping).
std::unique_ptr<State> make_state(int dim, Precision p, std::size_t n, double L) {
  auto s = std::make_unique<State>(dim, p, n);
  for (int k = 0; k < dim; ++k) s->box.L[k] = L;
  Field& x = s->field(fields::position);
  for (std::size_t i = 0; i < n; ++i)
    for (int k = 0; k < dim; ++k) {
      const double v = std::fmod(0.37 * double(i) * (k + 1) + 0.5 * k, L);
      if (p == Precision::f64) x.host<double>()[i * dim + k] = v;
      else x.host<float>()[i * dim + k] = float(v);
    }
  return s;
}

using test::values;

std::vector<double> unwrapped(State& s) {
  auto u = values(s, fields::position);
  Field& im = s.field(fields::image);
  im.acquire(Where::host, Mode::read);
  for (std::size_t i = 0; i < u.size(); ++i) u[i] += im.host<std::int32_t>()[i] * s.box.L[i % s.dim()];
  return u;
}

// Unit orientation vectors (2D: from θ).
std::vector<double> directions(State& s) {
  auto o = values(s, "orientation");
  if (s.dim() == 3) return o;
  std::vector<double> e(2 * o.size());
  for (std::size_t i = 0; i < o.size(); ++i) {
    e[2 * i] = std::cos(o[i]);
    e[2 * i + 1] = std::sin(o[i]);
  }
  return e;
}

struct MeanSe {
  double mean, se;
};
MeanSe mean_se(const std::vector<double>& v) {
  double m = 0, m2 = 0;
  for (double x : v) m += x;
  m /= double(v.size());
  for (double x : v) m2 += (x - m) * (x - m);
  return {m, std::sqrt(m2 / double(v.size() - 1) / double(v.size()))};
}

// ABP MSD in d dimensions: 2dDt + 2v0²/((d-1)Dr)² ((d-1)Dr t + exp(-(d-1)Dr t) - 1).
double abp_msd(int d, double v0, double Dr, double D, double t) {
  const double g = (d - 1) * Dr;
  return 2 * d * D * t + 2 * v0 * v0 / (g * g) * (g * t + std::exp(-g * t) - 1);
}

}  // namespace

TEST_CASE("abp.integrate: MSD and orientation correlation match the ABP formulas within 3 SE",
          "[abp][physics]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  INFO("backend " << to_string(b) << ", " << dim << "D, " << to_string(p));
  const std::size_t n = 10000;
  const double v0 = 1.0, Dr = 0.5, D = 0.05, dt = 0.01, L = 50;
  auto s = make_state(dim, p, n, L);
  Run run(b, p, dim, 2024, v0, Dr, D);
  run.stage->configure(*s);
  const auto u0 = unwrapped(*s);
  const auto e0 = directions(*s);
  std::uint64_t k = 0;
  for (int checkpoint : {50, 150, 300}) {  // t = 0.5, 1.5, 3 (ballistic to crossover)
    for (; k < std::uint64_t(checkpoint); ++k) run.step(*s, k, dt);
    const double t = checkpoint * dt;
    const auto u = unwrapped(*s);
    const auto e = directions(*s);
    std::vector<double> d2(n, 0.0), corr(n, 0.0);
    for (std::size_t i = 0; i < u.size(); ++i) d2[i / dim] += (u[i] - u0[i]) * (u[i] - u0[i]);
    for (std::size_t i = 0; i < e.size(); ++i) corr[i / dim] += e[i] * e0[i];
    const auto msd = mean_se(d2);
    const auto c = mean_se(corr);
    const double want = abp_msd(dim, v0, Dr, D, t);
    INFO("t = " << t << ": MSD " << msd.mean << " ± " << msd.se << ", formula " << want << "; <e(t)·e(0)> "
                << c.mean << " ± " << c.se << ", formula " << std::exp(-(dim - 1) * Dr * t));
    CHECK(std::fabs(msd.mean - want) < 3 * msd.se);
    CHECK(std::fabs(c.mean - std::exp(-(dim - 1) * Dr * t)) < 3 * c.se);
  }
  // Wrapped positions stay in the box; 3D orientations stay unit vectors.
  const auto x = values(*s, fields::position);
  for (double v : x) REQUIRE((v >= 0 && v < L));
  if (dim == 3) {
    const auto o = values(*s, "orientation");
    const double tol = p == Precision::f64 ? 1e-12 : 1e-5;
    for (std::size_t i = 0; i < n; ++i)
      REQUIRE(std::fabs(o[3 * i] * o[3 * i] + o[3 * i + 1] * o[3 * i + 1] + o[3 * i + 2] * o[3 * i + 2] - 1) < tol);
  }
}

TEST_CASE("abp.integrate: pure propulsion moves each particle by v0·Δt along its orientation", "[abp]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  auto s = make_state(dim, Precision::f64, 100, 20);
  Run run(b, Precision::f64, dim, 1, 2.0, 0.0, 0.0);
  run.stage->configure(*s);
  const auto u0 = unwrapped(*s);
  const auto e0 = directions(*s);
  run.step(*s, 0, 0.1);
  const auto u1 = unwrapped(*s);
  for (std::size_t i = 0; i < u0.size(); ++i) REQUIRE(u1[i] - u0[i] == Approx(0.2 * e0[i]).margin(1e-12));
  const auto e1 = directions(*s);  // Dr = 0: the orientation does not change
  for (std::size_t i = 0; i < e0.size(); ++i) REQUIRE(e1[i] == Approx(e0[i]).margin(1e-12));
}

TEST_CASE("abp.integrate: initial orientations are uniform (2D angles, 3D unit sphere)", "[abp][init]") {
  const int dim = GENERATE(2, 3);
  const std::size_t n = 40000;
  auto s = make_state(dim, Precision::f64, n, 10);
  Run run(Backend::cpu, Precision::f64, dim, 5, 1, 1, 0);
  run.stage->configure(*s);
  const auto e = directions(*s);
  for (int k = 0; k < dim; ++k) {
    std::vector<double> c(n), c2(n);
    for (std::size_t i = 0; i < n; ++i) {
      c[i] = e[i * dim + k];
      c2[i] = e[i * dim + k] * e[i * dim + k];
    }
    const auto m = mean_se(c), m2 = mean_se(c2);
    INFO("component " << k << ": <e> = " << m.mean << " ± " << m.se << ", <e²> = " << m2.mean << " ± " << m2.se);
    CHECK(std::fabs(m.mean) < 3 * m.se);
    CHECK(std::fabs(m2.mean - 1.0 / dim) < 3 * m2.se);
  }
  if (dim == 2) {  // angles lie in [-π, π)
    for (double th : values(*s, "orientation")) REQUIRE((th >= -M_PI && th < M_PI));
  }
}

TEST_CASE("abp.integrate: an existing orientation field is kept; a misshapen one is an InputError", "[abp][init]") {
  auto s = make_state(2, Precision::f64, 10, 10);
  Field& o = s->add_particle_field("orientation", DType::f64, 1);
  for (std::size_t i = 0; i < 10; ++i) o.host<double>()[i] = 0.25 * double(i);
  Run run(Backend::cpu, Precision::f64, 2, 5, 1, 1, 0);
  run.stage->configure(*s);
  for (std::size_t i = 0; i < 10; ++i) CHECK(s->field("orientation").host<double>()[i] == 0.25 * double(i));

  auto s3 = make_state(3, Precision::f64, 10, 10);
  s3->add_particle_field("orientation", DType::f64, 1);  // 3D needs a unit vector
  Run run3(Backend::cpu, Precision::f64, 3, 5, 1, 1, 0);
  CHECK_THROWS_AS(run3.stage->configure(*s3), InputError);
}

TEST_CASE("abp.integrate: same seed gives identical bits, another seed does not; `force` is ignored",
          "[abp][determinism]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  auto trajectory = [&](std::uint64_t seed, bool with_force) {
    auto s = make_state(dim, Precision::f64, 3000, 30);
    if (with_force) {
      Field& f = s->add_particle_field("force", DType::f64, dim);
      for (std::size_t i = 0; i < f.size(); ++i) f.host<double>()[i] = 1e6 * (i % 7 ? 1.0 : -3.0);
    }
    Run run(b, Precision::f64, dim, seed, 1.5, 0.7, 0.2);
    run.stage->configure(*s);
    for (std::uint64_t k = 0; k < 25; ++k) run.step(*s, k, 0.01);
    auto u = unwrapped(*s);
    auto o = values(*s, "orientation");
    u.insert(u.end(), o.begin(), o.end());
    return u;
  };
  const auto a = trajectory(11, false);
  const auto again = trajectory(11, false);
  const auto forced = trajectory(11, true);
  const auto other = trajectory(12, false);
  CHECK(std::memcmp(a.data(), again.data(), a.size() * sizeof(double)) == 0);
  CHECK(std::memcmp(a.data(), forced.data(), a.size() * sizeof(double)) == 0);
  CHECK(std::memcmp(a.data(), other.data(), a.size() * sizeof(double)) != 0);
}

TEST_CASE("abp.integrate: CPU and CUDA give the same trajectory", "[abp][cuda]") {
  if (!test::have_cuda("abp.integrate CPU vs CUDA")) return;
  const int dim = GENERATE(2, 3);
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  auto trajectory = [&](Backend b) {
    auto s = make_state(dim, p, 5000, 40);
    Run run(b, p, dim, 77, 1.0, 0.3, 0.1);
    run.stage->configure(*s);
    for (std::uint64_t k = 0; k < 50; ++k) run.step(*s, k, 0.01);
    auto u = unwrapped(*s);
    auto o = values(*s, "orientation");
    u.insert(u.end(), o.begin(), o.end());
    return u;
  };
  const auto c = trajectory(Backend::cpu);
  const auto g = trajectory(Backend::cuda);
  const double tol = p == Precision::f64 ? 1e-10 : 1e-4;  // libm vs CUDA cos/sin/sqrt, last ulps
  double worst = 0;
  for (std::size_t i = 0; i < c.size(); ++i) worst = std::max(worst, std::fabs(c[i] - g[i]));
  INFO("largest |CPU - CUDA| = " << worst);
  CHECK(worst < tol);
}
