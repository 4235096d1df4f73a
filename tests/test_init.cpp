// Initial conditions (core/input/init.h): box from the packing fraction, species counts, placement
// without overlaps (checked by brute force over all pairs, minimum image), reproducibility.
#include <algorithm>
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <map>
#include <set>
#include <vector>

#include "core/base/error.h"
#include "core/input/init.h"

using namespace ff;

namespace {

constexpr double kPi = 3.14159265358979323846;

SystemSpec spec(int dim, std::uint64_t n, double phi, const std::string& init) {
  SystemSpec s;
  s.dimensions = dim;
  s.N = n;
  s.packing_fraction = phi;
  s.init = init;
  return s;
}

SystemSpec bidisperse(int dim, std::uint64_t n, double phi, const std::string& init) {
  SystemSpec s = spec(dim, n, phi, init);
  s.sigma = 2.0;
  s.types = {SpeciesSpec{"small", 0.5, 1.0}, SpeciesSpec{"big", 0.5, 1.4}};
  return s;
}

double min_image(double d, double L) { return d - L * std::rint(d / L); }

std::vector<double> positions(const State& st) {
  const Field& f = st.field(fields::position);
  std::vector<double> x(f.size());
  if (st.precision() == Precision::f32)
    std::copy(f.host<float>(), f.host<float>() + f.size(), x.begin());
  else
    std::copy(f.host<double>(), f.host<double>() + f.size(), x.begin());
  return x;
}

std::vector<double> diameters(const State& st) {
  const Field& f = st.field(fields::diameter);
  std::vector<double> d(f.size());
  if (st.precision() == Precision::f32)
    std::copy(f.host<float>(), f.host<float>() + f.size(), d.begin());
  else
    std::copy(f.host<double>(), f.host<double>() + f.size(), d.begin());
  return d;
}

std::vector<int> types(const State& st) {
  const Field& f = st.field(fields::type);
  return std::vector<int>(f.host<std::int32_t>(), f.host<std::int32_t>() + f.size());
}

// Smallest distance / contact distance over all pairs, by brute force with minimum image:
// ≥ 1 means no two particles overlap.
double min_gap_ratio(const State& st) {
  const auto x = positions(st);
  const auto d = diameters(st);
  const int dim = st.dim();
  double worst = 1e300;
  for (std::size_t i = 0; i < st.n(); ++i)
    for (std::size_t j = i + 1; j < st.n(); ++j) {
      double r2 = 0;
      for (int k = 0; k < dim; ++k) {
        const double dx = min_image(x[i * dim + k] - x[j * dim + k], st.box.L[k]);
        r2 += dx * dx;
      }
      worst = std::min(worst, std::sqrt(r2) / (0.5 * (d[i] + d[j])));
    }
  return worst;
}

void require_inside_box(const State& st) {
  const auto x = positions(st);
  for (std::size_t i = 0; i < st.n(); ++i)
    for (int k = 0; k < st.dim(); ++k) {
      REQUIRE(x[i * st.dim() + k] >= 0.0);
      REQUIRE(x[i * st.dim() + k] < st.box.L[k]);
    }
}

double packing_fraction(const State& st) {
  double occupied = 0;
  for (double d : diameters(st)) occupied += st.dim() == 2 ? kPi * d * d / 4 : kPi * d * d * d / 6;
  return occupied / st.box.volume();
}

}  // namespace

