// trap.harmonic against its formula and its statistical mechanics: a hand-made state gets exactly
// F = −k (x − c) with the minimum image (a particle across the periodic boundary from the centre
// too), on the trapped axes only, added to an earlier force with add: true, and U = k/2 |x − c|²;
// with overdamped.integrate (D, μ: k_BT = D/μ) the mean displacement from an offset start decays
// as exp(−μkt) and the stationary ⟨(x − c)_a²⟩ is k_BT/k per axis (equipartition), within three
// standard errors; CPU and CUDA give the same bits. Hard disks in the trap are in hydrostatic
// equilibrium with the hard-disk equation of state (the trap's virial against the local-density
// pressure).
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <random>

#include "core/run/simulation.h"
#include "core/stage/stage_registration.h"
#include "support/backends.h"
#include "support/fields.h"
#include "support/spec.h"
#include "support/stage_driver.h"
#include "support/test_plugins.h"

using namespace ff;
using test::values;

namespace {

const Registry& registry() {
  static const auto r = test::registry_with({"trap"});
  return *r;
}

// n particles at positions x (n x dim) in a periodic box of side L.
std::unique_ptr<State> state(int dim, Precision p, double L, const std::vector<double>& x) {
  auto s = std::make_unique<State>(dim, p, x.size() / dim);
  for (int c = 0; c < dim; ++c) s->box.L[c] = L;
  Field& f = s->field(fields::position);
  f.acquire(Where::host, Mode::write);
  for (std::size_t i = 0; i < x.size(); ++i)
    if (p == Precision::f64) f.host<double>()[i] = x[i];
    else f.host<float>()[i] = float(x[i]);
  return s;
}

// A field `name` of real x components, every element `value` (the force a stage before wrote).
void fill(State& s, const char* name, int components, double value) {
  Field& f = s.add_particle_field(name, s.real(), components);
  f.acquire(Where::host, Mode::write);
  for (std::size_t i = 0; i < f.size(); ++i)
    if (s.precision() == Precision::f64) f.host<double>()[i] = value;
    else f.host<float>()[i] = float(value);
}

test::StageDriver trap(State& s, Backend b, test::ParamSettings set) {
  ParamValues v = ParamValues::defaults(registry().get("trap.harmonic").decl.params);
  for (auto& kv : set) v.set(kv.first, kv.second);
  test::StageDriver d(registry(), "trap.harmonic", b, s.precision(), s.dim(), v, 1);
  d.stage->configure(s);
  return d;
}

// A random state of n particles in a box of side 6 and a trap off the box centre.
std::unique_ptr<State> scattered(int dim, Precision p) {
  std::mt19937_64 gen(3);
  std::uniform_real_distribution<double> u(0, 6);
  std::vector<double> x(3000 * dim);
  for (auto& v : x) v = u(gen);
  return state(dim, p, 6, x);
}

}  // namespace

