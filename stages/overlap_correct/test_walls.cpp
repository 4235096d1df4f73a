// Hard planar walls in both overlap corrections (seed-gaps D2, W1): exact moves of one particle
// at a wall (reflect, contact, carried through the wall by an integrator), the same bits as the
// naive definition (every particle gathered every iteration) for a dense jiggled slab, the two
// variants giving the same trajectory in a brownian slab, 3D spheres between walls, ideal
// brownian particles with a flat density profile between the contact planes (χ²), and the wall
// contact theorem βP = ρ(σ/2⁺) against the bulk Z of observe.gr. Pipelines are built without
// YAML (support/spec.h).
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "core/base/error.h"
#include "core/input/init.h"
#include "core/run/simulation.h"
#include "stages/delaunay/common/fields.h"
#include "stages/overlap_correct/kernel.h"
#include "stages/overlap_correct/params.h"
#include "stages/overlap_correct/test_support.h"
#include "support/backends.h"
#include "support/fields.h"
#include "support/spec.h"
#include "support/stage_driver.h"
#include "support/test_plugins.h"

using namespace ff;
using ff::test::positions;
using ff::test::dry;
using ff::test::entry;

namespace {

const Registry& registry() {
  static const auto r = test::registry_with({"brownian"});
  return *r;
}

std::vector<std::int32_t> images(State& s) {
  Field& f = s.field(fields::image);
  f.acquire(Where::host, Mode::read);
  return std::vector<std::int32_t>(f.host<std::int32_t>(), f.host<std::int32_t>() + f.size());
}

void set_positions(State& s, const std::vector<double>& x) {
  Field& f = s.field(fields::position);
  f.acquire(Where::host, Mode::write);
  std::copy(x.begin(), x.end(), f.host<double>());
}

// Smallest r_ij/σ over all pairs (σ = 1): minimum image, except along the wall axis.
double min_gap(State& s, int wall) {
  const auto x = positions(s);
  const int dim = s.dim();
  double worst = HUGE_VAL;
  for (std::size_t i = 0; i < s.n(); ++i)
    for (std::size_t j = i + 1; j < s.n(); ++j) {
      double r2 = 0;
      for (int k = 0; k < dim; ++k) {
        double d = x[dim * j + k] - x[dim * i + k];
        if (k != wall) d -= s.box.L[k] * std::rint(d / s.box.L[k]);
        r2 += d * d;
      }
      worst = std::min(worst, r2);
    }
  return std::sqrt(worst);
}

// The smallest distance of a particle centre to a wall (unwrapped coordinates) and whether every
// image count along the wall axis is 0.
double wall_gap(State& s, int wall, bool& images_zero) {
  const auto x = positions(s);
  const auto m = images(s);
  const int dim = s.dim();
  const double L = s.box.L[wall];
  double worst = HUGE_VAL;
  images_zero = true;
  for (std::size_t i = 0; i < s.n(); ++i) {
    const double u = x[dim * i + wall] + L * m[dim * i + wall];
    worst = std::min({worst, u, L - u});
    images_zero = images_zero && m[dim * i + wall] == 0;
  }
  return worst;
}

double metric(const Simulation& sim, const std::string& name) {
  auto it = sim.stats().metrics.find(name);
  REQUIRE(it != sim.stats().metrics.end());
  return it->second;
}

// The steps of a correction variant, after `before` (an integrator, or nothing).
std::vector<StepEntry> correction(const std::string& variant, const std::string& walls,
                                  std::map<std::string, ParamValue> params = {}, std::vector<StepEntry> before = {}) {
  const Registry& r = registry();
  params["walls"] = walls;
  std::vector<StepEntry> step = std::move(before);
  if (variant == "delaunay") {
    if (step.empty()) {
      step.push_back(entry(r, "delaunay.build"));
    } else {
      for (const char* st : {"delaunay.detect_inversion", "delaunay.flip", "delaunay.lawson"}) step.push_back(entry(r, st));
    }
    step.push_back(entry(r, "overlap_correct", params));
  } else {
    step.push_back(entry(r, "neighbors.verlet", {{"cutoff", 1.0}, {"skin", 0.3}}));
    step.push_back(entry(r, "overlap_correct.verlet", params));
  }
  return step;
}

std::string stage_of(const std::string& variant) {
  return variant == "delaunay" ? "overlap_correct/" : "overlap_correct.verlet/";
}

// A lattice sample squeezed along y into [margin, L − margin] (no overlaps with the walls).
void squeeze(State& s, int wall, double margin) {
  auto x = positions(s);
  const int dim = s.dim();
  const double L = s.box.L[wall];
  for (std::size_t i = 0; i < s.n(); ++i) {
    double& u = x[dim * i + wall];
    u = margin + (L - 2 * margin) * (u / L);
  }
  set_positions(s, x);
}

}  // namespace

