// neighbors.delaunay: rows against a brute-force O(N²) search (set equality, same acceptance
// arithmetic) on uniform random points, the triangular lattice, the degenerate square lattice and
// a clustered state, r from 0.5 to 5 mean spacings, both traversals, f64 and f32; on a
// triangulation made stale by moves after it was built (the 2m widening); row growth, long rings;
// inside a running hard-disk pipeline (stale by overlap_correct) against neighbors.verlet at the
// same cutoff every step for 10³ steps; a phoretic short-range run bit-identical with either
// source; CPU vs CUDA; the refusals.
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/physics/box.h"
#include "core/run/simulation.h"
#include "stages/delaunay/test_support.h"
#include "stages/neighbors/list.h"
#include "support/backends.h"
#include "support/spec.h"
#include "support/stage_driver.h"
#include "support/test_plugins.h"

using namespace ff;
using ff::test::dry;
using ff::test::entry;
namespace dl = ff::test::dl;

namespace {

using Rows = std::vector<std::vector<std::uint32_t>>;

const Registry& stage_registry() {
  static const std::unique_ptr<Registry> r = test::registry_of({"delaunay", "neighbors"});
  return *r;
}
const Registry& model_registry() {
  static const auto r = test::registry_with({"brownian", "phoretic"});
  return *r;
}

std::unique_ptr<Stage> make(const std::string& name, Backend b, Precision p, const test::ParamSettings& set = {}) {
  return test::make_stage(stage_registry(), name, b, p, 2, set);
}

Rows rows(State& s) {
  Field& list = s.field(neighbors::kList);
  Field& count = s.field(neighbors::kCount);
  list.acquire(Where::host, Mode::read);
  count.acquire(Where::host, Mode::read);
  const std::uint32_t cap = neighbors::list_capacity(s);
  Rows r(s.n());
  std::size_t too_long = 0;
  for (std::size_t i = 0; i < s.n(); ++i) {
    const std::uint32_t m = std::min(count.host<std::uint32_t>()[i], cap);
    too_long += count.host<std::uint32_t>()[i] > cap;
    r[i].assign(list.host<std::uint32_t>() + i * cap, list.host<std::uint32_t>() + i * cap + m);
  }
  REQUIRE(too_long == 0);  // a count beyond the row: an overflow left behind
  return r;
}

// Every j ≠ i with |x_j − x_i|² ≤ r² computed as neighbors.verlet's BuildList computes it (in R).
template <class R>
bool within(const State& s, const R* x, std::size_t i, std::size_t j, double r) {
  const auto box = PeriodicBox<R>::make(s.box.L);
  R d2 = 0;
  for (int k = 0; k < 2; ++k) {
    const R d = box.min_image(x[2 * j + k] - x[2 * i + k], k);
    d2 += d * d;
  }
  return d2 <= R(r * r);
}
template <class R>
Rows brute_force_t(State& s, double r) {
  Field& f = s.field(fields::position);
  f.acquire(Where::host, Mode::read);
  const R* x = f.host<R>();
  Rows out(s.n());
  for (std::size_t i = 0; i < s.n(); ++i)
    for (std::size_t j = 0; j < s.n(); ++j)
      if (j != i && within(s, x, i, j, r)) out[i].push_back(std::uint32_t(j));
  return out;
}
Rows brute_force(State& s, double r) {
  return s.precision() == Precision::f64 ? brute_force_t<double>(s, r) : brute_force_t<float>(s, r);
}

// Rows restricted to the pairs within r (a Verlet list also holds pairs up to cutoff + skin).
template <class R>
Rows restrict_t(State& s, const Rows& in, double r) {
  Field& f = s.field(fields::position);
  f.acquire(Where::host, Mode::read);
  Rows out(in.size());
  for (std::size_t i = 0; i < in.size(); ++i)
    for (std::uint32_t j : in[i])
      if (within(s, f.host<R>(), i, j, r)) out[i].push_back(j);
  return out;
}

std::size_t pairs(const Rows& r) {
  std::size_t n = 0;
  for (auto& row : r) n += row.size();
  return n;
}

// The first row that differs, for messages (N when none).
std::size_t first_difference(const Rows& a, const Rows& b) {
  for (std::size_t i = 0; i < a.size(); ++i)
    if (i >= b.size() || a[i] != b[i]) return i;
  return a.size();
}

// Point sets in a box of side L with mean spacing 1 (N = L²).
struct PointSet {
  std::vector<double> xy;
  double Lx, Ly;
};

PointSet uniform_points(int n, std::uint64_t seed) {
  const double L = std::sqrt(double(n));
  return {dl::random_points(std::size_t(n), L, L, seed), L, L};
}
PointSet triangular_points(int nx, int ny) {
  // Spacing chosen so that the mean spacing (area per point)^(1/2) is 1.
  const double a = std::sqrt(2 / std::sqrt(3.0));
  return {dl::triangular_lattice(nx, ny, a), nx * a, ny * a * std::sqrt(3.0) / 2};
}
PointSet square_points(int nx) { return {dl::square_lattice(nx, nx, 1.0), double(nx), double(nx)}; }
// Six dense Gaussian blobs (σ = 1, 100 points each) in a uniform background of 400 points.
PointSet clustered_points(std::uint64_t seed) {
  const double L = std::sqrt(1000.0);
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> u(0, L);
  std::normal_distribution<double> g(0, 1.0);
  std::vector<double> xy;
  for (int c = 0; c < 6; ++c) {
    const double cx = u(gen), cy = u(gen);
    for (int k = 0; k < 100; ++k) {
      xy.push_back(cx + g(gen));
      xy.push_back(cy + g(gen));
    }
  }
  for (int k = 0; k < 400; ++k) {
    xy.push_back(u(gen));
    xy.push_back(u(gen));
  }
  return {xy, L, L};
}

// A State of `pts`, triangulated by delaunay.build, with neighbors.delaunay configured on it.
struct Searched {
  std::unique_ptr<State> s;
  std::unique_ptr<Stage> build, search;
  test::StageDriver driver;

