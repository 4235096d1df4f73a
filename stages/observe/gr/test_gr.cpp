// observe.gr: g(r) of an ideal gas is 1 within its counting error (2D, 3D); a perfect triangular
// lattice has its exact shells; the contact extrapolation; the CSV output; errors; thread-count
// independence. The stage's source is compiled into this test to drive it directly.
#include <oneapi/tbb/global_control.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "core/base/error.h"
#include "stages/observe/gr/stage.h"

using namespace ff;
using namespace ff::observe;

namespace {

constexpr double pi = 3.14159265358979323846;

std::unique_ptr<State> make_state(int dim, std::size_t n, const double* L, double sigma = 1.0) {
  auto s = std::make_unique<State>(dim, Precision::f64, n);
  for (int k = 0; k < dim; ++k) s->box.L[k] = L[k];
  Field& d = s->field(fields::diameter);
  for (std::size_t i = 0; i < n; ++i) d.host<double>()[i] = sigma;
  return s;
}

void set_positions(State& s, const std::vector<double>& x) {
  Field& f = s.field(fields::position);
  f.acquire(Where::host, Mode::write);
  std::copy(x.begin(), x.end(), f.host<double>());
}

// Drives one observer stage like the scheduler does (host fields, one call per "step").
struct Driver {
  State& s;
  RunInfo info;
  RunStats stats;
  Metrics metrics;
  std::uint64_t step = 0;

  void run(Stage& st) {
    metrics.clear();
    StepContext ctx{s, info, stats, step++, 0, 0.01, 0.0, Backend::cpu, nullptr, make_rng_key(1, "gr"), metrics};
    st.run(ctx);
  }
  double metric(const std::string& k) const { return metrics.values().at(k); }
};

std::vector<double> uniform_points(int dim, std::size_t n, const double* L, std::mt19937_64& gen) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> x(n * dim);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = u(gen) * L[i % dim];
  return x;
}

GrParams params(double r_max = 3.0, std::int64_t bins = 150) {
  GrParams p;
  p.r_max = r_max;
  p.bins = bins;
  return p;
}

}  // namespace

TEST_CASE("observe.gr: an ideal gas has g(r) = 1 within the counting error (2D and 3D)", "[gr][physics]") {
  for (int dim : {2, 3}) {
    INFO(dim << "D");
    const std::size_t n = 3000;
    const double L[3] = {dim == 2 ? 60.0 : 16.0, dim == 2 ? 50.0 : 15.0, 14.0};
    auto s = make_state(dim, n, L);
    Gr gr(params(), RunInfo{});
    gr.configure(*s);
    Driver drv{*s, {}, {}, {}};
    std::mt19937_64 gen(17 + dim);
    const int frames = 20;
    for (int f = 0; f < frames; ++f) {
      set_positions(*s, uniform_points(dim, n, L, gen));
      drv.run(gr);
    }
    const auto g = gr.g();
    REQUIRE(g.size() == 150);
    const double volume = dim == 2 ? L[0] * L[1] : L[0] * L[1] * L[2];
    const double dr = gr.dr();
    double chi2 = 0, worst = 0;
    int used = 0;  // bins with at least 20 expected pairs (where counts are nearly Gaussian)
    for (std::size_t k = 0; k < g.size(); ++k) {
      const double lo = k * dr, hi = (k + 1) * dr;
      const double shell = dim == 2 ? pi * (hi * hi - lo * lo) : 4.0 / 3.0 * pi * (hi * hi * hi - lo * lo * lo);
      const double expected = frames * double(n) * double(n - 1) / (2 * volume) * shell;  // pairs in the bin
      if (expected < 20) continue;
      const double z = (g[k] - 1) * expected / std::sqrt(expected);  // (H − E)/√E
      ++used;
      chi2 += z * z;
      worst = std::max(worst, std::fabs(z));
    }
    INFO(used << " bins: χ²/bins = " << chi2 / used << ", worst bin " << worst << " standard errors");
    CHECK(used > 120);
    CHECK(chi2 / used < 1.35);  // ~140 bins: 1 ± 0.12 (one standard deviation)
    CHECK(worst < 4.5);
    // The outer third of the bins together: g = 1 to ~0.2 % (one standard error).
    double outer = 0;
    for (std::size_t k = 100; k < g.size(); ++k) outer += g[k] / 50;
    INFO("mean g over r in [2σ, 3σ): " << outer);
    CHECK(std::fabs(outer - 1) < 0.006);
  }
}