TEST_CASE("make_box: edge from the packing fraction", "[init]") {
  SECTION("2D monodisperse: L² = N π d²/4 / φ") {
    SystemSpec s = spec(2, 100, 0.5, "random");
    const Box b = make_box(s);
    CHECK(b.dim == 2);
    CHECK(b.L[0] == Approx(std::sqrt(100 * kPi / 4 / 0.5)).epsilon(1e-14));
    CHECK(b.L[1] == b.L[0]);
    CHECK(b.L[0] == Approx(12.533141373155).epsilon(1e-12));
  }
  SECTION("2D bidisperse with sigma: d_i = sigma × diameter") {
    SystemSpec s = bidisperse(2, 1000, 0.6, "random");
    const Box b = make_box(s);
    const double occupied = 500 * kPi * 2.0 * 2.0 / 4 + 500 * kPi * 2.8 * 2.8 / 4;
    CHECK(b.L[0] * b.L[1] == Approx(occupied / 0.6).epsilon(1e-13));
  }
  SECTION("3D: L³ = N π d³/6 / φ") {
    SystemSpec s = spec(3, 500, 0.3, "random");
    s.sigma = 1.5;
    const Box b = make_box(s);
    CHECK(b.dim == 3);
    CHECK(b.L[0] == Approx(std::cbrt(500 * kPi * 1.5 * 1.5 * 1.5 / 6 / 0.3)).epsilon(1e-14));
    CHECK(b.L[1] == b.L[0]);
    CHECK(b.L[2] == b.L[0]);
  }
  SECTION("exact species counts enter the volume: N = 10, fractions 1:2 -> 3 and 7") {
    SystemSpec s = spec(2, 10, 0.4, "random");
    s.types = {SpeciesSpec{"A", 1.0, 1.0}, SpeciesSpec{"B", 2.0, 2.0}};
    const Box b = make_box(s);
    CHECK(b.volume() == Approx((3 * kPi / 4 + 7 * kPi * 4 / 4) / 0.4).epsilon(1e-13));
  }
  SECTION("an explicit box is taken as given") {
    SystemSpec s = spec(2, 10, 0.0, "random");
    s.box = {7.0, 9.5};
    const Box b = make_box(s);
    CHECK(b.L[0] == 7.0);
    CHECK(b.L[1] == 9.5);
    s.box = {7.0};
    CHECK_THROWS_AS(make_box(s), InputError);
    s.box = {7.0, -1.0};
    CHECK_THROWS_AS(make_box(s), InputError);
  }
  SECTION("no box and no valid packing fraction") {
    CHECK_THROWS_AS(make_box(spec(2, 10, 0.0, "random")), InputError);
    CHECK_THROWS_AS(make_box(spec(2, 10, 1.2, "random")), InputError);
  }
}

TEST_CASE("species counts are exact and sum to N", "[init]") {
  SystemSpec s = spec(2, 1000, 0.3, "random");
  s.types = {SpeciesSpec{"A", 0.3, 1.0}, SpeciesSpec{"B", 0.7, 1.0}};
  CHECK(species_counts(s) == std::vector<std::uint64_t>{300, 700});

  s.types = {SpeciesSpec{"A", 2, 1.0}, SpeciesSpec{"B", 6, 1.0}};  // normalised
  CHECK(species_counts(s) == std::vector<std::uint64_t>{250, 750});

  s.N = 10;  // 3.33 each rounds to 3 + 3 + 3 = 9: one more to the first
  s.types = {SpeciesSpec{"A", 1, 1.0}, SpeciesSpec{"B", 1, 1.0}, SpeciesSpec{"C", 1, 1.0}};
  CHECK(species_counts(s) == std::vector<std::uint64_t>{4, 3, 3});

  s.N = 2;  // 0.5 each rounds up to 1 + 1 + 1 = 3 (llround): one taken back
  CHECK(species_counts(s) == std::vector<std::uint64_t>{0, 1, 1});

  s.N = 7;
  s.types = {SpeciesSpec{"A", 0.5, 1.0}, SpeciesSpec{"B", 0.5, 1.0}};
  auto c = species_counts(s);
  CHECK(c[0] + c[1] == 7);
  CHECK(std::abs(double(c[0]) - double(c[1])) == 1.0);

  SECTION("the type field holds exactly those counts, in a shuffled order") {
    SystemSpec t = spec(2, 1000, 0.3, "triangular_lattice_sample");
    t.types = {SpeciesSpec{"A", 0.3, 1.0}, SpeciesSpec{"B", 0.7, 1.0}};
    auto st = make_initial_state(t, Precision::f64, 5);
    auto ty = types(*st);
    CHECK(std::count(ty.begin(), ty.end(), 0) == 300);
    CHECK(std::count(ty.begin(), ty.end(), 1) == 700);
    // Shuffled: the first 300 are not all species 0 (would be with probability ~1e-265).
    CHECK(std::count(ty.begin(), ty.begin() + 300, 0) < 200);
    CHECK(std::count(ty.begin(), ty.begin() + 300, 0) > 40);
    CHECK(st->species == std::vector<std::string>{"A", "B"});
  }
}