  Searched(const PointSet& pts, Backend b, Precision p, const test::ParamSettings& search_params)
      : s(dl::make_state(pts.xy, pts.Lx, pts.Ly, p)),
        build(make("delaunay.build", b, p)),
        search(make("neighbors.delaunay", b, p, search_params)),
        driver(b, p, 2) {
    build->configure(*s);
    search->configure(*s);
    REQUIRE_FALSE(driver.run(*build, *s).rollback);
  }
  void run(std::uint64_t step = 0) { REQUIRE_FALSE(driver.run(*search, *s, step).rollback); }
};

}  // namespace

TEST_CASE("neighbors.delaunay: rows equal a brute-force search (point sets, r = 0.5 … 5 spacings, both traversals)",
          "[neighbors][delaunay]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const std::string traversal = GENERATE("visited", "parent");
  const int set = GENERATE(0, 1, 2, 3);
  const PointSet pts = set == 0   ? uniform_points(1000, 5)
                       : set == 1 ? triangular_points(30, 34)
                       : set == 2 ? square_points(32)
                                  : clustered_points(7);
  const char* names[] = {"uniform", "triangular lattice", "square lattice", "clustered"};
  for (double r : {0.5, 1.0, 1.5, 2.0, 3.0, 5.0}) {
    INFO(to_string(b) << ", " << traversal << ", " << names[set] << ", r = " << r);
    Searched run(pts, b, Precision::f64, {{"radius", r}, {"traversal", traversal}});
    run.run();
    const Rows got = rows(*run.s), want = brute_force(*run.s, r);
    INFO("first differing row " << first_difference(got, want) << "; pairs " << pairs(got) << " vs " << pairs(want));
    CHECK(got == want);
    if (r >= 1.5) CHECK(pairs(want) > 2 * run.s->n());  // rows with something in them
    CHECK(run.driver.metric("max_move") == 0);
  }
}

TEST_CASE("neighbors.delaunay: exact in single precision", "[neighbors][delaunay][f32]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const std::string traversal = GENERATE("visited", "parent");
  for (double r : {1.0, 2.5}) {
    Searched run(uniform_points(1500, 11), b, Precision::f32, {{"radius", r}, {"traversal", traversal}});
    run.run();
    CHECK(rows(*run.s) == brute_force(*run.s, r));
  }
}

