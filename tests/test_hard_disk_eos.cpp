// Hard-disk equation of state (physics, ~1 minute): Brownian disks with the maintained Delaunay
// triangulation and overlap correction (Carter et al. 2017's pipeline) sample the hard-disk
// fluid; the contact value of g(r) gives the pressure Z = βP/ρ = 1 + 2η g(σ⁺), compared with
// Henderson's Z = (1 + η²/8)/(1 − η)² (2.064 at η = 0.3, 4.125 at η = 0.5).
//
// The correction's reflections make g(σ⁺) slightly too large at finite Δt, by an amount ∝ Δt
// (D = σ = 1, N = 2000, t = 6): Δt = 1e-3: +2.6 % (η = 0.3), +2.7 % (η = 0.5);
// Δt = 3e-4: +0.4…1.2 % over three seeds at both; Δt = 1e-4: +0.2 % at η = 0.5.
// This test runs Δt = 3e-4: 1 time unit from the RSA start to equilibrate, 4 to average.
// It discriminates: mode: contact (pairs left at contact instead of reflected) piles pairs up at
// σ and gives Z = 5.28 at η = 0.5 (+28 %), as Carter et al. warn.
#include <catch2/catch.hpp>
#include <cmath>

#include "core/run/simulation.h"
#include "support/backends.h"
#include "support/spec.h"
#include "support/test_plugins.h"

using namespace ff;
using ff::test::entry;

namespace {

double henderson(double eta) { return (1 + eta * eta / 8) / ((1 - eta) * (1 - eta)); }

double min_gap(State& s) {
  Field& f = s.field(fields::position);
  f.acquire(Where::host, Mode::read);
  const double* x = f.host<double>();
  const double L0 = s.box.L[0], L1 = s.box.L[1];
  double worst = HUGE_VAL;
  for (std::size_t i = 0; i < s.n(); ++i)
    for (std::size_t j = i + 1; j < s.n(); ++j) {
      double dx = x[2 * j] - x[2 * i], dy = x[2 * j + 1] - x[2 * i + 1];
      dx -= L0 * std::rint(dx / L0);
      dy -= L1 * std::rint(dy / L1);
      worst = std::min(worst, dx * dx + dy * dy);
    }
  return std::sqrt(worst);
}

}  // namespace

namespace {

// The runs of both tests: 2000 hard disks at packing fraction eta from `init` (brownian D = 1,
// Δt = 3e-4 as in hard-disks.yaml, the Delaunay stages, overlap_correct), g(r) sampled from t = 1
// to t = 5 (seed 42).
constexpr double kDt = 3e-4;
struct EosRun {
  double z, g_contact, min_gap;
  std::uint64_t rollbacks;
};
template <class Reg>
EosRun run_hard_disks(const Reg& r, Backend backend, double eta, const std::string& init) {
  const std::uint64_t equilibrate = 3334, steps = 16667;
  auto s = test::spec(2, 2000, eta, steps, kDt,
                      {entry(r, "brownian.integrate", {{"D", 1.0}}), entry(r, "delaunay.detect_inversion"),
                       entry(r, "delaunay.flip"), entry(r, "delaunay.lawson"), entry(r, "overlap_correct"),
                       entry(r, "observe.gr", {{"from_step", std::int64_t(equilibrate)}}, {"", {}, false, 10})},
                      42);
  s.system.init = init;
  RunOptions o;
  o.dry_run = true;
  o.backend = backend;
  Simulation sim(s, r, o);
  sim.run();
  return {sim.stats().metrics.at("observe.gr/Z"), sim.stats().metrics.at("observe.gr/g_contact"),
          min_gap(sim.state()), std::uint64_t(sim.stats().rollbacks)};
}

}  // namespace

TEST_CASE("hard-disk equation of state: Z = 1 + 2η g(σ⁺) within 3 % of Henderson at η = 0.3 and 0.5",
          "[physics][eos][long]") {
  const Backend backend = GENERATE(from_range(test::backends()));
  auto r = test::registry_with({"brownian"});
  for (double eta : {0.3, 0.5}) {
    const EosRun run = run_hard_disks(*r, backend, eta, "random");
    const double ref = henderson(eta);
    WARN(to_string(backend) << ": η = " << eta << ", Δt = " << kDt << ": g(σ⁺) = " << run.g_contact << ", Z = "
                            << run.z << ", Henderson " << ref << " (" << 100 * (run.z / ref - 1) << " %), rollbacks "
                            << run.rollbacks);
    CHECK(std::fabs(run.z / ref - 1) < 0.03);
    CHECK(run.min_gap >= 1 - 1e-6);  // and no overlap is left
  }
}