TEST_CASE("trap.harmonic: F = −k (x − c) and U = k/2 |x − c|², minimum image, exactly", "[trap]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  INFO(to_string(b) << ", " << dim << "D, " << to_string(p));
  const double k = 2.5, L = 8;
  // Centre (0.25, 4[, 4]) near the boundary. Particle 0 at (7.75, 4.5[, 3]) is 0.5 from it across
  // the boundary along x: d = (−0.5, 0.5[, −1]); particle 1 at (1.25, 6.25[, 4.125]):
  // d = (1, 2.25[, 0.125]); particle 2 on the centre. Dyadic numbers: exact in float too.
  std::vector<double> c{0.25, 4, 4}, x, d;
  if (dim == 2) x = {7.75, 4.5, 1.25, 6.25, 0.25, 4}, d = {-0.5, 0.5, 1, 2.25, 0, 0};
  else x = {7.75, 4.5, 3, 1.25, 6.25, 4.125, 0.25, 4, 4}, d = {-0.5, 0.5, -1, 1, 2.25, 0.125, 0, 0, 0};
  c.resize(dim);
  auto s = state(dim, p, L, x);
  // The state's force is exactly −k·disp and trap.energy k/2 |disp|², particle by particle.
  auto check_trap = [&](State& st, const std::vector<double>& disp) {
    const auto f = values(st, "force"), u = values(st, "trap.energy");
    for (std::size_t i = 0; i < 3; ++i) {
      double d2 = 0;
      for (int a = 0; a < dim; ++a) {
        CHECK(f[i * dim + a] == -k * disp[i * dim + a]);
        d2 += disp[i * dim + a] * disp[i * dim + a];
      }
      CHECK(u[i] == 0.5 * k * d2);
    }
  };
  auto drive = trap(*s, b, {{"k", k}, {"centre", c}, {"energy", true}});
  drive.step(*s, 0, 0.01);
  check_trap(*s, d);

  SECTION("the default centre is the box centre") {
    auto s2 = state(dim, p, L, x);
    auto centred = trap(*s2, b, {{"k", k}});
    centred.step(*s2, 0, 0.01);
    const auto g = values(*s2, "force");
    for (std::size_t i = 0; i < x.size(); ++i) CHECK(g[i] == -k * (x[i] - 4));
  }
  SECTION("axes: only the named axes are pulled") {
    auto s2 = state(dim, p, L, x);
    auto along_y = trap(*s2, b, {{"k", k}, {"centre", c}, {"axes", std::vector<std::string>{"y"}}, {"energy", true}});
    along_y.step(*s2, 0, 0.01);
    const auto g = values(*s2, "force"), u2 = values(*s2, "trap.energy");
    for (std::size_t i = 0; i < 3; ++i) {
      for (int a = 0; a < dim; ++a) CHECK(g[i * dim + a] == (a == 1 ? -k * d[i * dim + 1] : 0.0));
      CHECK(u2[i] == 0.5 * k * d[i * dim + 1] * d[i * dim + 1]);
    }
  }
  SECTION("velocity: the centre is c + v t at the step's start, wrapped into the box") {
    // Step 100 of Δt 0.25, t = 25: c(t) = (0.25 + 12.5, 4 − 6.25[, 4]) = (4.75, 5.75[, 4]) after the
    // wrap (both ways); d = (3, −1.25[, −1]), (−3.5, 0.5[, 0.125]), (3.5, −1.75[, 0]) (particle 2's x
    // across the boundary).
    std::vector<double> v{0.5, -0.25, 0}, dv;
    if (dim == 2) dv = {3, -1.25, -3.5, 0.5, 3.5, -1.75};
    else dv = {3, -1.25, -1, -3.5, 0.5, 0.125, 3.5, -1.75, 0};
    v.resize(dim);
    auto s2 = state(dim, p, L, x);
    auto moving = trap(*s2, b, {{"k", k}, {"centre", c}, {"velocity", v}, {"energy", true}});
    moving.step(*s2, 100, 0.25);
    check_trap(*s2, dv);
  }
  SECTION("types: only the particles of the named types feel the trap") {
    auto s2 = state(dim, p, L, x);
    s2->species = {"bath", "probe"};
    Field& t = s2->field(fields::type);
    t.acquire(Where::host, Mode::write);
    const std::int32_t types[3] = {1, 0, 1};
    std::copy(types, types + 3, t.host<std::int32_t>());
    auto probes = trap(*s2, b, {{"k", k}, {"centre", c}, {"types", std::vector<std::string>{"probe"}}, {"energy", true}});
    probes.step(*s2, 0, 0.01);
    std::vector<double> felt = d;  // the bath particle (1) feels nothing
    for (int a = 0; a < dim; ++a) felt[std::size_t(dim + a)] = 0;
    check_trap(*s2, felt);
    CHECK(std::signbit(values(*s2, "force")[dim]) == false);  // the bath's zero force is +0
    CHECK_THROWS_WITH(trap(*s2, b, {{"types", std::vector<std::string>{"probes"}}}),
                      Catch::Contains("`probes`, which is not one of system.types (bath, probe)"));
  }
  SECTION("add: true adds to the force a stage before wrote") {
    auto s2 = state(dim, p, L, x);
    fill(*s2, "force", dim, 0.75);
    auto adding = trap(*s2, b, {{"k", k}, {"centre", c}, {"add", true}});
    adding.step(*s2, 0, 0.01);
    const auto g = values(*s2, "force");
    for (std::size_t i = 0; i < x.size(); ++i) CHECK(g[i] == 0.75 - k * d[i]);
  }
}

