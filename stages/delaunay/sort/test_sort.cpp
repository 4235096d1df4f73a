// delaunay.sort: at configure time the particles are renumbered along a Hilbert curve; every
// per-particle field moves with its particle (other fields stay), the initial configuration is
// the same set of particles, consecutive particles are close in space, and a pipeline that
// starts with it maintains CGAL's triangulation as before; in 3D the same along CGAL's Hilbert
// curve. Refusal: a triangulation already built.
#include <algorithm>
#include <cmath>
#include <random>

#include "core/base/error.h"
#include "core/run/simulation.h"
#include "stages/delaunay/common/hilbert.h"
#include "support/spec.h"
#include "support/test_plugins.h"
#include "stages/delaunay/test_support.h"

using namespace ff;
using namespace ff::test::dl;

namespace {

// Mean distance between particles i and i+1 (minimum image), in units of the mean spacing.
double consecutive_distance(State& s) {
  const auto xy = positions(s);
  const double L0 = s.box.L[0], L1 = s.box.L[1];
  double sum = 0;
  for (std::size_t i = 0; i + 1 < s.n(); ++i) {
    double dx = xy[2 * i + 2] - xy[2 * i], dy = xy[2 * i + 3] - xy[2 * i + 1];
    dx -= L0 * std::rint(dx / L0);
    dy -= L1 * std::rint(dy / L1);
    sum += std::hypot(dx, dy);
  }
  return sum / double(s.n() - 1) / std::sqrt(L0 * L1 / double(s.n()));
}

}  // namespace

TEST_CASE("sort: every per-particle field moves with its particle, into Hilbert order", "[delaunay][sort]") {
  const std::size_t n = 5000;
  const double L = std::sqrt(n / 0.6);
  auto s = make_state(random_points(n, L, L, 31), L, L);
  // Tag fields: particle i holds i (i32), -3i and 7i (image), i/2 (diameter); a non-particle
  // field (count 2N) must stay untouched.
  Field& tag = s->add_field("test.tag", DType::i32, 1, n);
  Field& other = s->add_field("test.edges", DType::i32, 1, 2 * n);
  std::int32_t* im = s->field(fields::image).host<std::int32_t>();
  double* dia = s->field(fields::diameter).host<double>();
  for (std::size_t i = 0; i < n; ++i) {
    tag.host<std::int32_t>()[i] = std::int32_t(i);
    im[2 * i] = -3 * std::int32_t(i);
    im[2 * i + 1] = 7 * std::int32_t(i);
    dia[i] = 0.5 * double(i);
  }
  for (std::size_t k = 0; k < 2 * n; ++k) other.host<std::int32_t>()[k] = std::int32_t(k);
  const auto before = positions(*s);
  const double spread_before = consecutive_distance(*s);

  auto st = make_stage("delaunay.sort", Backend::cpu);
  st->configure(*s);

  const auto after = positions(*s);
  std::vector<bool> seen(n, false);
  bool rows_agree = true;
  for (std::size_t r = 0; r < n; ++r) {
    const std::int32_t i = s->field("test.tag").host<std::int32_t>()[r];
    REQUIRE(i >= 0);
    REQUIRE(std::size_t(i) < n);
    seen[std::size_t(i)] = true;
    rows_agree = rows_agree && after[2 * r] == before[2 * std::size_t(i)] &&
                 after[2 * r + 1] == before[2 * std::size_t(i) + 1] && im[2 * r] == -3 * i && im[2 * r + 1] == 7 * i &&
                 dia[r] == 0.5 * double(i);
  }
  CHECK(rows_agree);
  CHECK(std::all_of(seen.begin(), seen.end(), [](bool b) { return b; }));  // a permutation
  bool untouched = true;
  for (std::size_t k = 0; k < 2 * n; ++k) untouched = untouched && other.host<std::int32_t>()[k] == std::int32_t(k);
  CHECK(untouched);
  // Hilbert order: ranks are now the identity, and neighbours in memory are neighbours in space.
  const auto rank = ff::delaunay::hilbert_ranks(after, L, L);
  bool identity = true;
  for (std::size_t r = 0; r < n; ++r) identity = identity && rank[r] == std::int32_t(r);
  CHECK(identity);
  const double spread_after = consecutive_distance(*s);
  INFO("mean distance between consecutive particles / mean spacing: " << spread_before << " -> " << spread_after);
  CHECK(spread_before > 20);
  CHECK(spread_after < 2);
}

