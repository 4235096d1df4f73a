// What the overlap_correct tests share (test_overlap_correct.cpp, test_determinism.cpp,
// test_errors.cpp, test_cpu_cuda.cpp in this folder): their registry, pipelines built without
// YAML (support/spec.h: delaunay.build triangulates, overlap_correct corrects), positions and
// diameters read and written on the host, the smallest gap, random overlaps (a jiggled lattice, an
// ideal gas), the stage's metrics, a triangulated state with the stage driven alone on it, and
// 64 hand-placed disks for the motifs.
#pragma once
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/input/init.h"
#include "core/run/simulation.h"
#include "stages/overlap_correct/kernel.h"
#include "support/fields.h"
#include "support/spec.h"
#include "support/stage_driver.h"
#include "support/test_plugins.h"

namespace ff::overlap_test {

using ff::test::dry;
using ff::test::entry;

inline const Registry& registry() {
  static const auto r = test::registry_with({});
  return *r;
}

inline PipelineSpec correct_spec(std::uint64_t n, double eta, const std::map<std::string, ParamValue>& params = {},
                                 Precision p = Precision::f64) {
  const Registry& r = registry();
  auto s = test::spec(2, n, eta, 1, 0.01, {entry(r, "delaunay.build"), entry(r, "overlap_correct", params)}, 3, p);
  s.system.init = "triangular_lattice_sample";
  return s;
}

using ff::test::positions;  // any precision, as doubles

template <class R>
void set_positions(State& s, const std::vector<double>& xy) {
  Field& f = s.field(fields::position);
  f.acquire(Where::host, Mode::write);
  for (std::size_t i = 0; i < xy.size(); ++i) {
    const double L = s.box.L[i % 2];
    double x = xy[i] - L * std::floor(xy[i] / L);
    if (x >= L) x -= L;
    f.host<R>()[i] = R(x);
  }
}

inline void set_positions(State& s, const std::vector<double>& xy) {
  if (s.precision() == Precision::f64)
    set_positions<double>(s, xy);
  else
    set_positions<float>(s, xy);
}

// The stage's definition, naively (the reference its loops are held to): every iteration gathers
// every particle with `m` (Overlaps::gather, the fan walk in fan order), then applies every
// displacement, until no pair overlaps beyond the tolerance. Adds the iterations and pairs to
// `iterations` / `pairs`; marks the particles some overlap touched when `touched` is given.
template <class M>
void jacobi_reference(const M& m, double* xy, std::int32_t* image, std::size_t n, double& iterations, double& pairs,
                      std::uint8_t* touched = nullptr) {
  std::vector<double> d(2 * n);
  for (;;) {
    std::uint64_t bad = 0, count = 0, broken = 0;
    for (std::size_t v = 0; v < n; ++v) {
      const auto q = m.gather(int(v));
      broken += q.broken;
      d[2 * v] = q.dx;
      d[2 * v + 1] = q.dy;
      bad += q.bad;
      count += q.pairs;
      if (touched && q.touched) touched[v] = 1;
    }
    REQUIRE(broken == 0);
    if (!bad) return;
    pairs += double(count);
    ++iterations;
    for (std::size_t v = 0; v < n; ++v) overlap::apply_one(xy, image, m.box, v, d[2 * v], d[2 * v + 1]);
  }
}

inline std::vector<double> diameters(State& s) {
  Field& f = s.field(fields::diameter);
  f.acquire(Where::host, Mode::read);
  std::vector<double> d(s.n());
  for (std::size_t i = 0; i < s.n(); ++i)
    d[i] = s.precision() == Precision::f64 ? f.host<double>()[i] : double(f.host<float>()[i]);
  return d;
}

// Smallest r_ij / σ_ij over all pairs (minimum image, brute force).
inline double min_gap(State& s) {
  const auto xy = positions(s);
  const auto d = diameters(s);
  const double L0 = s.box.L[0], L1 = s.box.L[1];
  double worst = HUGE_VAL;
  for (std::size_t i = 0; i < s.n(); ++i)
    for (std::size_t j = i + 1; j < s.n(); ++j) {
      double dx = xy[2 * j] - xy[2 * i], dy = xy[2 * j + 1] - xy[2 * i + 1];
      dx -= L0 * std::rint(dx / L0);
      dy -= L1 * std::rint(dy / L1);
      worst = std::min(worst, std::sqrt(dx * dx + dy * dy) / (0.5 * (d[i] + d[j])));
    }
  return worst;
}

// Every particle displaced by a Gaussian of `amplitude` per component (seeded): random overlaps.
inline void jiggle(State& s, double amplitude, std::uint64_t seed) {
  auto xy = positions(s);
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> g(0.0, amplitude);
  for (auto& x : xy) x += g(gen);
  set_positions(s, xy);
}

// Uniform random positions: an ideal gas, overlapping everywhere.
inline void scatter(State& s, std::uint64_t seed) {
  std::vector<double> xy(2 * s.n());
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (std::size_t i = 0; i < xy.size(); ++i) xy[i] = u(gen) * s.box.L[i % 2];
  set_positions(s, xy);
}

inline double metric(const Simulation& sim, const std::string& m) {
  auto it = sim.stats().metrics.find("overlap_correct/" + m);
  REQUIRE(it != sim.stats().metrics.end());
  return it->second;
}

// A triangulated state: the lattice sample of correct_spec, `before` applied to it, then
// delaunay.build run once, then `after` applied.
template <class Before, class After>
std::unique_ptr<Simulation> triangulated(std::uint64_t n, double eta, Before before, After after) {
  const Registry& r = registry();
  auto s = test::spec(2, n, eta, 1, 0.01, {entry(r, "delaunay.build")}, 3);
  s.system.init = "triangular_lattice_sample";
  auto state = make_initial_state(s.system, s.run.precision, s.run.seed);
  before(*state);
  auto sim = std::make_unique<Simulation>(s, r, dry(), std::move(state));
  sim->advance();
  after(sim->state());
  return sim;
}

// overlap_correct driven alone on a triangulated state, as the scheduler would.
inline test::StageDriver corrector(State& s, Backend b, const std::map<std::string, ParamValue>& params = {}) {
  auto v = ParamValues::defaults(registry().get("overlap_correct").decl.params);
  for (auto& kv : params) v.set(kv.first, kv.second);
  test::StageDriver d(registry(), "overlap_correct", b, Precision::f64, 2, v, 1);
  d.stage->configure(s);
  return d;
}

// 64 disks (σ = 1) on a square grid of spacing 4 in a 32 x 32 box: rows and columns at 2, 6, ..., 30.
inline std::vector<double> grid64() {
  std::vector<double> xy(2 * 64);
  for (std::size_t i = 0; i < 64; ++i) {
    xy[2 * i] = 2 + 4.0 * double(i % 8);
    xy[2 * i + 1] = 2 + 4.0 * double(i / 8);
  }
  return xy;
}

// One step of `steps` on the 64 disks at xy with the given diameters (1 where not listed).
inline std::unique_ptr<Simulation> hand_made(const std::vector<StepEntry>& steps, const std::vector<double>& xy,
                                             const std::map<std::size_t, double>& diameter, Backend b = Backend::cpu) {
  auto spec = test::spec(2, 64, 0.05, 1, 0.01, steps, 3);
  spec.system.box = {32.0, 32.0};
  auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
  set_positions(*state, xy);
  Field& d = state->field(fields::diameter);
  d.acquire(Where::host, Mode::readwrite);
  for (auto& kv : diameter) d.host<double>()[kv.first] = kv.second;
  return std::make_unique<Simulation>(spec, registry(), dry(b), std::move(state));
}

// The steps of either variant: delaunay.build + overlap_correct ("delaunay"), or neighbors.verlet +
// overlap_correct.verlet.
inline std::vector<StepEntry> variant_steps(const std::string& variant,
                                            const std::map<std::string, ParamValue>& params) {
  const Registry& r = registry();
  if (variant == "delaunay") return {entry(r, "delaunay.build"), entry(r, "overlap_correct", params)};
  return {entry(r, "neighbors.verlet", {{"cutoff", 1.0}, {"skin", 0.3}}), entry(r, "overlap_correct.verlet", params)};
}

}  // namespace ff::overlap_test