TEST_CASE("trap.harmonic: input errors name what to change", "[trap]") {
  auto s = state(2, Precision::f64, 8, {1, 1});
  CHECK_THROWS_WITH(trap(*s, Backend::cpu, {{"centre", std::vector<double>{1, 2, 3}}}), Catch::Contains("one per dimension"));
  CHECK_THROWS_WITH(trap(*s, Backend::cpu, {{"axes", std::vector<std::string>{"z"}}}), Catch::Contains("2 dimensions"));
  CHECK_THROWS_WITH(trap(*s, Backend::cpu, {{"velocity", std::vector<double>{1}}}), Catch::Contains("velocity has 1 numbers; give one per dimension"));
  CHECK_THROWS_WITH(trap(*s, Backend::cpu, {{"add", true}}), Catch::Contains("no stage before it writes"));
  fill(*s, "force", 2, 0.0);
  CHECK_THROWS_WITH(trap(*s, Backend::cpu, {}), Catch::Contains("add: true"));
}

// With overdamped.integrate (D = 1, μ = 0.5: k_BT = D/μ = 2) and k = 4: relaxation rate μk = 2,
// ⟨d_a²⟩ = k_BT/k = 0.5. N = 4096 particles start at c + d0 (all the same), the trap's centre near
// a corner of a box of side 10, so the particles cross the periodic boundary all along; Δt = 0.0025
// (μkΔt = 0.005).
TEST_CASE("trap.harmonic: ⟨x − c⟩ decays as exp(−μkt) and ⟨(x − c)_a²⟩ = k_BT/k (equipartition)",
          "[trap][physics]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  INFO(to_string(b) << ", " << dim << "D, " << to_string(p));
  const std::size_t n = 4096;
  const double L = 10, k = 4, D = 1, mu = 0.5, kT = D / mu, rate = mu * k, dt = 0.0025;
  const double c[3] = {0.5, 9.75, 5}, d0[3] = {1.5, -1.0, 0.75};
  std::vector<double> x(n * dim);
  for (std::size_t i = 0; i < n; ++i)
    for (int a = 0; a < dim; ++a) x[i * dim + a] = std::fmod(c[a] + d0[a] + L, L);
  auto s = state(dim, p, L, x);
  auto force = trap(*s, b, {{"k", k}, {"centre", std::vector<double>(c, c + dim)}, {"energy", true}});
  ParamValues v = ParamValues::defaults(registry().get("overdamped.integrate").decl.params);
  v.set("D", std::vector<double>{D});
  v.set("mobility", std::vector<double>{mu});
  test::StageDriver integrate(registry(), "overdamped.integrate", b, p, dim, v, 11);
  integrate.stage->configure(*s);
  // d = minimum image of x − c, per particle and axis.
  auto displacements = [&] {
    auto y = values(*s, fields::position);
    for (std::size_t i = 0; i < y.size(); ++i) {
      const int a = int(i % dim);
      y[i] -= c[a];
      y[i] -= L * std::rint(y[i] / L);
    }
    return y;
  };
  std::uint64_t step = 0;
  auto advance_to = [&](double t) {
    for (; double(step) * dt < t - 1e-9; ++step) {
      force.step(*s, step, dt);
      integrate.step(*s, step, dt);
    }
  };
  // Relaxation: ⟨d_a(t)⟩ = d0_a exp(−μkt), sampled at μkt = 0.5, 1, 2; standard error from the
  // sample. Euler–Maruyama's mean is d0 (1 − μkΔt)^(t/Δt), 0.25 % below it at μkt = 1: about a
  // tenth of a standard error here.
  for (double t : {0.25, 0.5, 1.0}) {
    advance_to(t);
    const auto d = displacements();
    for (int a = 0; a < dim; ++a) {
      double m = 0, m2 = 0;
      for (std::size_t i = 0; i < n; ++i) {
        m += d[i * dim + a];
        m2 += d[i * dim + a] * d[i * dim + a];
      }
      m /= n;
      const double se = std::sqrt((m2 / n - m * m) / n), want = d0[a] * std::exp(-rate * t);
      const double measured_rate = -std::log(m / d0[a]) / t, rate_se = se / (std::fabs(m) * t);
      INFO("t = " << t << ", axis " << a << ": ⟨d⟩ = " << m << " ± " << se << ", d0 exp(−μkt) = " << want
                  << "; rate " << measured_rate << " ± " << rate_se << " (μk = " << rate << ")");
      CHECK(std::fabs(m - want) < 3 * se);
      CHECK(std::fabs(measured_rate - rate) < 3 * rate_se);
    }
  }
  // Equipartition: after 5 relaxation times (the offset left is d0 e^(−5) ≤ 0.01), frames two
  // relaxation times apart (the correlation of d² between them, e^(−4), is negligible):
  // ⟨d_a²⟩ per axis and frame; the standard error from the spread of d_a² over all samples.
  // Euler–Maruyama's stationary variance is k_BT/k / (1 − μkΔt/2), 0.25 % above: about a third
  // of a standard error here.
  double sum = 0, sum2 = 0, energy = 0;
  std::size_t samples = 0, frames = 0;
  for (double t = 2.5; t < 6.5; t += 1.0, ++frames) {
    advance_to(t);
    const auto d = displacements();
    for (double y : d) {
      sum += y * y;
      sum2 += y * y * y * y;
    }
    samples += d.size();
    force.step(*s, step, dt);  // U at these positions (the step's trap.energy is that of its start)
    for (double u : values(*s, "trap.energy")) energy += u;
  }
  const double m = sum / samples, se = std::sqrt((sum2 / samples - m * m) / samples);
  const double u = energy / (frames * n);
  INFO("⟨d_a²⟩ = " << m << " ± " << se << " (" << samples << " samples), k_BT/k = " << kT / k << "; ⟨U⟩ = " << u
                   << ", d k_BT/2 = " << 0.5 * dim * kT);
  CHECK(std::fabs(m - kT / k) < 3 * se);
  // U_i = k/2 Σ_a d_a² of the same samples (energy: true), in float to float's rounding.
  CHECK(u == Approx(0.5 * k * dim * m).epsilon(p == Precision::f64 ? 1e-12 : 1e-5));
}