TEST_CASE("random placement: no overlaps (2D φ=0.3, 3D φ=0.2)", "[init]") {
  SECTION("2D, f64") {
    auto st = make_initial_state(spec(2, 2000, 0.3, "random"), Precision::f64, 1);
    CHECK(st->n() == 2000);
    CHECK(packing_fraction(*st) == Approx(0.3).epsilon(1e-12));
    CHECK(min_gap_ratio(*st) >= 1.0);
    require_inside_box(*st);
  }
  SECTION("2D, f32: the stored (rounded) positions do not overlap") {
    auto st = make_initial_state(spec(2, 2000, 0.45, "random"), Precision::f32, 2);
    CHECK(min_gap_ratio(*st) >= 1.0);
    require_inside_box(*st);
  }
  SECTION("3D") {
    auto st = make_initial_state(spec(3, 1500, 0.2, "random"), Precision::f64, 3);
    CHECK(packing_fraction(*st) == Approx(0.2).epsilon(1e-12));
    CHECK(min_gap_ratio(*st) >= 1.0);
    require_inside_box(*st);
  }
  SECTION("positions cover the box uniformly: mean x ≈ L/2") {
    auto st = make_initial_state(spec(2, 2000, 0.3, "random"), Precision::f64, 4);
    const auto x = positions(*st);
    double mean[2] = {0, 0};
    for (std::size_t i = 0; i < st->n(); ++i)
      for (int k = 0; k < 2; ++k) mean[k] += x[i * 2 + k] / double(st->n());
    // Standard error of the mean of a uniform on [0, L): L/sqrt(12 N) ≈ 0.0065 L.
    for (int k = 0; k < 2; ++k) CHECK(std::abs(mean[k] / st->box.L[k] - 0.5) < 0.03);
  }
}

TEST_CASE("lattice placement: no overlaps at φ=0.7 and 0.8 (2D) and 0.5 (3D fcc)", "[init]") {
  const std::string init = GENERATE(as<std::string>{}, "triangular_lattice_sample", "lattice_sample");
  const double phi = GENERATE(0.7, 0.8);
  const Precision prec = GENERATE(Precision::f64, Precision::f32);
  CAPTURE(init, phi, to_string(prec));
  auto st = make_initial_state(spec(2, 2000, phi, init), prec, 11);
  CHECK(min_gap_ratio(*st) >= 1.0);
  require_inside_box(*st);

  SECTION("every particle sits on a distinct lattice site") {
    double spacing = 0;
    const auto sites = lattice_sites(st->box, st->n(), spacing);
    CHECK(sites.size() >= st->n());
    CHECK(sites.size() < st->n() + 100);  // N* ≥ N, but not wastefully more
    const auto x = positions(*st);
    std::set<std::size_t> used;
    for (std::size_t i = 0; i < st->n(); ++i) {
      std::size_t nearest = 0;
      double best = 1e300;
      for (std::size_t s = 0; s < sites.size(); ++s) {
        const double dx = min_image(x[2 * i] - sites[s][0], st->box.L[0]);
        const double dy = min_image(x[2 * i + 1] - sites[s][1], st->box.L[1]);
        if (dx * dx + dy * dy < best) best = dx * dx + dy * dy, nearest = s;
      }
      CHECK(std::sqrt(best) < 1e-4 * spacing);
      used.insert(nearest);
    }
    CHECK(used.size() == st->n());
  }
}

TEST_CASE("3D lattice_sample: no overlaps", "[init]") {
  auto st = make_initial_state(spec(3, 1000, 0.5, "lattice_sample"), Precision::f64, 5);
  CHECK(min_gap_ratio(*st) >= 1.0);
  require_inside_box(*st);
  CHECK_THROWS_AS(make_initial_state(spec(3, 100, 0.3, "triangular_lattice_sample"), Precision::f64, 1),
                  InputError);
}