TEST_CASE("walls: exact moves of one particle at a wall, both variants", "[overlap][walls]") {
  // 64 disks on a square grid of spacing 4 in a 32 x 32 box (rows at y = 2, 6, ..., 30); particle 0
  // is moved to x = 4 (between two columns) at the height below. Every number is exact in double.
  struct Case {
    const char* mode;
    double cap, y;       // start (wrapped)
    std::int32_t image;  // its image count along y (−1: carried through the bottom wall)
    double y_after;
    double iterations;
  };
  const Case cases[] = {
      {"reflect", 0.25, 0.375, 0, 0.625, 1},       // δ = σ − 2h = 0.25: the reflection about y = σ/2
      {"contact", 0.25, 0.375, 0, 0.5, 1},         // δ/2: left at contact
      {"reflect", 0.25, 31.625, 0, 31.375, 1},     // the top wall: h = 0.375 -> 0.625
      {"reflect", 2.0, 31.875, -1, 1.125, 1},      // through the bottom wall: u = −0.125 -> σ − u = 1.125
      {"reflect", 0.25, 31.875, -1, 0.625, 3},     // the same, capped at 0.25: −0.125, 0.125, 0.375, 0.625
      {"contact", 2.0, 0.125, 1, 31.5, 1},         // through the top wall: u = 32.125 -> 31.5
  };
  for (const char* variant : {"delaunay", "verlet"})
    for (const Case& c : cases) {
      INFO(variant << ": " << c.mode << " cap " << c.cap << " y " << c.y << " image " << c.image);
      auto spec = test::spec(2, 64, 0.05, 1, 0.01,
                             correction(variant, "y", {{"mode", std::string(c.mode)}, {"cap", c.cap}}));
      spec.system.box = {32.0, 32.0};
      auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
      std::vector<double> x(2 * 64);
      for (std::size_t i = 0; i < 64; ++i) {
        x[2 * i] = 2 + 4.0 * double(i % 8);
        x[2 * i + 1] = 2 + 4.0 * double(i / 8);
      }
      x[0] = 4;
      x[1] = c.y;
      set_positions(*state, x);
      Simulation sim(spec, registry(), dry(), std::move(state));
      {  // after configure (which refuses image counts other than 0), as an integrator would
        Field& f = sim.state().field(fields::image);
        f.acquire(Where::host, Mode::readwrite);
        f.host<std::int32_t>()[1] = c.image;
      }
      sim.advance();
      const auto after = positions(sim.state());
      const auto m = images(sim.state());
      CHECK(after[0] == 4);
      CHECK(after[1] == c.y_after);
      CHECK(m[1] == 0);
      CHECK(metric(sim, stage_of(variant) + "iterations") == c.iterations);
      for (std::size_t i = 2; i < after.size(); ++i) CHECK(after[i] == x[i]);
    }
}

namespace {

// A triangulated lattice sample of n disks at η, jiggled by a Gaussian of `amplitude`·σ per
// component (positions wrapped, image counts 0): rows at y ≈ 0 and y ≈ L overlap the walls.
std::unique_ptr<Simulation> jiggled_slab(std::uint64_t n, double eta, double amplitude, std::uint64_t seed) {
  const Registry& r = registry();
  auto s = test::spec(2, n, eta, 1, 0.01, {entry(r, "delaunay.build")}, 3);
  s.system.init = "triangular_lattice_sample";
  auto state = make_initial_state(s.system, s.run.precision, s.run.seed);
  auto x = positions(*state);
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> g(0.0, amplitude);
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double L = state->box.L[i % 2];
    double u = x[i] + g(gen);
    u -= L * std::floor(u / L);
    x[i] = u >= L ? 0.0 : u;
  }
  set_positions(*state, x);
  auto sim = std::make_unique<Simulation>(s, r, dry(), std::move(state));
  sim->advance();
  return sim;
}