// A trap moving at v (velocity) drags its particles: in the steady state they lag behind the
// centre by ⟨d⟩ = −v/(μk), the trap pulling each with k|⟨d⟩| = |v|/μ, Stokes' drag (exact in
// Euler–Maruyama too: d_{n+1} = (1 − μkΔt) d_n − vΔt + noise). D = 1, μ = 0.5, k = 4 (μk = 2), the
// 4096 particles start on the centre; v·t carries the centre across the periodic boundary.
TEST_CASE("trap.harmonic: a moving trap drags its particles behind it by v/(μk)", "[trap][physics]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int dim = GENERATE(2, 3);
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  INFO(to_string(b) << ", " << dim << "D, " << to_string(p));
  const std::size_t n = 4096;
  const double L = 10, k = 4, D = 1, mu = 0.5, dt = 0.0025;
  std::vector<double> c0{2, 7, 5}, v{1.5, -0.75, 0.5};
  c0.resize(dim);
  v.resize(dim);
  std::vector<double> x(n * dim);
  for (std::size_t i = 0; i < n; ++i)
    for (int a = 0; a < dim; ++a) x[i * dim + a] = c0[a];
  auto s = state(dim, p, L, x);
  auto force = trap(*s, b, {{"k", k}, {"centre", c0}, {"velocity", v}});
  ParamValues pv = ParamValues::defaults(registry().get("overdamped.integrate").decl.params);
  pv.set("D", std::vector<double>{D});
  pv.set("mobility", std::vector<double>{mu});
  test::StageDriver integrate(registry(), "overdamped.integrate", b, p, dim, pv, 17);
  integrate.stage->configure(*s);
  std::uint64_t step = 0;
  std::vector<double> sum(dim, 0.0), sum2(dim, 0.0);
  std::size_t samples = 0;
  // Frames from 7 relaxation times on (the start's offset left: e^(−7) of the lag), 2 apart.
  for (double t = 3.5; t < 7.6; t += 1.0) {
    for (; double(step) * dt < t - 1e-9; ++step) {
      force.step(*s, step, dt);
      integrate.step(*s, step, dt);
    }
    const auto y = values(*s, fields::position);
    for (std::size_t i = 0; i < n; ++i)
      for (int a = 0; a < dim; ++a) {
        double c = c0[a] + v[a] * (double(step) * dt);
        c -= L * std::floor(c / L);
        double d = y[i * dim + a] - c;
        d -= L * std::rint(d / L);
        sum[a] += d;
        sum2[a] += d * d;
      }
    samples += n;
  }
  for (int a = 0; a < dim; ++a) {
    const double m = sum[a] / samples, se = std::sqrt((sum2[a] / samples - m * m) / samples);
    const double want = -v[a] / (mu * k);
    INFO("axis " << a << ": ⟨d⟩ = " << m << " ± " << se << ", −v/(μk) = " << want);
    CHECK(std::fabs(m - want) < 3 * se);
  }
}