TEST_CASE("observe.gr: a perfect triangular lattice has exactly its shells", "[gr]") {
  // 40 x 40 sites, spacing a = 1.005σ; shells within 3σ: a (6), √3 a (6), 2a (6), √7 a (12).
  const int nx = 40, ny = 40;
  const double a = 1.005;
  const double L[3] = {nx * a, ny * a * std::sqrt(3.0) / 2, 0};
  const std::size_t n = std::size_t(nx) * ny;
  auto s = make_state(2, n, L);
  std::vector<double> x(2 * n);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      x[2 * (j * nx + i)] = (i + 0.5 * (j % 2) + 0.25) * a;
      x[2 * (j * nx + i) + 1] = (j + 0.25) * a * std::sqrt(3.0) / 2;
    }
  set_positions(*s, x);
  Gr gr(params(), RunInfo{});
  gr.configure(*s);
  Driver drv{*s, {}, {}, {}};
  drv.run(gr);
  const auto g = gr.g();
  const double dr = gr.dr();
  auto bin = [&](double r) { return std::size_t(r / dr); };
  std::size_t peak = 0;
  for (std::size_t k = 0; k < g.size(); ++k)
    if (g[k] > g[peak]) peak = k;
  CHECK(peak == bin(a));
  // Pairs per bin: g × (N(N−1)/2V) × shell.
  auto pairs = [&](std::size_t k) {
    const double lo = k * dr, hi = (k + 1) * dr;
    return g[k] * double(n) * double(n - 1) / (2 * L[0] * L[1]) * pi * (hi * hi - lo * lo);
  };
  CHECK(pairs(bin(a)) == Approx(3.0 * n).epsilon(1e-12));
  CHECK(pairs(bin(std::sqrt(3.0) * a)) == Approx(3.0 * n).epsilon(1e-12));
  CHECK(pairs(bin(2 * a)) == Approx(3.0 * n).epsilon(1e-12));
  CHECK(pairs(bin(std::sqrt(7.0) * a)) == Approx(6.0 * n).epsilon(1e-12));
  double total = 0;
  for (std::size_t k = 0; k < g.size(); ++k) total += pairs(k);
  CHECK(total == Approx(15.0 * n).epsilon(1e-12));  // nothing else within 3σ
  for (std::size_t k = 0; k < bin(a); ++k) CHECK(g[k] == 0.0);
}

TEST_CASE("observe.gr: contact value by a quadratic fit", "[gr]") {
  const double dr = 0.02, sigma = 1.0;
  std::vector<double> g(150, 0.0);
  SECTION("a quadratic is extrapolated exactly") {
    for (std::size_t k = 0; k < g.size(); ++k) {
      const double r = (k + 0.5) * dr;
      g[k] = r < sigma ? 0.0 : 3.0 - 4.0 * (r - sigma) + 7.0 * (r - sigma) * (r - sigma);
    }
    CHECK(contact_value(g, dr, sigma, 0.1) == Approx(3.0).epsilon(1e-12));
  }
  SECTION("a steep exponential (bin averages of 1 + 2e^(−8x)) to 0.3 %") {
    for (std::size_t k = 0; k < g.size(); ++k) {
      const double lo = k * dr - sigma, hi = (k + 1) * dr - sigma;
      g[k] = lo < 0 ? 0.0 : 1 + 2 * (std::exp(-8 * lo) - std::exp(-8 * hi)) / (8 * dr);
    }
    CHECK(contact_value(g, dr, sigma, 0.1) == Approx(3.0).epsilon(3e-3));
  }
  SECTION("too few bins above contact: 0") { CHECK(contact_value(std::vector<double>(51, 1.0), dr, sigma, 0.1) == 0.0); }
}