TEST_CASE("lattice_sites: the reported spacing is the true periodic nearest distance", "[init]") {
  // Brute force over all site pairs, minimum image: catches a wrong wrap-around row or column
  // (odd row counts, one row, one cell along an axis, ...).
  auto brute = [](const Box& box, const std::vector<std::array<double, 3>>& sites) {
    double best = 1e300;
    for (std::size_t i = 0; i < sites.size(); ++i) {
      // A site meets its own image at the box edge.
      for (int k = 0; k < box.dim; ++k) best = std::min(best, box.L[k]);
      for (std::size_t j = i + 1; j < sites.size(); ++j) {
        double r2 = 0;
        for (int k = 0; k < box.dim; ++k) {
          const double dx = min_image(sites[i][k] - sites[j][k], box.L[k]);
          r2 += dx * dx;
        }
        best = std::min(best, std::sqrt(r2));
      }
    }
    return best;
  };
  SECTION("2D, square and elongated boxes") {
    for (std::uint64_t n : {1u, 2u, 3u, 7u, 13u, 50u, 101u, 400u}) {
      for (double aspect : {1.0, 0.3, 3.7}) {
        Box box;
        box.dim = 2;
        box.L[0] = 10.0;
        box.L[1] = 10.0 * aspect;
        double spacing = 0;
        const auto sites = lattice_sites(box, n, spacing);
        CAPTURE(n, aspect, sites.size());
        CHECK(sites.size() >= n);
        CHECK(spacing == Approx(brute(box, sites)).epsilon(1e-12));
      }
    }
  }
  SECTION("3D") {
    for (std::uint64_t n : {1u, 5u, 32u, 100u, 257u}) {
      Box box;
      box.dim = 3;
      box.L[0] = 8.0, box.L[1] = 8.0, box.L[2] = 11.0;
      double spacing = 0;
      const auto sites = lattice_sites(box, n, spacing);
      CAPTURE(n, sites.size());
      CHECK(sites.size() >= n);
      CHECK(spacing == Approx(brute(box, sites)).epsilon(1e-12));
    }
  }
  SECTION("a dense 2D lattice is close to the ideal triangular one") {
    // Ideal: area per site (√3/2) a². A square box with N = 2000 loses a few percent at most.
    Box box;
    box.dim = 2;
    box.L[0] = box.L[1] = 50.0;
    double spacing = 0;
    lattice_sites(box, 2000, spacing);
    const double ideal = std::sqrt(2.0 * 2500.0 / (std::sqrt(3.0) * 2000));
    CHECK(spacing <= ideal);
    CHECK(spacing > 0.97 * ideal);
  }
}

TEST_CASE("same seed, same state; another seed, another state", "[init]") {
  for (const char* init : {"random", "triangular_lattice_sample"}) {
    CAPTURE(init);
    SystemSpec s = bidisperse(2, 500, 0.4, init);
    auto a = make_initial_state(s, Precision::f64, 42);
    auto b = make_initial_state(s, Precision::f64, 42);
    auto c = make_initial_state(s, Precision::f64, 43);
    CHECK(positions(*a) == positions(*b));
    CHECK(types(*a) == types(*b));
    const auto xa = positions(*a), xc = positions(*c);
    std::size_t differ = 0;
    for (std::size_t i = 0; i < a->n(); ++i)
      if (xa[2 * i] != xc[2 * i] || xa[2 * i + 1] != xc[2 * i + 1]) ++differ;
    CHECK(differ > a->n() / 2);
    CHECK(types(*a) != types(*c));
  }
  SECTION("3D random") {
    auto a = make_initial_state(spec(3, 300, 0.2, "random"), Precision::f64, 7);
    auto b = make_initial_state(spec(3, 300, 0.2, "random"), Precision::f64, 7);
    auto c = make_initial_state(spec(3, 300, 0.2, "random"), Precision::f64, 8);
    CHECK(positions(*a) == positions(*b));
    CHECK(positions(*a) != positions(*c));
  }
}