// The correction's definition with walls, naively: every iteration gathers every particle
// (Overlaps::gather: its fan and its wall term), then applies every displacement.
struct Reference {
  std::vector<double> xy;
  std::vector<std::int32_t> image;
  std::vector<std::uint8_t> touched;
  double iterations = 0, pairs = 0;
};
Reference reference(State& s, double factor, double cap, double tol, int wall) {
  const std::size_t n = s.n();
  Reference out{positions(s), images(s), std::vector<std::uint8_t>(n, 0)};
  for (const char* f : {fields::diameter, delaunay::fields::halfedge, delaunay::fields::vertex_edge})
    s.field(f).acquire(Where::host, Mode::read);
  const overlap::Overlaps<double, true> m{
      overlap::PushRule::make(PeriodicBox<double>::make(s.box.L), factor, cap, tol, 1.0, 0.0, wall),
      out.xy.data(),
      s.field(fields::diameter).host<double>(),
      s.field(delaunay::fields::halfedge).host<std::int32_t>(),
      s.field(delaunay::fields::vertex_edge).host<std::int32_t>(),
      std::int32_t(n),
      1.0,
      out.image.data()};
  overlap_test::jacobi_reference(m, out.xy.data(), out.image.data(), n, out.iterations, out.pairs,
                                 out.touched.data());
  return out;
}

// overlap_correct driven alone on a triangulated state.
test::StageDriver corrector(State& s, Backend b, const std::map<std::string, ParamValue>& params) {
  auto v = ParamValues::defaults(registry().get("overlap_correct").decl.params);
  for (auto& kv : params) v.set(kv.first, kv.second);
  test::StageDriver d(registry(), "overlap_correct", b, Precision::f64, 2, v, 1);
  d.stage->configure(s);
  return d;
}

}  // namespace

TEST_CASE("walls: overlap_correct gives the same bits as gathering every particle in every iteration",
          "[overlap][walls][determinism]") {
  // 20000 disks at η = 0.5 jiggled by 0.15σ (edge passes, then work lists), walls along y or x.
  // The disks within 0.4σ of the far wall count as carried through the near one (image −1, set
  // after configure): they are reflected from below the near wall, across the seam.
  const Backend backend = GENERATE(from_range(test::backends()));
  for (int wall : {1, 0})
    for (const char* mode : {"reflect", "contact"}) {
      INFO(to_string(backend) << ": walls along " << (wall ? "y" : "x") << ", " << mode);
      auto sim = jiggled_slab(20000, 0.5, 0.15, 7);
      State& s = sim->state();
      auto d = corrector(s, backend, {{"mode", std::string(mode)}, {"walls", std::string(wall ? "y" : "x")}, {"mark", true}});
      std::size_t crossed = 0;
      {
        const auto x = positions(s);
        Field& f = s.field(fields::image);
        f.acquire(Where::host, Mode::readwrite);
        for (std::size_t i = 0; i < s.n(); ++i)
          if (x[2 * i + wall] > s.box.L[wall] - 0.4) {
            f.host<std::int32_t>()[2 * i + wall] = -1;
            ++crossed;
          }
      }
      const Reference ref = reference(s, std::string(mode) == "contact" ? 0.5 : 1.0, 0.25, 1e-6, wall);
      d.step(s, 0, 0.01);
      const auto xy = positions(s);
      const auto m = images(s);
      Field& t = s.field(overlap::touched_field);
      t.acquire(Where::host, Mode::read);
      const std::vector<std::uint8_t> touched(t.host<std::uint8_t>(), t.host<std::uint8_t>() + s.n());
      const double marked = double(std::count(ref.touched.begin(), ref.touched.end(), 1));
      INFO("iterations " << ref.iterations << ", pairs " << ref.pairs << ", carried through " << crossed
                         << ", touched " << marked);
      CHECK(crossed > 10);
      CHECK(ref.iterations >= 3);
      CHECK(d.metric("iterations") == ref.iterations);
      CHECK(d.metric("pairs") == ref.pairs);
      CHECK(std::memcmp(xy.data(), ref.xy.data(), xy.size() * sizeof(double)) == 0);
      CHECK(m == ref.image);
      CHECK(touched == ref.touched);
      CHECK(d.metric("touched") == marked);
      CHECK(d.metric("touched_fraction") == marked / double(s.n()));
      bool zero = true;
      CHECK(wall_gap(s, wall, zero) >= 0.5 * (1 - 1e-6));
      CHECK(zero);
    }
}