// Issue 20, item 3: a correction scheme becomes overlap_correct's default only if, at the Δt the
// pipelines use (hard-disks.yaml: 3e-4), it leaves no overlap and gives the hard-disk pressure
// within 1 % of Liu's equation of state (Mol. Phys. 2021, stable fluid:
// Z = (1 + η²/8 + η⁴/18 − 4η⁶/21)/(1 − η)², within 0.2 % of Henderson's up to η = 0.6). This is
// that check at η = 0.6 for the default, the same 2000 disks, seed and times as the test above,
// from a lattice sample (random placement jams before 0.6). Measured: Z = 6.502 against Liu's
// 6.521 (−0.28 %; +0.06 % before session 29's pair math, whose other rounding gives another
// trajectory: the run-to-run spread of this single run is a few tenths of a percent). (At η = 0.3
// and 0.5 the default is +1.09 % and +0.62 % from Liu in this run, +1.11 % and +1.00 % before, the
// Δt bias described above; the test above bounds those against Henderson.)
TEST_CASE("hard-disk equation of state at η = 0.6 within 1 % of Liu", "[physics][eos][long]") {
  const Backend backend = GENERATE(from_range(test::backends()));
  auto r = test::registry_with({"brownian"});
  const double eta = 0.6;
  const double liu = (1 + eta * eta / 8 + std::pow(eta, 4) / 18 - 4 * std::pow(eta, 6) / 21) / ((1 - eta) * (1 - eta));
  const EosRun run = run_hard_disks(*r, backend, eta, "triangular_lattice_sample");
  WARN(to_string(backend) << ": η = " << eta << ", Δt = " << kDt << ": Z = " << run.z << ", Liu " << liu << " ("
                          << 100 * (run.z / liu - 1) << " %), rollbacks " << run.rollbacks);
  CHECK(std::fabs(run.z / liu - 1) < 0.01);
  CHECK(run.min_gap >= 1 - 1e-6);
}

// A binary hard-disk mixture (50 % σ = 1, 50 % σ = 1.4, η = 0.3), the case of the audit that found
// observe.gr's Z of the mean diameter wrong for mixtures (1.75). The contact theorem over the
// species pairs is compared with the Santos–Yuste–López de Haro mapping of the one-component Z_s
// onto additive disk mixtures (Mol. Phys. 96, 1 (1999)):
//   Z_mix = 1/(1 − η) + (⟨σ⟩²/⟨σ²⟩)·[Z_s(η) − 1/(1 − η)],
// with Henderson's Z_s: 2.0466 here. It reduces to Z_s for one diameter, to the mixture SPT for
// Z_s = 1/(1 − η)², and its second virial coefficient is the exact (πρ/2) Σ x_i x_j σ_ij². (The
// rule 1 + (⟨σ⟩²/⟨σ²⟩)(Z_s − 1) gives 2.0350, but not the exact second virial coefficient.)
// The runs of the tests above (2000 disks, Δt = 3e-4, t = 1 + 4; ~2 s on 2 cores), CPU only.
// Measured: +0.84 % (seed 42), +0.38 % (7), +0.48 % (3); Δt = 1e-4: +0.44 %, +0.38 % (seeds
// 42, 7): the Δt bias of the pure fluid plus at most a few tenths of a percent, against
// +0.95…1.4 % from the other rule.
TEST_CASE("hard-disk mixture equation of state: the contact theorem over species pairs within 2 % of SYH, η = 0.3",
          "[physics][eos][mixture]") {
  auto r = test::registry_with({"brownian"});
  const double eta = 0.3;
  const std::uint64_t equilibrate = 3334, steps = 16667;
  auto s = test::spec(2, 2000, eta, steps, kDt,
                      {entry(*r, "brownian.integrate", {{"D", 1.0}}), entry(*r, "delaunay.detect_inversion"),
                       entry(*r, "delaunay.flip"), entry(*r, "delaunay.lawson"), entry(*r, "overlap_correct"),
                       entry(*r, "observe.gr", {{"from_step", std::int64_t(equilibrate)}}, {"", {}, false, 10})},
                      42);
  s.system.types = {SpeciesSpec{"A", 0.5, 1.0}, SpeciesSpec{"B", 0.5, 1.4}};
  Simulation sim(s, *r, test::dry(Backend::cpu));
  sim.run();
  const double z = sim.stats().metrics.at("observe.gr/Z");
  const double mean = 0.5 * (1.0 + 1.4), mean2 = 0.5 * (1.0 + 1.4 * 1.4);
  const double syh = 1 / (1 - eta) + mean * mean / mean2 * (henderson(eta) - 1 / (1 - eta));
  WARN("binary disks 1 : 1.4, η = " << eta << ": Z = " << z << " (g_contact = "
                                    << sim.stats().metrics.at("observe.gr/g_contact") << "), SYH " << syh << " ("
                                    << 100 * (z / syh - 1) << " %)");
  CHECK(std::fabs(z / syh - 1) < 0.02);
  CHECK(std::fabs(z - 1.75) > 0.2);
  // No overlap is left: r ≥ σ_ij for every pair.
  State& st = sim.state();
  for (const char* f : {fields::position, fields::diameter}) st.field(f).acquire(Where::host, Mode::read);
  const double* x = st.field(fields::position).host<double>();
  const double* d = st.field(fields::diameter).host<double>();
  double worst = HUGE_VAL;
  for (std::size_t i = 0; i < st.n(); ++i)
    for (std::size_t j = i + 1; j < st.n(); ++j) {
      double dx = x[2 * j] - x[2 * i], dy = x[2 * j + 1] - x[2 * i + 1];
      dx -= st.box.L[0] * std::rint(dx / st.box.L[0]);
      dy -= st.box.L[1] * std::rint(dy / st.box.L[1]);
      worst = std::min(worst, std::sqrt(dx * dx + dy * dy) / (0.5 * (d[i] + d[j])));
    }
  CHECK(worst >= 1 - 1e-6);  // not the mean-σ value of before
}