TEST_CASE("neighbors.delaunay: exact on a triangulation made stale by moves since it was built",
          "[neighbors][delaunay][stale]") {
  // Every particle moves up to `step` (a tenth to half a spacing) after the triangulation was
  // made: it is no longer Delaunay for the positions, and edges may even be inverted. The search
  // walks the old positions widened by 2m and must still list exactly the pairs within r now.
  const Backend b = GENERATE(from_range(test::backends()));
  const std::string traversal = GENERATE("visited", "parent");
  const double step = GENERATE(0.1, 0.5);
  const PointSet pts = uniform_points(1200, 23);
  std::mt19937_64 gen(31);
  std::uniform_real_distribution<double> u(-1, 1);
  for (double r : {1.0, 2.0, 4.0}) {
    INFO(to_string(b) << ", " << traversal << ", moves up to " << step << ", r = " << r);
    Searched run(pts, b, Precision::f64, {{"radius", r}, {"traversal", traversal}});
    auto xy = pts.xy;
    double largest = 0;
    for (std::size_t i = 0; i < xy.size(); i += 2) {
      double dx, dy;
      do {
        dx = step * u(gen);
        dy = step * u(gen);
      } while (dx * dx + dy * dy > step * step);
      xy[i] += dx;
      xy[i + 1] += dy;
      largest = std::max(largest, std::sqrt(dx * dx + dy * dy));
    }
    dl::set_positions(*run.s, xy);
    run.run();
    CHECK(run.driver.metric("max_move") == Approx(largest).epsilon(1e-6));
    const Rows got = rows(*run.s), want = brute_force(*run.s, r);
    INFO("first differing row " << first_difference(got, want));
    CHECK(got == want);
  }
}

TEST_CASE("neighbors.delaunay: rows grow when they overflow, never silently; long one-rings", "[neighbors][delaunay][capacity]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const std::string traversal = GENERATE("visited", "parent");
  SECTION("rows: capacity 1 to start") {
    Searched run(uniform_points(800, 3), b, Precision::f64, {{"radius", 3.0}, {"traversal", traversal},
                                                             {"capacity", std::int64_t(1)}});
    run.run();
    CHECK(run.driver.metric("capacity") > 30);
    CHECK(run.driver.metric("max_visited") <= run.driver.metric("capacity"));
    CHECK(rows(*run.s) == brute_force(*run.s, 3.0));
  }
  SECTION("rings: a vertex with 40 Delaunay neighbours (past the 8 members the gather holds in registers)") {
    // A centre with 40 points on a circle of radius 3 around it and a uniform background outside
    // the circle: the centre's one-ring is the 40 circle points.
    PointSet pts = uniform_points(1600, 9);
    const double c = pts.Lx / 2;
    std::vector<double> xy{c, c};
    for (int k = 0; k < 40; ++k) {
      xy.push_back(c + 3 * std::cos(2 * M_PI * k / 40));
      xy.push_back(c + 3 * std::sin(2 * M_PI * k / 40));
    }
    for (std::size_t i = 0; i < pts.xy.size(); i += 2)
      if (std::hypot(pts.xy[i] - c, pts.xy[i + 1] - c) > 3.6) {
        xy.push_back(pts.xy[i]);
        xy.push_back(pts.xy[i + 1]);
      }
    pts.xy = xy;
    for (double r : {1.0, 3.5}) {
      Searched run(pts, b, Precision::f64, {{"radius", r}, {"traversal", traversal}});
      run.run();
      const Rows got = rows(*run.s);
      CHECK(got == brute_force(*run.s, r));
      CHECK(got[0].size() == (r > 3 ? 40u : 0u));
    }
  }
}