TEST_CASE("too dense: InputError that says what to do", "[init]") {
  auto message = [](const SystemSpec& s) {
    try {
      make_initial_state(s, Precision::f64, 1);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("(no InputError)");
  };
  SECTION("2D random past RSA jamming") {
    const auto m = message(spec(2, 300, 0.62, "random"));
    CHECK_THAT(m, Catch::Contains("too high for random placement"));
    CHECK_THAT(m, Catch::Contains("0.547"));
    CHECK_THAT(m, Catch::Contains("init: triangular_lattice_sample"));
  }
  SECTION("3D random past RSA jamming") {
    const auto m = message(spec(3, 300, 0.45, "random"));
    CHECK_THAT(m, Catch::Contains("too high for random placement"));
    CHECK_THAT(m, Catch::Contains("0.38"));
    CHECK_THAT(m, Catch::Contains("init: lattice_sample"));
  }
  SECTION("many equal particles past jamming: refused at once, before any drop") {
    // 200 000 spheres at 0.625 took over two minutes of drops to fail; the message says none was made.
    const auto m = message(spec(3, 200000, 0.625, "random"));
    CHECK_THAT(m, Catch::Contains("refused before placing any particle") && Catch::Contains("0.38 in 3D"));
    CHECK_THAT(message(spec(2, 5000, 0.58, "random")), Catch::Contains("refused before placing any particle"));
    // Below the margin the drops are tried, as before.
    CHECK_THAT(message(spec(2, 300, 0.62, "random")), !Catch::Contains("refused before"));
  }
  SECTION("2D lattice past close packing") {
    const auto m = message(spec(2, 1000, 0.92, "triangular_lattice_sample"));
    CHECK_THAT(m, Catch::Contains("too dense for a triangular lattice"));
    CHECK_THAT(m, Catch::Contains("0.9069"));
  }
  SECTION("3D lattice past fcc close packing") {
    const auto m = message(spec(3, 500, 0.76, "lattice_sample"));
    CHECK_THAT(m, Catch::Contains("too dense"));
    CHECK_THAT(m, Catch::Contains("0.7405"));
  }
  SECTION("bidisperse: the lattice is spaced by the largest diameter") {
    // φ = 0.8 with diameters 1 and 1.4: as dense as equal disks of 1.4 at
    // 0.8 · 1.96 / ((1 + 1.96) / 2) ≈ 1.06 > 0.907 — cannot fit.
    const auto m = message(bidisperse(2, 1000, 0.8, "triangular_lattice_sample"));
    CHECK_THAT(m, Catch::Contains("largest diameter 2.8"));
  }
  SECTION("other bad input") {
    CHECK_THAT(message(spec(2, 10, 0.3, "hexagonal")), Catch::Contains("unknown value 'hexagonal'"));
    CHECK_THAT(message(spec(3, 10, 0.3, "triangular_lattice_sample")), Catch::Contains("lattice_sample"));
    CHECK_THAT(message(spec(2, 0, 0.3, "random")), Catch::Contains("system.N"));
  }
}

TEST_CASE("bidisperse: diameters follow the species", "[init]") {
  const std::string init = GENERATE(as<std::string>{}, "random", "triangular_lattice_sample");
  const Precision prec = GENERATE(Precision::f64, Precision::f32);
  CAPTURE(init, to_string(prec));
  const double phi = init == "random" ? 0.4 : 0.6;
  auto st = make_initial_state(bidisperse(2, 1000, phi, init), prec, 9);
  REQUIRE(st->species_diameter.size() == 2);
  CHECK(st->species_diameter[0] == Approx(2.0));
  CHECK(st->species_diameter[1] == Approx(2.8));
  const auto ty = types(*st);
  const auto d = diameters(*st);
  std::map<int, int> count;
  for (std::size_t i = 0; i < st->n(); ++i) {
    ++count[ty[i]];
    CHECK(d[i] == Approx(st->species_diameter[std::size_t(ty[i])]).epsilon(1e-7));
  }
  CHECK(count[0] == 500);
  CHECK(count[1] == 500);
  CHECK(packing_fraction(*st) == Approx(phi).epsilon(1e-6));
  // Contact distance is the mean of the two diameters: big–big pairs need 2.8, small–small 2.0.
  CHECK(min_gap_ratio(*st) >= 1.0);
}