TEST_CASE("trap.harmonic: CPU and CUDA give the same bits", "[trap][cuda]") {
  if (!test::have_cuda("trap.harmonic CPU vs CUDA")) return;
  const int dim = GENERATE(2, 3);
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  const bool add = GENERATE(false, true);
  // moving: velocity (at step 37 of Δt 0.3: the centre wrapped around the box of 6) and a trap on
  // one of two types (random types, the same on both).
  const bool moving = GENERATE(false, true);
  INFO(dim << "D, " << to_string(p) << (add ? ", add" : "") << (moving ? ", moving, one type" : ""));
  auto cpu = scattered(dim, p), cuda = scattered(dim, p);
  std::vector<double> centre{0.3, 5.9, 2.2}, velocity{0.71, -1.3, 0.37};
  centre.resize(dim);
  velocity.resize(dim);
  test::ParamSettings set{{"k", 3.7}, {"centre", centre}, {"energy", true}, {"add", add}};
  if (moving) {
    set.push_back({"velocity", velocity});
    set.push_back({"types", std::vector<std::string>{"probe"}});
  }
  for (auto [s, b] : {std::pair{cpu.get(), Backend::cpu}, std::pair{cuda.get(), Backend::cuda}}) {
    if (add) fill(*s, "force", dim, 0.1);
    if (moving) {
      s->species = {"bath", "probe"};
      Field& t = s->field(fields::type);
      t.acquire(Where::host, Mode::write);
      std::mt19937_64 gen(5);
      for (std::size_t i = 0; i < s->n(); ++i) t.host<std::int32_t>()[i] = std::int32_t(gen() % 2);
    }
    auto drive = trap(*s, b, set);
    drive.step(*s, moving ? 37 : 0, moving ? 0.3 : 0.01);
  }
  for (const char* f : {"force", "trap.energy"}) {
    INFO(f);
    const auto a = test::bytes_of(*cpu, f), c = test::bytes_of(*cuda, f);
    REQUIRE(a.size() == c.size());
    CHECK(std::memcmp(a.data(), c.data(), a.size()) == 0);
  }
}