TEST_CASE("sort: in 3D the particles move along CGAL's Hilbert curve, fields with them", "[delaunay][sort]") {
  const std::size_t n = 20000;
  const double L = 30;
  State s(3, Precision::f64, n);
  for (int k = 0; k < 3; ++k) s.box.L[k] = L;
  Field& pos = s.field(fields::position);
  double* x = pos.host<double>();
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, L);
  for (std::size_t k = 0; k < 3 * n; ++k) x[k] = u(rng);
  const std::vector<double> before(x, x + 3 * n);
  Field& tag = s.add_field("test.tag", DType::i32, 1, n);
  for (std::size_t i = 0; i < n; ++i) tag.host<std::int32_t>()[i] = std::int32_t(i);
  // Mean distance between particles i and i+1 (minimum image), in units of the mean spacing.
  auto spread = [&](const double* p) {
    double sum = 0;
    for (std::size_t i = 0; i + 1 < n; ++i) {
      double d2 = 0;
      for (int k = 0; k < 3; ++k) {
        double d = p[3 * i + 3 + k] - p[3 * i + k];
        d -= L * std::rint(d / L);
        d2 += d * d;
      }
      sum += std::sqrt(d2);
    }
    return sum / double(n - 1) / std::cbrt(L * L * L / double(n));
  };
  const double spread_before = spread(before.data());

  auto st = make_stage("delaunay.sort", Backend::cpu);
  st->configure(s);

  std::vector<bool> seen(n, false);
  bool rows_agree = true;
  for (std::size_t r = 0; r < n; ++r) {
    const std::int32_t i = s.field("test.tag").host<std::int32_t>()[r];
    REQUIRE(i >= 0);
    REQUIRE(std::size_t(i) < n);
    seen[std::size_t(i)] = true;
    for (int k = 0; k < 3; ++k) rows_agree = rows_agree && x[3 * r + k] == before[3 * std::size_t(i) + k];
  }
  CHECK(rows_agree);
  CHECK(std::all_of(seen.begin(), seen.end(), [](bool b) { return b; }));  // a permutation
  const double spread_after = spread(x);
  INFO("mean distance between consecutive particles / mean spacing: " << spread_before << " -> " << spread_after);
  CHECK(spread_before > 10);  // random order: about the box's mean distance, ~ (N)^(1/3) spacings
  CHECK(spread_after < 2);    // a space-filling curve: about one spacing
}

TEST_CASE("sort: refusals", "[delaunay][sort]") {
  SECTION("after a triangulation was built") {
    auto s = make_state(random_points(300, 20, 20, 2), 20, 20);
    auto build = make_stage("delaunay.build", Backend::cpu);
    build->configure(*s);
    Runner r(*s, Backend::cpu);
    REQUIRE_FALSE(r.run(*build).rollback);
    auto st = make_stage("delaunay.sort", Backend::cpu);
    CHECK_THROWS_WITH(st->configure(*s), Catch::Contains("list delaunay.sort before"));
  }
}

TEST_CASE("sort: a pipeline starting with it has the same initial particles and stays Delaunay",
          "[delaunay][sort][pipeline]") {
  const Backend backend = GENERATE(from_range(ff::test::backends()));
  INFO("backend " << to_string(backend));
  auto reg = test::registry_with({"brownian"});
  using ff::test::entry;
  auto make = [&](bool sorted) {
    std::vector<StepEntry> steps;
    if (sorted) steps.push_back(entry(*reg, "delaunay.sort"));
    for (auto* name : {"brownian.integrate", "delaunay.detect_inversion", "delaunay.flip", "delaunay.lawson"})
      steps.push_back(std::string(name) == "brownian.integrate" ? entry(*reg, name, {{"D", 0.01}}) : entry(*reg, name));
    steps.push_back(entry(*reg, "delaunay.check", {}, {"", {}, false, 100}));
    auto spec = test::spec(2, 4000, 0.5, 300, 0.01, steps, 42);
    spec.system.init = "random";
    return spec;
  };
  RunOptions o;
  o.dry_run = true;
  o.backend = backend;
  Simulation plain(make(false), *reg, o), sorted(make(true), *reg, o);
  auto p0 = positions(plain.state()), s0 = positions(sorted.state());
  CHECK(p0 != s0);  // reordered ...
  auto pairs = [](const std::vector<double>& xy) {
    std::vector<std::pair<double, double>> v;
    for (std::size_t i = 0; i < xy.size() / 2; ++i) v.emplace_back(xy[2 * i], xy[2 * i + 1]);
    std::sort(v.begin(), v.end());
    return v;
  };
  CHECK(pairs(p0) == pairs(s0));  // ... the same particles
  CHECK(consecutive_distance(sorted.state()) < 2);
  sorted.run();
  CHECK(sorted.slots()[5].calls == 4);  // checks at 0, 100, 200, 300: no mismatch
  CHECK(sorted.stats().metrics.at("delaunay.check/mismatches") == 0);
}
