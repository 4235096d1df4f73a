// observe.gr: g(r) of an ideal gas is 1 within its counting error (2D, 3D); a perfect triangular
// lattice has its exact shells; the contact extrapolation; the CSV output; errors; thread-count
// independence; one diameter bit for bit as before mixtures; a mixture's partial contact values
// and contact-theorem Z (ideal gas, brute force, CSV, continuation). The stage's source is
// compiled into this test to drive it directly.
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

// Uniform points from the raw 64-bit outputs (fixed by the standard, unlike the distributions).
std::vector<double> canonical_points(int dim, std::size_t n, const double* L, std::mt19937_64& gen) {
  std::vector<double> x(n * dim);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = double(gen() >> 11) * 0x1p-53 * L[i % dim];
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
    if (f < 2) {  // before from_step: nothing accumulated, so no value (not a placeholder 0 or 1)
      CHECK(std::isnan(drv.metric("Z")));
      CHECK(std::isnan(drv.metric("g_contact")));
    }
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

TEST_CASE("observe.gr: one diameter gives the metrics of before mixtures, bit for bit", "[gr]") {
  // The values of main (fbc8648), before the mixture contact theorem: 2000 uniform points, 2D
  // and 3D, 10 frames. Two types of one diameter take the same path.
  for (int dim : {2, 3}) {
    for (int types : {1, 2}) {
      INFO(dim << "D, " << types << " type(s)");
      const double L[3] = {dim == 2 ? 40.0 : 13.0, dim == 2 ? 36.0 : 12.0, 11.0};
      const std::size_t n = 2000;
      auto s = make_state(dim, n, L);
      if (types == 2) {
        s->species = {"A", "B"};
        s->species_diameter = {1.0, 1.0};
        for (std::size_t i = 0; i < n; ++i) s->field(fields::type).host<std::int32_t>()[i] = std::int32_t(i % 2);
      }
      Gr gr(params(), RunInfo{});
      gr.configure(*s);
      Driver drv{*s, {}, {}, {}};
      std::mt19937_64 gen(101 + dim);
      for (int f = 0; f < 10; ++f) {
        set_positions(*s, canonical_points(dim, n, L, gen));
        drv.run(gr);
      }
      CHECK_FALSE(gr.mixture());
      CHECK(drv.metric("g_contact") == (dim == 2 ? 0.99071866666210195 : 0.99408605171301789));
      CHECK(drv.metric("Z") == (dim == 2 ? 3.1614128367777941 : 3.4265838672088234));
    }
  }
}

namespace {

// Two species: type 0 ("A", diameter dA) for the first nA particles, type 1 ("B", dB) after.
std::unique_ptr<State> make_mixture(int dim, std::size_t n, std::size_t nA, const double* L, double dA, double dB) {
  auto s = make_state(dim, n, L);
  s->species = {"A", "B"};
  s->species_diameter = {dA, dB};
  for (std::size_t i = 0; i < n; ++i) {
    s->field(fields::diameter).host<double>()[i] = i < nA ? dA : dB;
    s->field(fields::type).host<std::int32_t>()[i] = i < nA ? 0 : 1;
  }
  return s;
}

// The statistical standard error of a contact value of an ideal gas: the fit is linear in the
// bins, g_c = Σ c_k g_k, and a bin expecting E_k pairs has Var(g_k) = 1/E_k (Poisson).
double contact_error(double ds, double fit_width, const std::vector<double>& expected) {
  double var = 0;
  for (std::size_t k = 0; k < expected.size(); ++k) {
    std::vector<double> unit(expected.size(), 0.0);
    unit[k] = 1;
    const double c = contact_value(unit, ds, 1.0, fit_width);
    if (c != 0) var += c * c / expected[k];
  }
  return std::sqrt(var);
}

}  // namespace

TEST_CASE("observe.gr: an ideal-gas mixture has every g_ij(σ_ij⁺) = 1 and Z = 1 + (πρ/2) Σ x_i x_j σ_ij² (2D), "
          "1 + (2πρ/3) Σ x_i x_j σ_ij³ (3D)",
          "[gr][physics][mixture]") {
  // 30 % of σ = 1 and 70 % of σ = 1.4, uniform points (no exclusion): 2D at ρ = 2, 3D at ρ = 1.
  for (int dim : {2, 3}) {
    INFO(dim << "D");
    const double L[3] = {dim == 2 ? 100.0 : 20.0, dim == 2 ? 100.0 : 20.0, 20.0};
    const std::size_t n = dim == 2 ? 20000 : 8000, nA = n * 3 / 10;
    const double dA = 1.0, dB = 1.4;
    auto s = make_mixture(dim, n, nA, L, dA, dB);
    GrParams p = params(1.5, 75);  // bins of 0.02, as by default
    Gr gr(p, RunInfo{});
    gr.configure(*s);
    REQUIRE(gr.mixture());
    REQUIRE(gr.species() == std::vector<std::string>{"A", "B"});
    Driver drv{*s, {}, {}, {}};
    std::mt19937_64 gen(23 + dim);
    const int frames = dim == 2 ? 200 : 100;
    for (int f = 0; f < frames; ++f) {
      set_positions(*s, canonical_points(dim, n, L, gen));
      drv.run(gr);
    }
    const double volume = dim == 2 ? L[0] * L[1] : L[0] * L[1] * L[2], rho = n / volume, ds = 0.02;
    const double prefactor = dim == 2 ? pi / 2 : 2 * pi / 3;
    const double sigma[2] = {dA, dB}, x[2] = {double(nA) / n, double(n - nA) / n};
    const double count[2] = {double(nA), double(n - nA)};
    double z_ideal = 1, z_var = 0, weights = 0;
    for (int a = 0; a < 2; ++a)
      for (int b = a; b < 2; ++b) {
        const double pairs = a == b ? count[a] * (count[a] - 1) / 2 : count[a] * count[b];
        const double sab = 0.5 * (sigma[a] + sigma[b]), sd = std::pow(sab, dim);
        std::vector<double> expected(60);
        for (std::size_t k = 0; k < expected.size(); ++k) {
          const double lo = k * ds, hi = (k + 1) * ds;
          const double shell = dim == 2 ? pi * (hi * hi - lo * lo) : 4.0 / 3.0 * pi * (hi * hi * hi - lo * lo * lo);
          expected[k] = frames * pairs / volume * shell * sd;
        }
        const double err = contact_error(ds, p.fit_width, expected);
        const double w = (a == b ? 1 : 2) * x[a] * x[b] * sd;
        z_ideal += prefactor * rho * w;
        z_var += std::pow(prefactor * rho * w * err, 2);
        weights += w;
        const double g = gr.pair_contact(a, b);
        INFO("g_contact[" << a << "," << b << "] = " << g << " ± " << err);
        CHECK(err < 0.02);  // a few-% test
        CHECK(std::fabs(g - 1) < 4 * err);
        CHECK(gr.pair_contact(b, a) == g);
      }
    const double z = drv.metric("Z"), z_err = std::sqrt(z_var);
    INFO("Z = " << z << ", ideal " << z_ideal << " ± " << z_err);
    CHECK(z_err / (z_ideal - 1) < 0.02);
    CHECK(std::fabs(z - z_ideal) < 4 * z_err);
    // g_contact is the weighted mean of the g_ij that enters Z.
    CHECK(z == Approx(1 + prefactor * rho * weights * drv.metric("g_contact")).epsilon(1e-12));
    // The total g(r) stays in units of the mean diameter, 1 everywhere for an ideal gas.
    CHECK(gr.sigma() == Approx(0.3 * dA + 0.7 * dB).epsilon(1e-12));
    double outer = 0;
    for (std::size_t k = 25; k < 75; ++k) outer += gr.g()[k] / 50;
    CHECK(std::fabs(outer - 1) < 0.003);
  }
}

TEST_CASE("observe.gr: a mixture's contact histograms equal brute force, for any thread count", "[gr][mixture]") {
  const double L[3] = {40, 36, 0};
  const std::size_t n = 3000, nA = 1000;
  std::mt19937_64 gen(31);
  const auto xyz = canonical_points(2, n, L, gen);
  std::vector<std::int32_t> type(n);
  std::vector<double> diam(n);
  for (std::size_t i = 0; i < n; ++i) {
    type[i] = i < nA ? 1 : 0;  // the pair class is ordered by type, not by index
    diam[i] = i < nA ? 1.6 : 1.0;
  }
  const ContactWindow window{type.data(), diam.data(), 2, 0.02, 60};
  const int cells[3] = {13, 12, 1};
  std::vector<std::vector<std::uint64_t>> h, c;
  for (int threads : {1, 2, 3}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    h.emplace_back(150, 0);
    c.emplace_back(4 * 60, 0);
    count_pairs(xyz, 2, L, cells, 3.0, h.back(), &window, &c.back());
  }
  CHECK(c[1] == c[0]);
  CHECK(c[2] == c[0]);
  std::vector<std::uint64_t> hist(150, 0);
  count_pairs(xyz, 2, L, cells, 3.0, hist);
  CHECK(h[0] == hist);  // the window leaves g(r) alone
  std::vector<std::uint64_t> brute(4 * 60, 0);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      double dx = xyz[2 * j] - xyz[2 * i], dy = xyz[2 * j + 1] - xyz[2 * i + 1];
      dx -= L[0] * std::rint(dx / L[0]);
      dy -= L[1] * std::rint(dy / L[1]);
      const double r = std::sqrt(dx * dx + dy * dy);
      if (r >= 3.0) continue;
      const std::size_t k = std::size_t(r / (0.5 * (diam[i] + diam[j])) / 0.02);
      const std::size_t cls = std::size_t(std::min(type[i], type[j]) * 2 + std::max(type[i], type[j]));
      if (k < 60) ++brute[cls * 60 + k];
    }
  CHECK(c[0] == brute);
  for (std::size_t k = 0; k < 60; ++k) CHECK(c[0][2 * 60 + k] == 0);  // (1, 0): never used
}