// Hard disks (σ = 1) in the trap, with the overlap correction on a Verlet list (the triangulation
// cannot span the empty box around the cloud: pipelines/trap-hard-disks.yaml). In local equilibrium
// the pressure balances the trap, dP/dr = −ρ k r, so over the plane ∫ P dA = k/2 ⟨Σ_i r_i²⟩, the
// trap's virial W (r_i the distance from c, k_BT = 1), while the local density gives
// ∫ P dA = ∫ ρ(r) Z(η(r)) dA with Liu's hard-disk Z (Mol. Phys. 2021; η = ρπ/4). An ideal gas has
// both equal to N; here W − N, the hard cores' part, is two thirds of W, and the two excesses
// agree within a few percent: measured +0.4 % (this run, seed 5, on the CPU), +1.8 % (seed 1), +1.3 %
// for 1024 disks at k = 0.02 (docs/model-notes.md#trap): the seeds' spread, the local-density
// approximation's error in a cloud ~25σ across and the reflections' Δt bias
// (tests/test_hard_disk_eos.cpp). The bound, 5 %, leaves the sample's spread (~1 %) and that bias
// room; a correction that left the disks' pressure out (Z = 1) is 100 % off.
TEST_CASE("trap.harmonic: hard disks in the trap balance it with the hard-disk equation of state",
          "[trap][physics]") {
  const Backend b = GENERATE(from_range(test::backends()));
  INFO(to_string(b));
  const Registry& r = registry();
  const double k = 0.08, L = 32, dt = 1e-3;
  const std::uint64_t equilibrate = 30000, steps = 130000, every = 250;
  auto s = test::spec(2, 256, 0, steps, dt,
                      {test::entry(r, "trap.harmonic", {{"k", k}}),
                       test::entry(r, "overdamped.integrate", {{"D", std::vector<double>{1.0}},
                                                               {"mobility", std::vector<double>{1.0}}}),
                       test::entry(r, "neighbors.verlet", {{"cutoff", 1.0}, {"skin", 0.3}}),
                       test::entry(r, "overlap_correct.verlet")},
                      5);
  s.system.box = {L, L};
  RunOptions o;
  o.dry_run = true;
  o.backend = b;
  Simulation sim(s, r, o);
  const double bin = 0.5;
  std::vector<double> counts(std::size_t(0.5 * L / bin) + 1, 0.0);
  double virial = 0, closest = HUGE_VAL;
  std::size_t frames = 0;
  for (std::uint64_t step = 0; step < steps; ++step) {
    sim.advance();
    if (step + 1 < equilibrate || (step + 1) % every) continue;
    const auto x = values(sim.state(), fields::position);
    const std::size_t n = x.size() / 2;
    for (std::size_t i = 0; i < n; ++i) {
      double d[2];
      for (int a = 0; a < 2; ++a) {
        d[a] = x[2 * i + a] - 0.5 * L;
        d[a] -= L * std::rint(d[a] / L);
      }
      const double r2 = d[0] * d[0] + d[1] * d[1];
      virial += 0.5 * k * r2;
      counts[std::min(counts.size() - 1, std::size_t(std::sqrt(r2) / bin))] += 1;
    }
    if (step + 1 == steps)
      for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = i + 1; j < n; ++j) {
          double r2 = 0;
          for (int a = 0; a < 2; ++a) {
            double dx = x[2 * j + a] - x[2 * i + a];
            dx -= L * std::rint(dx / L);
            r2 += dx * dx;
          }
          closest = std::min(closest, std::sqrt(r2));
        }
    ++frames;
  }
  const double n = 256, w = virial / double(frames);
  // The last bin holds the few disks beyond L/2 (in the box's corners, 0.4 a frame): an ideal gas there.
  double local = counts.back() / double(frames), eta_centre = 0;
  for (std::size_t j = 0; j + 1 < counts.size(); ++j) {
    const double area = M_PI * bin * bin * (double(j + 1) * double(j + 1) - double(j) * double(j));
    const double rho = counts[j] / double(frames) / area, eta = rho * M_PI / 4;
    const double z = (1 + eta * eta / 8 + std::pow(eta, 4) / 18 - 4 * std::pow(eta, 6) / 21) / ((1 - eta) * (1 - eta));
    local += rho * z * area;
    if (j < 4) eta_centre += eta / 4;
  }
  INFO(frames << " frames: trap virial k/2⟨Σr²⟩ = " << w << ", ∫ρZ(η)dA = " << local << ", N = " << n
              << "; excess ratio " << (local - n) / (w - n) << ", η within 2σ of the centre " << eta_centre
              << ", closest pair " << closest << " (beyond L/2: " << counts.back() << ")");
  CHECK(eta_centre > 0.45);                      // the hard cores matter: a dense centre
  CHECK((w - n) / w > 0.5);                      // the hard cores hold up most of the trap's pressure
  CHECK(std::fabs((local - n) / (w - n) - 1) < 0.05);
  CHECK(closest >= 1 - 1e-6);                    // and no overlap is left
}