TEST_CASE("neighbors.delaunay: CPU and CUDA give the same rows", "[neighbors][delaunay][cuda]") {
  if (!test::have_cuda("neighbors.delaunay CPU vs CUDA")) return;
  const std::string traversal = GENERATE("visited", "parent");
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  auto search = [&](Backend b) {
    Searched run(uniform_points(20000, 41), b, p, {{"radius", 2.0}, {"traversal", traversal}});
    run.run();
    return rows(*run.s);
  };
  const Rows cpu = search(Backend::cpu), gpu = search(Backend::cuda);
  INFO("first differing row " << first_difference(cpu, gpu));
  CHECK(cpu == gpu);
}

namespace {

// Brownian hard disks on the maintained triangulation, neighbors.delaunay after the overlap
// correction (the triangulation is Delaunay for the positions before it).
PipelineSpec hard_disks_spec(std::uint64_t n, std::uint64_t steps, double radius, const std::string& traversal) {
  const Registry& r = model_registry();
  std::vector<StepEntry> step{entry(r, "brownian.integrate", {{"D", 1.0}})};
  for (const char* st : {"delaunay.detect_inversion", "delaunay.flip", "delaunay.lawson", "overlap_correct"})
    step.push_back(entry(r, st));
  step.push_back(entry(r, "neighbors.delaunay", {{"radius", radius}, {"traversal", traversal}}));
  auto s = test::spec(2, n, 0.5, steps, 3e-4, std::move(step), 42);
  s.system.init = "triangular_lattice_sample";
  return s;
}

// neighbors.verlet's rows for the positions of `s` (a fresh list on a copy of the positions).
Rows verlet_rows(State& s, Backend b, double cutoff) {
  auto copy = std::make_unique<State>(2, s.precision(), s.n());
  copy->box = s.box;
  Field& from = s.field(fields::position);
  from.acquire(Where::host, Mode::read);
  Field& to = copy->field(fields::position);
  to.acquire(Where::host, Mode::write);
  std::memcpy(to.host_raw(), from.host_raw(), from.bytes());
  auto verlet = test::make_stage(stage_registry(), "neighbors.verlet", b, s.precision(), 2,
                                 {{"cutoff", cutoff}, {"skin", 0.05}});
  verlet->configure(*copy);
  test::StageDriver driver(b, s.precision(), 2);
  REQUIRE_FALSE(driver.run(*verlet, *copy).rollback);
  const Rows all = rows(*copy);
  return s.precision() == Precision::f64 ? restrict_t<double>(*copy, all, cutoff) : restrict_t<float>(*copy, all, cutoff);
}

}  // namespace

TEST_CASE("neighbors.delaunay: in a hard-disk run (stale by overlap_correct), rows equal neighbors.verlet's every step",
          "[neighbors][delaunay][pipeline]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const std::string traversal = GENERATE("visited", "parent");
  INFO(to_string(b) << ", " << traversal);
  const std::uint64_t steps = 1000;
  const double radius = 2.0;
  Simulation sim(hard_disks_spec(2000, steps, radius, traversal), model_registry(), dry(b));
  std::size_t moved_steps = 0, listed = 0;
  for (std::uint64_t k = 0; k < steps; ++k) {
    sim.advance();
    if (sim.stats().metrics.at("neighbors.delaunay/max_move") > 0) ++moved_steps;
    const Rows got = rows(sim.state()), want = verlet_rows(sim.state(), b, radius);
    INFO("step " << k << ": first differing row " << first_difference(got, want));
    REQUIRE(got == want);
    listed += pairs(got);
  }
  CHECK(sim.stats().rollbacks == 0);
  // overlap_correct moved particles after Lawson on most steps: the stale case was exercised.
  CHECK(moved_steps > steps / 2);
  CHECK(listed > steps * 2000 * 5);  // ~ 8 neighbours each at η = 0.5, r = 2σ
}