TEST_CASE("observe.gr: a mixture's CSV names each species pair's contact value; errors", "[gr][mixture]") {
  const double L[3] = {40, 40, 0};
  auto s = make_mixture(2, 1200, 600, L, 1.0, 1.4);
  const auto dir = std::filesystem::temp_directory_path() / "flipflow-test-gr-mixture";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  RunInfo info;
  info.out_dir = dir.string();
  Gr gr(params(), info);
  gr.configure(*s);
  Driver drv{*s, info, {}, {}};
  std::mt19937_64 gen(5);
  for (int f = 0; f < 3; ++f) {
    set_positions(*s, canonical_points(2, 1200, L, gen));
    drv.run(gr);
  }
  gr.finish(*s, true);
  std::ifstream in(dir / "gr.csv");
  REQUIRE(in);
  std::string line;
  std::vector<std::string> comments;
  while (std::getline(in, line))
    if (line[0] == '#') comments.push_back(line);
  REQUIRE(comments.size() == 5);
  CHECK_THAT(comments[1], Catch::Contains("mixture"));
  const char* pairs[3][2] = {{"A", "A"}, {"A", "B"}, {"B", "B"}};
  for (int k = 0; k < 3; ++k) {
    const std::string head = std::string("# g_contact[") + pairs[k][0] + "," + pairs[k][1] + "] = ";
    REQUIRE(comments[2 + k].rfind(head, 0) == 0);
    const double value = std::stod(comments[2 + k].substr(head.size()));
    CHECK(value == gr.pair_contact(k == 2 ? 1 : 0, k == 0 ? 0 : 1));
  }
  std::filesystem::remove_all(dir);

  SECTION("a contact window beyond r_max") {
    auto wide = make_mixture(2, 1200, 600, L, 1.0, 3.0);
    Gr short_reach(params(1.2, 60), RunInfo{});
    CHECK_THROWS_WITH(short_reach.configure(*wide), Catch::Contains("raise r_max"));
  }
}

