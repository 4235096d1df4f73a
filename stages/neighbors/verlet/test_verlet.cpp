// neighbors.verlet driven alone on hand-made states: lists against a brute-force O(N²) search
// (2D and 3D, boxes with fewer than three cells along an axis, float and double), Tran's dynamic
// rebuild test, capacity growth, CPU vs CUDA.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "core/base/error.h"
#include "core/stage/registry.h"
#include "core/stage/state.h"
#include "stages/neighbors/list.h"
#include "support/backends.h"
#include "support/stage_driver.h"
#include "support/test_plugins.h"

using namespace ff;

namespace {

const Registry& registry() {
  static const std::unique_ptr<Registry> r = test::registry_of({"neighbors"});
  return *r;
}

// neighbors.verlet with (cutoff, skin), driven step by step (support/stage_driver.h). It reads
// neither dt, time nor the RNG key, so step(s, k) passes a nominal dt and seed 0.
struct Run : test::StageDriver {
  Run(Backend b, Precision p, int dim, double cutoff, double skin)
      : StageDriver(registry(), "neighbors.verlet", b, p, dim, params(cutoff, skin), 0) {}
  static ParamValues params(double cutoff, double skin) {
    ParamValues v;
    v.set("cutoff", cutoff);
    v.set("skin", skin);
    return v;
  }
  void step(State& s, std::uint64_t k) { StageDriver::step(s, k, 0.01); }
};

// Uniformly random positions in a box with edges L (one per axis).
std::unique_ptr<State> random_state(int dim, Precision p, std::size_t n, std::vector<double> L, unsigned seed) {
  auto s = std::make_unique<State>(dim, p, n);
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> u(0, 1);
  for (int k = 0; k < dim; ++k) s->box.L[k] = L[k];
  Field& x = s->field(fields::position);
  for (std::size_t i = 0; i < n * dim; ++i) {
    const double v = u(gen) * L[i % dim];
    if (p == Precision::f64) x.host<double>()[i] = v;
    else x.host<float>()[i] = float(v);
  }
  return s;
}

double coord(State& s, std::size_t i, int k) {
  Field& x = s.field(fields::position);
  return s.precision() == Precision::f64 ? x.host<double>()[i * s.dim() + k]
                                          : double(x.host<float>()[i * s.dim() + k]);
}
void set_coord(State& s, std::size_t i, int k, double v) {
  Field& x = s.field(fields::position);
  x.acquire(Where::host, Mode::readwrite);
  if (s.precision() == Precision::f64) x.host<double>()[i * s.dim() + k] = v;
  else x.host<float>()[i * s.dim() + k] = float(v);
}

// Positions as doubles (host copy).
std::vector<double> positions(State& s) {
  s.field(fields::position).acquire(Where::host, Mode::read);
  std::vector<double> x(s.n() * s.dim());
  for (std::size_t i = 0; i < s.n(); ++i)
    for (int k = 0; k < s.dim(); ++k) x[i * s.dim() + k] = coord(s, i, k);
  return x;
}

// Squared minimum-image distance, in double (the stage works in the run's precision: compare
// only pairs not within `eps` of the list radius).
double dist2(const State& s, const std::vector<double>& x, std::size_t i, std::size_t j) {
  double d2 = 0;
  for (int k = 0; k < s.dim(); ++k) {
    double d = x[i * s.dim() + k] - x[j * s.dim() + k];
    d -= s.box.L[k] * std::rint(d / s.box.L[k]);
    d2 += d * d;
  }
  return d2;
}

std::vector<std::vector<std::uint32_t>> rows(State& s) {
  Field& list = s.field(neighbors::kList);
  Field& count = s.field(neighbors::kCount);
  list.acquire(Where::host, Mode::read);
  count.acquire(Where::host, Mode::read);
  const std::uint32_t cap = neighbors::list_capacity(s);
  std::vector<std::vector<std::uint32_t>> r(s.n());
  for (std::size_t i = 0; i < s.n(); ++i) {
    const std::uint32_t m = count.host<std::uint32_t>()[i];
    REQUIRE(m <= cap);
    r[i].assign(list.host<std::uint32_t>() + i * cap, list.host<std::uint32_t>() + i * cap + m);
  }
  return r;
}

// Every row: sorted ascending, no self, no duplicates, exactly the particles within r_list
// (pairs within eps of r_list may go either way in float). Returns the number of listed pairs.
std::size_t check_against_brute_force(State& s, double rl) {
  const auto x = positions(s);
  const auto r = rows(s);
  const double eps = s.precision() == Precision::f64 ? 1e-9 : 1e-4;
  std::size_t pairs = 0, brute = 0;
  for (std::size_t i = 0; i < s.n(); ++i) {
    REQUIRE(std::is_sorted(r[i].begin(), r[i].end()));
    REQUIRE(std::adjacent_find(r[i].begin(), r[i].end()) == r[i].end());
    std::vector<std::uint32_t> want;
    for (std::size_t j = 0; j < s.n(); ++j) {
      if (j == i) continue;
      const double d = std::sqrt(dist2(s, x, i, j));
      if (std::fabs(d - rl) < eps) {  // borderline: accept either, keep it out of the comparison
        auto it = std::find(r[i].begin(), r[i].end(), std::uint32_t(j));
        if (it != r[i].end()) want.push_back(std::uint32_t(j));
        continue;
      }
      if (d < rl) want.push_back(std::uint32_t(j));
    }
    INFO("particle " << i);
    REQUIRE(r[i] == want);
    pairs += r[i].size();
    brute += want.size();
  }
  CHECK(pairs == brute);
  return pairs;
}

}  // namespace