namespace {

// Phoretic short range (Carter's c3 charges) on hard disks, the list from `source`. The list
// must exist when the forces run at the start of the step, so delaunay.build makes the first
// triangulation (step 0 only) and neighbors.delaunay searches the one the previous step left.
PipelineSpec phoretic_spec(const std::string& source, std::uint64_t steps) {
  const Registry& r = model_registry();
  std::vector<StepEntry> step;
  step.push_back(entry(r, "delaunay.build", {}, {"", {}, false, steps + 1}));
  if (source == "verlet")
    step.push_back(entry(r, "neighbors.verlet", {{"cutoff", 2.5}, {"skin", 0.5}}));
  else
    step.push_back(entry(r, "neighbors.delaunay", {{"radius", 2.5}}));
  step.push_back(entry(r, "phoretic.forces",
                       {{"range", std::string("short")},
                        {"cutoff", 2.5},
                        {"alpha", std::vector<double>{-1, 1}},
                        {"mu", std::vector<double>{1, -2}}}));
  step.push_back(entry(r, "phoretic.integrate"));
  for (const char* st : {"delaunay.detect_inversion", "delaunay.flip", "delaunay.lawson", "overlap_correct"})
    step.push_back(entry(r, st));
  auto s = test::spec(2, 1024, 0.6, steps, 0.01, std::move(step), 3);
  s.system.init = "triangular_lattice_sample";
  s.system.types = {{"A", 0.5}, {"B", 0.5}};
  return s;
}

}  // namespace

TEST_CASE("neighbors.delaunay: a phoretic short-range run is bit-identical with either neighbour source",
          "[neighbors][delaunay][determinism]") {
  const Backend b = GENERATE(from_range(test::backends()));
  INFO(to_string(b));
  const std::uint64_t steps = 300;
  struct End {
    std::vector<double> x, v;
    std::uint64_t rollbacks;
  };
  auto run = [&](const std::string& source) {
    Simulation sim(phoretic_spec(source, steps), model_registry(), dry(b));
    for (std::uint64_t k = 0; k < steps; ++k) sim.advance();
    return End{test::values(sim.state(), fields::position), test::values(sim.state(), "velocity"),
               sim.stats().rollbacks};
  };
  const End verlet = run("verlet");
  const End delaunay = run("delaunay");
  CHECK(verlet.rollbacks == delaunay.rollbacks);
  // The pair velocities are not trivially zero: the rows carried the interaction.
  double vmax = 0;
  for (double v : verlet.v) vmax = std::max(vmax, std::fabs(v));
  CHECK(vmax > 1e-3);
  REQUIRE(verlet.x.size() == delaunay.x.size());
  REQUIRE(verlet.v.size() == delaunay.v.size());
  CHECK(std::memcmp(verlet.v.data(), delaunay.v.data(), verlet.v.size() * sizeof(double)) == 0);
  CHECK(std::memcmp(verlet.x.data(), delaunay.x.data(), verlet.x.size() * sizeof(double)) == 0);
}

TEST_CASE("neighbors.delaunay: errors name what to change", "[neighbors][delaunay][errors]") {
  const Registry& r = model_registry();
  auto base = [&](std::vector<StepEntry> extra) {
    std::vector<StepEntry> step{entry(r, "brownian.integrate", {{"D", 1.0}})};
    for (const char* st : {"delaunay.detect_inversion", "delaunay.flip", "delaunay.lawson"}) step.push_back(entry(r, st));
    for (auto& e : extra) step.push_back(e);
    return test::spec(2, 400, 0.3, 1, 1e-3, std::move(step));
  };
  SECTION("no triangulation before it") {
    auto s = test::spec(2, 400, 0.3, 1, 1e-3, {entry(r, "neighbors.delaunay")});
    CHECK_THROWS_WITH(Simulation(s, r, dry()),
                      Catch::Contains("list `delaunay.build` (every: a large k, for the first step's triangulation) "
                                      "before it, and delaunay.detect_inversion, delaunay.flip and delaunay.lawson after "
                                      "the integrator"));
  }
  SECTION("between detect_inversion and lawson (the triangulation not yet Delaunay)") {
    std::vector<StepEntry> step{entry(r, "brownian.integrate", {{"D", 1.0}}), entry(r, "delaunay.detect_inversion"),
                                entry(r, "neighbors.delaunay"), entry(r, "delaunay.flip"), entry(r, "delaunay.lawson")};
    Simulation sim(test::spec(2, 400, 0.3, 1, 1e-3, std::move(step)), r, dry());
    CHECK_THROWS_WITH(sim.advance(), Catch::Contains("put neighbors.delaunay after delaunay.flip and delaunay.lawson"));
  }
  SECTION("a radius of half the box") {
    auto s = base({entry(r, "neighbors.delaunay", {{"radius", 20.0}})});
    CHECK_THROWS_WITH(Simulation(s, r, dry()), Catch::Contains("half the smallest box edge"));
  }
  SECTION("two list sources") {
    auto s = base({entry(r, "neighbors.verlet", {{"cutoff", 1.0}}), entry(r, "neighbors.delaunay")});
    CHECK_THROWS_WITH(Simulation(s, r, dry()), Catch::Contains("one neighbour list"));
  }
  SECTION("overlap_correct.verlet rebuilds a Verlet list and refuses this one") {
    auto s = base({entry(r, "neighbors.delaunay"), entry(r, "overlap_correct.verlet")});
    CHECK_THROWS_WITH(Simulation(s, r, dry()), Catch::Contains("put neighbors.verlet before it"));
  }
}