TEST_CASE("walls: brownian hard disks in a slab: both variants give the same bits, and no disk leaves it",
          "[overlap][walls][verlet][determinism]") {
  // 2000 disks at η = 0.5 from a lattice sample squeezed into [0.55, L − 0.55], Δt = 3e-4 (every
  // overlapping pair a Gabriel edge, as in test_verlet.cpp's comparison without walls).
  const Backend backend = GENERATE(from_range(test::backends()));
  INFO(to_string(backend));
  const std::uint64_t steps = 500;
  auto run = [&](const std::string& variant, double& iterations, double& closest) {
    auto spec = test::spec(2, 2000, 0.5, steps, 3e-4,
                           correction(variant, "y", {}, {entry(registry(), "brownian.integrate", {{"D", 1.0}})}), 42);
    spec.system.init = "triangular_lattice_sample";
    auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
    squeeze(*state, 1, 0.55);
    Simulation sim(spec, registry(), dry(backend), std::move(state));
    iterations = 0;
    closest = HUGE_VAL;
    bool images_zero = true;
    for (std::uint64_t k = 0; k < steps; ++k) {
      sim.advance();
      iterations += metric(sim, stage_of(variant) + "iterations");
      bool z = true;
      closest = std::min(closest, wall_gap(sim.state(), 1, z));
      images_zero = images_zero && z;
    }
    REQUIRE(sim.stats().rollbacks == 0);
    CHECK(images_zero);
    CHECK(min_gap(sim.state(), 1) >= 1 - 1e-6);
    return positions(sim.state());
  };
  double it_d = 0, it_v = 0, gap_d = 0, gap_v = 0;
  const auto a = run("delaunay", it_d, gap_d);
  const auto b = run("verlet", it_v, gap_v);
  INFO("iterations: Delaunay " << it_d << ", Verlet " << it_v << "; closest approach to a wall " << gap_d << ", "
                               << gap_v);
  CHECK(gap_d >= 0.5 * (1 - 1e-6));
  CHECK(gap_d < 0.51);  // the disks did press on the walls
  CHECK(it_v == it_d);
  CHECK(gap_v == gap_d);
  REQUIRE(a.size() == b.size());
  CHECK(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

TEST_CASE("walls: 3D hard spheres between walls (overlap_correct.verlet)", "[overlap][walls][verlet]") {
  // 1000 spheres at η = 0.3 from a lattice sample squeezed into [0.55, L − 0.55] along z, then
  // along y; 300 brownian steps at Δt = 1e-3.
  const Backend backend = GENERATE(from_range(test::backends()));
  for (int wall : {2, 1}) {
    INFO(to_string(backend) << ": walls along " << (wall == 2 ? "z" : "y"));
    auto spec = test::spec(3, 1000, 0.3, 300, 1e-3,
                           correction("verlet", wall == 2 ? "z" : "y", {},
                                      {entry(registry(), "brownian.integrate", {{"D", 1.0}})}),
                           5);
    spec.system.init = "lattice_sample";
    auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
    squeeze(*state, wall, 0.55);
    Simulation sim(spec, registry(), dry(backend), std::move(state));
    double closest = HUGE_VAL;
    bool images_zero = true;
    for (int k = 0; k < 300; ++k) {
      sim.advance();
      bool z = true;
      closest = std::min(closest, wall_gap(sim.state(), wall, z));
      images_zero = images_zero && z;
    }
    INFO("closest approach to a wall " << closest);
    CHECK(closest >= 0.5 * (1 - 1e-6));
    CHECK(closest < 0.51);
    CHECK(images_zero);
    CHECK(min_gap(sim.state(), wall) >= 1 - 1e-6);
  }
}

TEST_CASE("walls: init: random keeps every centre at least d_i/2 from the walls of the pipeline's correction",
          "[overlap][walls]") {
  // Before: RSA drew over the whole box, and the slab's frame 0 had a disk 0.0016 from a wall,
  // which the first step pushed off by ~σ/2. Both variants, walls along x and along y, two sizes.
  const Registry& r = registry();
  for (const char* variant : {"delaunay", "verlet"})
    for (int wall : {0, 1}) {
      auto step = correction(variant, wall ? "y" : "x", {}, {entry(r, "brownian.integrate", {{"D", 1.0}})});
      if (step[1].stage == "neighbors.verlet") step[1] = entry(r, "neighbors.verlet", {{"cutoff", 2.0}, {"skin", 0.3}});
      auto spec = test::spec(2, 600, 0.0, 1, 3e-4, std::move(step), 7);
      spec.system.box = {wall ? 491.0 : 8.0, wall ? 8.0 : 491.0};  // η = 0.3 with half the disks of diameter 2
      spec.system.types = {SpeciesSpec{"A", 0.5, 1.0}, SpeciesSpec{"B", 0.5, 2.0}};
      INFO(variant << ", walls along " << "xy"[wall]);
      Simulation sim(spec, r, dry());
      State& s = sim.state();
      const auto x = positions(s);
      Field& d = s.field(fields::diameter);
      d.acquire(Where::host, Mode::read);
      double worst = HUGE_VAL;
      for (std::size_t i = 0; i < s.n(); ++i) {
        const double u = x[2 * i + wall], half = 0.5 * d.host<double>()[i];
        worst = std::min({worst, u - half, s.box.L[wall] - u - half});
      }
      CHECK(worst >= -1e-12);
      CHECK(worst < 0.05);  // still reaching the contact planes (the draw is uniform between them)
    }
  // Without walls the draw covers the whole box, as before: some centre lies within 0.05 of x = 0.
  auto spec = test::spec(2, 600, 0.0, 1, 3e-4, {entry(r, "brownian.integrate", {{"D", 1.0}})}, 7);
  spec.system.box = {200.0, 8.0};
  Simulation sim(spec, r, dry());
  const auto x = positions(sim.state());
  double lowest = HUGE_VAL;
  for (std::size_t i = 0; i < 600; ++i) lowest = std::min({lowest, x[2 * i + 1], 8.0 - x[2 * i + 1]});
  CHECK(lowest < 0.05);
}

TEST_CASE("walls: ideal brownian particles fill the slab evenly between the contact planes (χ²)",
          "[overlap][walls][physics]") {
  // 6000 disks (σ = 1) in a 120000 x 4 box, walls along y, 20σ apart along x, so that no two ever
  // meet: ideal brownian particles. All start at y = 2; by t = 6 the slowest mode of the slab,
  // width W = L_y − σ = 3, has decayed by exp(−π²D t/W²) = 1.4e-3 (its amplitude starts at 2),
  // and the profile must be flat on [σ/2, L_y − σ/2] and empty outside. Three snapshots 2 time
  // units apart (18000 samples in 12 bins, χ² with 11 degrees of freedom: 31.3 is its 0.1 %
  // quantile). The crossings are tested too: Δt = 2e-3 gives steps of 0.063σ, and a particle
  // that reaches the wall ends ~1/4 of its steps beyond it.
  const std::uint64_t n = 6000;
  const Registry& r = registry();
  std::vector<StepEntry> step{entry(r, "brownian.integrate", {{"D", 1.0}}),
                              entry(r, "neighbors.verlet", {{"cutoff", 1.0}, {"skin", 1.0}}),
                              entry(r, "overlap_correct.verlet", {{"walls", std::string("y")}})};
  auto spec = test::spec(2, n, 0.0, 5000, 2e-3, std::move(step), 11);
  spec.system.box = {20.0 * double(n), 4.0};
  auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
  std::vector<double> x(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    x[2 * i] = 20.0 * double(i) + 10;
    x[2 * i + 1] = 2.0;
  }
  set_positions(*state, x);
  Simulation sim(spec, r, dry(), std::move(state));
  const int bins = 12;
  std::vector<double> count(bins, 0);
  double outside = 0, samples = 0, lowest = HUGE_VAL, highest = -HUGE_VAL;
  for (std::uint64_t k = 1; k <= 5000; ++k) {
    sim.advance();
    if (k < 3000 || k % 1000 != 0) continue;
    const auto p = positions(sim.state());
    for (std::size_t i = 0; i < n; ++i) {
      const double y = p[2 * i + 1];
      lowest = std::min(lowest, y);
      highest = std::max(highest, y);
      const int b = int(std::floor((y - 0.5) / 3.0 * bins));
      if (b < 0 || b >= bins)
        ++outside;
      else
        ++count[std::size_t(b)];
      ++samples;
    }
  }
  const double expected = samples / bins;
  double chi2 = 0;
  std::string profile;
  for (double c : count) {
    chi2 += (c - expected) * (c - expected) / expected;
    profile += " " + std::to_string(int(c));
  }
  INFO("counts per bin (expected " << expected << "):" << profile << "; χ² = " << chi2 << "; y in [" << lowest << ", "
                                   << highest << "]");
  CHECK(lowest >= 0.5 * (1 - 1e-6));
  CHECK(highest <= 4 - 0.5 * (1 - 1e-6));
  CHECK(outside <= samples * 1e-4);  // only disks within the tolerance of a contact plane
  CHECK(chi2 < 31.3);
}

TEST_CASE("walls: the wall contact theorem βP = ρ(σ/2⁺) with the bulk Z of observe.gr within 3 %, η = 0.3",
          "[overlap][walls][physics][long]") {
  // A slab of 2000 hard disks (σ = D = 1), 16σ between the walls and η = 0.3 overall, Δt = 3e-4
  // (test_hard_disk_eos.cpp: that Δt biases the contact value by about +1 %): 2 time units from
  // the RSA start, then the wall-distance histogram every 10 steps for 60. (A few disks are within
  // the fit's 0.3σ of a wall at a time: 1000 disks for 4 time units gave ratios from 0.95 to 1.01
  // over seeds; this length gives 0.987, 0.980, 0.984 for seeds 42, 7, 3.) The contact density
  // ρ(σ/2⁺) is a least-squares quadratic through bins of 0.02σ over the first 0.3σ, the bulk
  // density ρ_b the mean over the middle half of the slab. Then a periodic box at η_b = πρ_b/4
  // (same N, Δt and duration) gives Z = βP/ρ from observe.gr, and ρ(σ/2⁺)/ρ_b must equal it.
  const Backend backend = GENERATE(from_range(test::backends()));
  const Registry& r = registry();
  const std::uint64_t n = 2000, equilibrate = 6667, steps = 206667;
  const double dt = 3e-4, Ly = 16, Lx = double(n) * M_PI / 4 / (0.3 * Ly);
  auto spec = test::spec(2, n, 0.0, steps, dt,
                         correction("delaunay", "y", {}, {entry(r, "brownian.integrate", {{"D", 1.0}})}), 42);
  spec.system.box = {Lx, Ly};
  spec.system.init = "random";
  Simulation slab(spec, r, dry(backend));
  const double w = 0.02;
  const int near = 15;
  std::vector<double> hist(near, 0);
  double middle = 0, frames = 0;
  for (std::uint64_t k = 0; k < steps; ++k) {
    slab.advance();
    if (k < equilibrate || k % 10 != 0) continue;
    const auto p = positions(slab.state());
    for (std::size_t i = 0; i < n; ++i) {
      const double y = p[2 * i + 1];
      const double h = std::min(y, Ly - y) - 0.5;
      const int b = int(std::floor(h / w));
      if (b >= 0 && b < near) ++hist[std::size_t(b)];
      if (std::fabs(y - Ly / 2) < Ly / 4) ++middle;
    }
    ++frames;
  }
  const double rho_b = middle / (frames * Lx * Ly / 2);
  // Quadratic least squares ρ(h) = c0 + c1 h + c2 h² through the bin centres.
  double S[5] = {0, 0, 0, 0, 0}, T[3] = {0, 0, 0};
  for (int b = 0; b < near; ++b) {
    const double h = (b + 0.5) * w, rho = hist[std::size_t(b)] / (frames * 2 * Lx * w);
    for (int q = 0; q < 5; ++q) S[q] += std::pow(h, q);
    for (int q = 0; q < 3; ++q) T[q] += rho * std::pow(h, q);
  }
  auto det3 = [](double a, double b, double c, double d, double e, double f, double g, double h, double i) {
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
  };
  const double D = det3(S[0], S[1], S[2], S[1], S[2], S[3], S[2], S[3], S[4]);
  const double rho_c = det3(T[0], S[1], S[2], T[1], S[2], S[3], T[2], S[3], S[4]) / D;
  const double eta_b = M_PI / 4 * rho_b;

  auto bulk = test::spec(2, n, eta_b, steps, dt,
                         {entry(r, "brownian.integrate", {{"D", 1.0}}), entry(r, "delaunay.detect_inversion"),
                          entry(r, "delaunay.flip"), entry(r, "delaunay.lawson"), entry(r, "overlap_correct"),
                          entry(r, "observe.gr", {{"from_step", std::int64_t(equilibrate)}}, {"", {}, false, 10})},
                         42);
  bulk.system.init = "random";
  Simulation periodic(bulk, r, dry(backend));
  periodic.run();
  const double z = metric(periodic, "observe.gr/Z");
  const double henderson = (1 + eta_b * eta_b / 8) / ((1 - eta_b) * (1 - eta_b));
  WARN(to_string(backend) << ": slab ρ_b = " << rho_b << " (η_b = " << eta_b << "), ρ(σ/2⁺) = " << rho_c
                          << ", ρ(σ/2⁺)/ρ_b = " << rho_c / rho_b << "; bulk Z (observe.gr) = " << z
                          << ", Henderson " << henderson << "; ratio " << rho_c / (rho_b * z));
  CHECK(std::fabs(rho_c / (rho_b * z) - 1) < 0.03);
  bool images_zero = true;
  CHECK(wall_gap(slab.state(), 1, images_zero) >= 0.5 * (1 - 1e-6));
  CHECK(images_zero);
}

TEST_CASE("walls: CPU and CUDA give the same bits (double)", "[overlap][walls][cuda]") {
  if (!test::have_cuda("walls CPU vs CUDA")) return;
  for (const char* variant : {"delaunay", "verlet"}) {
    INFO(variant);
    std::vector<std::vector<double>> xy;
    std::vector<std::vector<std::uint8_t>> marks;
    for (Backend b : {Backend::cpu, Backend::cuda}) {
      auto spec = test::spec(2, 20000, 0.6, 200, 1e-3,
                             correction(variant, "y", {{"mark", true}},
                                        {entry(registry(), "brownian.integrate", {{"D", 1.0}})}),
                             42);
      spec.system.init = "triangular_lattice_sample";
      Simulation sim(spec, registry(), dry(b));
      for (int k = 0; k < 200; ++k) sim.advance();
      sim.synchronize();
      xy.push_back(positions(sim.state()));
      Field& t = sim.state().field(overlap::touched_field);
      t.acquire(Where::host, Mode::read);
      marks.emplace_back(t.host<std::uint8_t>(), t.host<std::uint8_t>() + sim.state().n());
    }
    CHECK(std::memcmp(xy[0].data(), xy[1].data(), xy[0].size() * sizeof(double)) == 0);
    CHECK(marks[0] == marks[1]);
  }
}

TEST_CASE("walls: errors name what to change", "[overlap][walls][errors]") {
  const Registry& r = registry();
  SECTION("walls: z in 2D") {
    auto s = test::spec(2, 200, 0.3, 1, 0.01, correction("delaunay", "z"));
    CHECK_THROWS_WITH(Simulation(s, r, dry()), Catch::Contains("walls: z"));
  }
  SECTION("a slab narrower than two diameters") {
    auto s = test::spec(2, 10, 0.3, 1, 0.01, correction("delaunay", "y"));
    s.system.box = {20.0, 1.5};
    CHECK_THROWS_WITH(Simulation(s, r, dry()), Catch::Contains("make the box longer along y"));
  }
  SECTION("a start with box crossings along the wall axis") {
    auto s = test::spec(2, 200, 0.3, 1, 0.01, correction("verlet", "y"));
    s.system.init = "triangular_lattice_sample";
    auto state = make_initial_state(s.system, s.run.precision, s.run.seed);
    Field& f = state->field(fields::image);
    f.acquire(Where::host, Mode::readwrite);
    f.host<std::int32_t>()[2 * 7 + 1] = 2;
    CHECK_THROWS_WITH(Simulation(s, r, dry(), std::move(state)), Catch::Contains("particle 7 has image count 2"));
  }
}