TEST_CASE("neighbors.verlet: lists equal a brute-force search (2D/3D, thin boxes, f32/f64)", "[neighbors]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  struct Case {
    int dim;
    std::size_t n;
    std::vector<double> L;
  };
  // Boxes of many cells, and boxes with 1 or 2 cells along an axis (scanned whole, no duplicates).
  const auto c = GENERATE(Case{2, 3000, {60, 45}}, Case{2, 400, {6.5, 40}}, Case{2, 300, {9.5, 7.0}},
                          Case{3, 3000, {16, 14, 18}}, Case{3, 500, {6.2, 9.1, 21}});
  INFO("backend " << to_string(b) << ", " << c.dim << "D, N = " << c.n << ", " << to_string(p));
  const double cutoff = 2.5, skin = 0.6;
  auto s = random_state(c.dim, p, c.n, c.L, 17);
  Run run(b, p, c.dim, cutoff, skin);
  run.stage->configure(*s);
  run.step(*s, 0);
  CHECK(run.metric("rebuilds") == 1);
  const std::size_t pairs = check_against_brute_force(*s, cutoff + skin);
  CHECK(pairs > 0);
  std::uint32_t most = 0;
  for (auto& row : rows(*s)) most = std::max<std::uint32_t>(most, std::uint32_t(row.size()));
  CHECK(run.metric("max_neighbors") == most);
  // The cutoff other stages check against.
  Field& cut = s->field(neighbors::kCutoff);
  CHECK((p == Precision::f64 ? cut.host<double>()[0] : double(cut.host<float>()[0])) == Approx(cutoff));
}