TEST_CASE("observe.gr: a mixture continued from its stage state gives the uninterrupted run's values", "[gr][mixture]") {
  const double L[3] = {40, 40, 0};
  std::vector<std::vector<double>> frames;
  std::mt19937_64 gen(41);
  for (int f = 0; f < 6; ++f) frames.push_back(canonical_points(2, 1500, L, gen));
  auto s = make_mixture(2, 1500, 500, L, 1.0, 1.4);
  Gr whole(params(), RunInfo{});
  whole.configure(*s);
  Driver a{*s, {}, {}, {}};
  for (auto& x : frames) {
    set_positions(*s, x);
    a.run(whole);
  }
  Gr first(params(), RunInfo{});
  first.configure(*s);
  Driver b{*s, {}, {}, {}};
  for (int f = 0; f < 3; ++f) {
    set_positions(*s, frames[f]);
    b.run(first);
  }
  StageState saved;
  first.save_state(saved);
  Gr rest(params(), RunInfo{});
  rest.configure(*s);
  rest.restore_state(saved, *s);
  CHECK(rest.pair_contact(0, 1) == first.pair_contact(0, 1));
  for (int f = 3; f < 6; ++f) {
    set_positions(*s, frames[f]);
    b.run(rest);
  }
  CHECK(b.metric("Z") == a.metric("Z"));
  CHECK(b.metric("g_contact") == a.metric("g_contact"));
  for (int i = 0; i < 2; ++i)
    for (int j = i; j < 2; ++j) CHECK(rest.pair_contact(i, j) == whole.pair_contact(i, j));
}

TEST_CASE("observe.gr: one type of several diameters is a mixture of one species, with a warning", "[gr][mixture]") {
  const double L[3] = {30, 30, 0};
  auto s = make_state(2, 400, L);
  for (std::size_t i = 0; i < 400; ++i) s->field(fields::diameter).host<double>()[i] = i % 2 ? 1.2 : 1.0;
  std::FILE* f = std::tmpfile();
  REQUIRE(f);
  RunInfo info;
  info.messages = f;
  Gr gr(params(), info);
  gr.configure(*s);
  std::rewind(f);
  std::string text;
  for (int c; (c = std::fgetc(f)) != EOF;) text += char(c);
  std::fclose(f);
  CHECK(gr.mixture());
  CHECK_THAT(text, Catch::Contains("diameters from 1 to 1.2") && Catch::Contains("one diameter per species"));
  CHECK(std::isnan(gr.pair_contact(0, 0)));  // no frame yet
}
