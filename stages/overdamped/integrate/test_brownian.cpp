// brownian.integrate: free-diffusion MSD, determinism across thread counts, CPU vs CUDA.
#include <oneapi/tbb/global_control.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>

#include "core/run/simulation.h"
#include "support/backends.h"
#include "support/spec.h"
#include "support/fields.h"
#include "support/test_plugins.h"

using namespace ff;
using ff::test::dry;
using ff::test::entry;

namespace {
using test::unwrapped;
// MSD after `steps` steps and its standard error over particles.
template <class R>
std::pair<double, double> msd(int dim, Backend b, Precision p) {
  auto r = test::registry_with({"brownian"});
  const std::uint64_t n = 1u << 14;
  auto s = test::spec(dim, n, 0.05, 50, 0.02, {entry(*r, "brownian.integrate", {{"D", 0.5}})}, 7, p);
  Simulation sim(s, *r, dry(b));
  const auto u0 = unwrapped<R>(sim.state());
  for (int k = 0; k < 50; ++k) sim.advance();
  const auto u1 = unwrapped<R>(sim.state());
  std::vector<double> d2(n, 0.0);
  for (std::size_t i = 0; i < u0.size(); ++i) d2[i / dim] += (u1[i] - u0[i]) * (u1[i] - u0[i]);
  double m = 0, m2 = 0;
  for (double v : d2) {
    m += v;
    m2 += v * v;
  }
  m /= n;
  const double var = m2 / n - m * m;
  return {m, std::sqrt(var / n)};
}
}  // namespace

TEST_CASE("free diffusion: MSD = 2·d·D·t within 3 standard errors (N = 2^14)", "[brownian][physics]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  INFO("backend " << to_string(b) << ", " << dim << "D");
  const double t = 50 * 0.02, D = 0.5;
  const auto [m, se] = msd<double>(dim, b, Precision::f64);
  CHECK(std::fabs(m - 2 * dim * D * t) < 3 * se);
  const auto [mf, sef] = msd<float>(dim, b, Precision::f32);
  CHECK(std::fabs(mf - 2 * dim * D * t) < 3 * sef);
}

TEST_CASE("CPU runs are bit-identical for 1, 2 and 4 threads", "[brownian][determinism]") {
  auto r = test::registry_with({"brownian"});
  auto s = test::spec(2, 20000, 0.3, 20, 0.01, {entry(*r, "brownian.integrate", {{"D", 1.0}})}, 99);
  std::vector<std::vector<double>> results;
  for (int threads : {1, 2, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    Simulation sim(s, *r, dry());
    for (int k = 0; k < 20; ++k) sim.advance();
    results.push_back(unwrapped<double>(sim.state()));
  }
  for (std::size_t k = 1; k < results.size(); ++k)
    CHECK(std::memcmp(results[k].data(), results[0].data(), results[0].size() * sizeof(double)) == 0);
}

TEST_CASE("CPU and CUDA free Brownian steps agree to 1e-12 relative (double)", "[brownian][cuda]") {
  if (!test::have_cuda("brownian CPU-vs-CUDA")) return;
  auto r = test::registry_with({"brownian"});
  for (int dim : {2, 3}) {
    auto s = test::spec(dim, 50000, 0.3, 10, 0.01, {entry(*r, "brownian.integrate", {{"D", 1.0}})}, 5);
    Simulation cpu(s, *r, dry(Backend::cpu));
    Simulation gpu(s, *r, dry(Backend::cuda));
    for (int k = 0; k < 10; ++k) {
      cpu.advance();
      gpu.advance();
    }
    // From the second step on, the CUDA step replays a captured graph: same numbers.
    CHECK(gpu.scheduler().step_is_captured());
    const auto a = unwrapped<double>(cpu.state());
    const auto b = unwrapped<double>(gpu.state());
    double worst = 0;
    for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::fabs(a[i] - b[i]) / std::max(1.0, std::fabs(a[i])));
    INFO(dim << "D worst relative difference " << worst);
    CHECK(worst <= 1e-12);
  }
}