TEST_CASE("neighbors.verlet: rebuilt only when a particle moved more than skin/2", "[neighbors][dynamic]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  const double cutoff = 1.5, skin = 0.4;
  auto s = dim == 2 ? random_state(2, Precision::f64, 2000, {40, 40}, 3)
                    : random_state(3, Precision::f64, 2000, {12, 12, 12}, 3);
  Run run(b, Precision::f64, dim, cutoff, skin);
  run.stage->configure(*s);
  run.step(*s, 0);
  CHECK(run.metric("rebuilds") == 1);
  const auto before = rows(*s);

  // Everyone moves 0.19 < skin/2 = 0.2 (across the periodic boundary for some): no rebuild.
  s->field(fields::position).acquire(Where::host, Mode::read);
  for (std::size_t i = 0; i < s->n(); ++i) {
    double x = coord(*s, i, 0) + 0.19;
    if (x >= s->box.L[0]) x -= s->box.L[0];
    set_coord(*s, i, 0, x);
  }
  run.step(*s, 1);
  CHECK(run.metric("rebuilds") == 0);
  CHECK(rows(*s) == before);
  // The list is still complete for the cutoff: every pair within r_c is listed.
  const auto r = rows(*s);
  const auto x = positions(*s);
  for (std::size_t i = 0; i < s->n(); ++i)
    for (std::size_t j = 0; j < s->n(); ++j)
      if (j != i && dist2(*s, x, i, j) < cutoff * cutoff) REQUIRE(std::binary_search(r[i].begin(), r[i].end(), j));

  // Particle 7 moves 0.05 further along x, 0.24 > skin/2 in all: rebuild, and the new list is
  // exact again.
  s->field(fields::position).acquire(Where::host, Mode::read);
  double x7 = coord(*s, 7, 0) + 0.05;
  if (x7 >= s->box.L[0]) x7 -= s->box.L[0];
  set_coord(*s, 7, 0, x7);
  run.step(*s, 2);
  CHECK(run.metric("rebuilds") == 1);
  check_against_brute_force(*s, cutoff + skin);
  run.step(*s, 3);
  CHECK(run.metric("rebuilds") == 0);
}

TEST_CASE("neighbors.verlet: row capacity grows when a cluster forms", "[neighbors][capacity]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  const std::size_t n = 1500;
  auto s = dim == 2 ? random_state(2, Precision::f64, n, {120, 120}, 9)
                    : random_state(3, Precision::f64, n, {30, 30, 30}, 9);
  Run run(b, Precision::f64, dim, 2.0, 0.5);
  run.stage->configure(*s);
  run.step(*s, 0);
  const std::uint32_t cap0 = neighbors::list_capacity(*s);
  check_against_brute_force(*s, 2.5);
  // Squeeze a third of the particles into a small ball: far more neighbours than the rows hold.
  std::mt19937_64 gen(4);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  s->field(fields::position).acquire(Where::host, Mode::read);
  for (std::size_t i = 0; i < n / 3; ++i)
    for (int k = 0; k < dim; ++k) set_coord(*s, i, k, 10 + u(gen));
  run.step(*s, 1);
  CHECK(run.metric("rebuilds") == 1);
  const std::uint32_t cap1 = neighbors::list_capacity(*s);
  INFO("capacity " << cap0 << " -> " << cap1 << ", max_neighbors " << run.metric("max_neighbors"));
  CHECK(cap1 > cap0);
  CHECK(run.metric("max_neighbors") > cap0);
  CHECK(run.metric("max_neighbors") <= cap1);
  check_against_brute_force(*s, 2.5);
}

TEST_CASE("neighbors.verlet: cutoff + skin beyond half the box is an InputError", "[neighbors]") {
  auto s = random_state(2, Precision::f64, 10, {8, 20}, 1);
  Run run(Backend::cpu, Precision::f64, 2, 3.5, 0.6);
  CHECK_THROWS_AS(run.stage->configure(*s), InputError);
}

TEST_CASE("neighbors.verlet: CPU and CUDA build the same lists", "[neighbors][cuda]") {
  if (!test::have_cuda("neighbors.verlet CPU vs CUDA")) return;
  const int dim = GENERATE(2, 3);
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  auto build = [&](Backend b) {
    auto s = dim == 2 ? random_state(2, p, 20000, {150, 150}, 21) : random_state(3, p, 20000, {30, 30, 30}, 21);
    Run run(b, p, dim, 2.5, 0.4);
    run.stage->configure(*s);
    run.step(*s, 0);
    return rows(*s);
  };
  CHECK(build(Backend::cpu) == build(Backend::cuda));
}