TEST_CASE("neighbors.delaunay: time per search of both traversals (benchmark, not run by CTest)",
          "[.bench][neighbors][delaunay]") {
  // 2^16 uniform points, r = 1.6 mean spacings (π r² ≈ 8 neighbours), the triangulation fresh.
  // Interleaved repeats; the best of each is printed.
  const Backend b = GENERATE(from_range(test::backends()));
  PointSet pts = uniform_points(1 << 16, 77);
  {  // numbered cell by cell (cells of 4 spacings), for memory locality as delaunay.sort gives
    std::vector<std::pair<std::pair<int, double>, std::pair<double, double>>> keyed;
    for (std::size_t i = 0; i < pts.xy.size(); i += 2)
      keyed.push_back({{int(pts.xy[i + 1] / 4) * 1000 + int(pts.xy[i] / 4), pts.xy[i]}, {pts.xy[i], pts.xy[i + 1]}});
    std::sort(keyed.begin(), keyed.end());
    for (std::size_t k = 0; k < keyed.size(); ++k) {
      pts.xy[2 * k] = keyed[k].second.first;
      pts.xy[2 * k + 1] = keyed[k].second.second;
    }
  }
  Searched visited(pts, b, Precision::f64, {{"radius", 1.6}, {"traversal", std::string("visited")}});
  Searched parent(pts, b, Precision::f64, {{"radius", 1.6}, {"traversal", std::string("parent")}});
  // The reference: neighbors.verlet rebuilt every time (particle 0 nudged past skin/2 each time).
  auto grid = dl::make_state(pts.xy, pts.Lx, pts.Ly);
  auto verlet = test::make_stage(stage_registry(), "neighbors.verlet", b, Precision::f64, 2,
                                 {{"cutoff", 1.6}, {"skin", 1e-6}});
  verlet->configure(*grid);
  test::StageDriver verlet_driver(b, Precision::f64, 2);
  double best[3] = {1e30, 1e30, 1e30};
  for (int rep = 0; rep < 20; ++rep)
    for (int t = 0; t < 3; ++t) {
      if (t == 2) {
        auto xy = pts.xy;
        xy[0] += 1e-5 * (rep % 2);
        dl::set_positions(*grid, xy);
      }
      const auto t0 = std::chrono::steady_clock::now();
      if (t == 2) REQUIRE_FALSE(verlet_driver.run(*verlet, *grid, std::uint64_t(rep)).rollback);
      else (t == 0 ? visited : parent).run(std::uint64_t(rep));
      const auto t1 = std::chrono::steady_clock::now();
      best[t] = std::min(best[t], std::chrono::duration<double, std::milli>(t1 - t0).count());
    }
  WARN(to_string(b) << ", N = 65536, r = 1.6: visited " << best[0] << " ms, parent " << best[1]
                    << " ms per search, neighbors.verlet rebuilt " << best[2] << " ms (best of 20); max_visited "
                    << visited.driver.metric("max_visited") << " / " << parent.driver.metric("max_visited"));
  CHECK(rows(*visited.s) == rows(*parent.s));
}