TEST_CASE("observe.gr: metrics, from_step, the CSV file, and errors", "[gr]") {
  const double L[3] = {30, 30, 0};
  const std::size_t n = 400;
  auto s = make_state(2, n, L);
  std::mt19937_64 gen(3);
  const auto dir = std::filesystem::temp_directory_path() / "flipflow-test-gr";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  RunInfo info;
  info.out_dir = dir.string();
  GrParams p = params();
  p.from_step = 2;
  Gr gr(p, info);
  gr.configure(*s);
  CHECK(gr.outputs() == std::vector<std::string>{"gr.csv"});
  Driver drv{*s, info, {}, {}};
  for (int f = 0; f < 5; ++f) {
    set_positions(*s, uniform_points(2, n, L, gen));
    drv.run(gr);
    if (f < 2) CHECK(drv.metric("Z") == 1.0);  // before from_step: nothing accumulated
  }
  const double eta = n * pi / 4 / (L[0] * L[1]);
  CHECK(drv.metric("Z") == Approx(1 + 2 * eta * drv.metric("g_contact")).epsilon(1e-14));
  CHECK(drv.metric("g_contact") == Approx(1.0).margin(0.5));  // ideal gas, few pairs
  gr.finish(*s, true);
  std::ifstream in(dir / "gr.csv");
  REQUIRE(in);
  std::string line;
  int comments = 0, rows = 0;
  std::uint64_t pairs = 0;
  while (std::getline(in, line)) {
    if (line[0] == '#') {
      ++comments;
      if (comments == 1) CHECK(line.find("frames = 3") != std::string::npos);
      continue;
    }
    if (line == "r_lo,r_hi,r,g,pairs") continue;
    ++rows;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream is(line);
    double lo, hi, r, g;
    std::uint64_t c;
    is >> lo >> hi >> r >> g >> c;
    CHECK(r == Approx(0.5 * (lo + hi)));
    pairs += c;
  }
  CHECK(comments == 2);
  CHECK(rows == 150);
  CHECK(pairs > 0);
  CHECK_FALSE(std::filesystem::exists(dir / "gr.csv.partial"));
  std::filesystem::remove_all(dir);

  SECTION("r_max beyond half the box") {
    Gr big(params(20.0), RunInfo{});
    CHECK_THROWS_AS(big.configure(*s), InputError);
  }
}

TEST_CASE("observe.gr: counts do not depend on the thread count", "[gr][determinism]") {
  const double L[3] = {120, 110, 0};
  std::mt19937_64 gen(9);
  const auto x = uniform_points(2, 12000, L, gen);
  const int cells[3] = {40, 36, 1};
  std::vector<std::vector<std::uint64_t>> h;
  for (int threads : {1, 2, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    h.emplace_back(150, 0);
    count_pairs(x, 2, L, cells, 3.0, h.back());
  }
  CHECK(h[1] == h[0]);
  CHECK(h[2] == h[0]);
  // Brute force on the same points, for a few bins.
  std::vector<std::uint64_t> brute(150, 0);
  for (std::size_t i = 0; i < 12000; i += 1)
    for (std::size_t j = i + 1; j < 12000; ++j) {
      double dx = x[2 * j] - x[2 * i], dy = x[2 * j + 1] - x[2 * i + 1];
      dx -= L[0] * std::rint(dx / L[0]);
      dy -= L[1] * std::rint(dy / L[1]);
      const double r2 = dx * dx + dy * dy;
      if (r2 < 9.0) ++brute[std::size_t(std::sqrt(r2) / 0.02)];
    }
  CHECK(h[0] == brute);
}

TEST_CASE("observe.gr: 3D cell-list counts equal brute force", "[gr]") {
  const double L[3] = {16, 15, 14};
  std::mt19937_64 gen(19);
  const std::size_t n = 3000;
  const auto x = uniform_points(3, n, L, gen);
  const int cells[3] = {5, 5, 4};
  std::vector<std::uint64_t> h(150, 0), brute(150, 0);
  count_pairs(x, 3, L, cells, 3.0, h);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      double r2 = 0;
      for (int k = 0; k < 3; ++k) {
        double d = x[3 * j + k] - x[3 * i + k];
        d -= L[k] * std::rint(d / L[k]);
        r2 += d * d;
      }
      if (r2 < 9.0) ++brute[std::size_t(std::sqrt(r2) / 0.02)];
    }
  CHECK(h == brute);
}

TEST_CASE("observe.gr: a from_step after the run's last step is warned of, naming both", "[gr]") {
  // Before: the run went through silently and wrote an empty g(r).
  const double L[3] = {30, 30, 0};
  auto s = make_state(2, 400, L);
  const auto dir = std::filesystem::temp_directory_path() / "flipflow-test-gr-late";
  std::filesystem::create_directories(dir);
  auto warning = [&](std::int64_t from_step) {
    std::FILE* f = std::tmpfile();
    REQUIRE(f);
    RunInfo info;
    info.out_dir = dir.string();
    info.steps = 1000;
    info.messages = f;
    GrParams p = params();
    p.from_step = from_step;
    Gr gr(p, info);
    gr.configure(*s);
    std::rewind(f);
    std::string text;
    for (int c; (c = std::fgetc(f)) != EOF;) text += char(c);
    std::fclose(f);
    return text;
  };
  CHECK_THAT(warning(5000), Catch::Contains("from_step = 5000 is after the run's last step (1000)"));
  CHECK(warning(1000).empty());
  std::filesystem::remove_all(dir);
}
