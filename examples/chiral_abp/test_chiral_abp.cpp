// The test of chiral_abp.integrate (Catch2; flipflow_add_plugin builds it as the CTest test
// test_chiral_abp): the stage from the built plugin, driven alone on free particles by flipflow's
// stage driver (support/stage_driver.h, installed with flipflow), on every available backend (CPU;
// CUDA when there is a GPU); ω = 0 (plain ABP) and ω = 2 in double, ω = 2 in float.
//
// 1. Statistics of N = 20000 particles against the closed forms, within 4 standard errors of the
//    sample, at t = 0.5, 1, 2, 4. Write e(θ) as the complex number e^{iθ} and let X = Δr·e(θ0),
//    Y = Δr·e⊥(θ0), e⊥ = (-sin θ0, cos θ0), so X + iY = e^{-iθ0} (Δx + iΔy).
//    (a) Mean displacement. θ(s) = θ0 + ωs + sqrt(2D_r) W(s), and for a Gaussian G,
//        <e^{iG}> = e^{i<G>} e^{-Var G/2}, so <e^{iθ(s)}> = e^{iθ0} e^{(iω - D_r)s}. The noise in x
//        averages out, hence
//          <X + iY> = v0 ∫0^t e^{(iω - D_r)s} ds = v0 (1 - e^{-(D_r - iω)t}) / (D_r - iω)
//                   = v0 (1 - e^{-D_r t}(cos ωt + i sin ωt)) (D_r + iω) / (D_r² + ω²),
//        whose real and imaginary parts are
//          <X> = v0 [D_r (1 - e^{-D_r t} cos ωt) + ω e^{-D_r t} sin ωt] / (D_r² + ω²)
//          <Y> = v0 [ω (1 - e^{-D_r t} cos ωt) - D_r e^{-D_r t} sin ωt] / (D_r² + ω²)
//        (for small t: <X> ≈ v0 t, <Y> ≈ v0 ω t²/2, the particle turning left for ω > 0).
//    (b) Mean-square displacement. <e(θ(s))·e(θ(s'))> = Re <e^{i(θ(s) - θ(s'))}>
//        = e^{-D_r|s - s'|} cos ω(s - s'), so with a = D_r - iω
//          <Δr²> = 4Dt + v0² ∫0^t∫0^t e^{-D_r|s-s'|} cos ω(s-s') ds ds'
//                = 4Dt + 2 v0² Re ∫0^t (t - u) e^{-a u} du = 4Dt + 2 v0² Re [t/a - (1 - e^{-at})/a²]
//                = 4Dt + 2 v0² [D_r t/(D_r² + ω²)
//                    + ((ω² - D_r²)(1 - e^{-D_r t} cos ωt) - 2ωD_r e^{-D_r t} sin ωt)/(D_r² + ω²)²],
//        the chiral ABP result (e.g. van Teeffelen & Löwen 2008; Kurzthaler & Franosch 2017). At
//        ω = 0 it is ABP's 4Dt + (2v0²/D_r²)(D_r t + e^{-D_r t} - 1), which the test also
//        checks numerically.
//    The Euler–Maruyama step (propulsion along the orientation at the start of each step) gives
//    exactly the left Riemann sums of these integrals: <X + iY> = v0 Δt Σ_{k<n} ρ^k e^{iωkΔt},
//    <Δr²> = 4Dt + v0²Δt² [n + 2 Σ_{0<m<n} (n - m) ρ^m cos ωmΔt], ρ = e^{-D_r Δt}. The test
//    requires them to lie within 0.3 standard errors of the closed forms, so that comparing the
//    sample with the closed forms tests the model, not the step size.
// 2. Circle swimmers: with D = D_r = 0 each particle runs a polygon of step v0Δt turning by ωΔt,
//    closing after one period 2π/ω (checked to 1e-9 in double against that sum).
// 3. The orientation field is added with angles in [-π, π) and a uniform mean e(θ).
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/stage/params.h"
#include "support/backends.h"
#include "support/fields.h"
#include "support/stage_driver.h"
#include "support/test_plugins.h"

using namespace ff;

namespace {

struct Model {
  double v0, omega, Dr, D;
};

// The closed forms of the header; [0]: <X>, [1]: <Y>, [2]: <Δr²>.
std::vector<double> closed_form(const Model& m, double t) {
  const double E = std::exp(-m.Dr * t), c = std::cos(m.omega * t), s = std::sin(m.omega * t);
  const double g = m.Dr * m.Dr + m.omega * m.omega;
  const double par = m.v0 * (m.Dr * (1 - E * c) + m.omega * E * s) / g;
  const double perp = m.v0 * (m.omega * (1 - E * c) - m.Dr * E * s) / g;
  const double msd = 4 * m.D * t +
                     2 * m.v0 * m.v0 *
                         (m.Dr * t / g + ((m.omega * m.omega - m.Dr * m.Dr) * (1 - E * c) - 2 * m.omega * m.Dr * E * s) / (g * g));
  return {par, perp, msd};
}

// What the Euler–Maruyama scheme gives exactly after n steps of dt (header).
std::vector<double> scheme(const Model& m, double dt, std::uint64_t n) {
  const double rho = std::exp(-m.Dr * dt);
  double par = 0, perp = 0, pairs = double(n);
  for (std::uint64_t k = 0; k < n; ++k) {
    par += std::pow(rho, double(k)) * std::cos(m.omega * k * dt);
    perp += std::pow(rho, double(k)) * std::sin(m.omega * k * dt);
    if (k > 0) pairs += 2 * double(n - k) * std::pow(rho, double(k)) * std::cos(m.omega * k * dt);
  }
  return {m.v0 * dt * par, m.v0 * dt * perp, 4 * m.D * n * dt + m.v0 * m.v0 * dt * dt * pairs};
}

// The model plugin alone (no standard stage: the stage needs none); test_plugin_path() finds the
// plugin this build made.
const Registry& registry() {
  static const auto r = test::registry_of({}, {"chiral_abp"});
  return *r;
}

// chiral_abp.integrate on n particles spread over a box of edge L, configured (which adds the
// orientations); step it with driver.step(*state, k, dt).
struct Run {
  test::StageDriver driver;
  std::unique_ptr<State> state;

  Run(Backend b, Precision p, const Model& m, std::size_t n, double L, std::uint64_t seed)
      : driver(registry(), "chiral_abp.integrate", b, p, 2,
               param_values({{"v0", m.v0}, {"omega", m.omega}, {"Dr", m.Dr}, {"D", m.D}}), seed),
        state(std::make_unique<State>(2, p, n)) {
    state->box.L[0] = state->box.L[1] = L;
    Field& x = state->field(fields::position);
    x.acquire(Where::host, Mode::write);
    for (std::size_t i = 0; i < n; ++i)
      for (int k = 0; k < 2; ++k) {
        const double c = std::fmod(0.37 * double(i) * (k + 1) + 0.5 * k, L);
        if (p == Precision::f64) x.host<double>()[2 * i + k] = c;
        else x.host<float>()[2 * i + k] = float(c);
      }
    driver.stage->configure(*state);
  }
  void steps(std::uint64_t from, std::uint64_t to, double dt) {
    for (std::uint64_t k = from; k < to; ++k) driver.step(*state, k, dt);
  }
  std::vector<double> unwrapped() {
    return state->precision() == Precision::f64 ? test::unwrapped<double>(*state) : test::unwrapped<float>(*state);
  }
  std::vector<double> orientation() { return test::values(*state, "orientation"); }
};

struct MeanSe {
  double mean, se;
};
MeanSe mean_se(const std::vector<double>& v) {
  double m = 0, m2 = 0;
  for (double x : v) m += x;
  m /= double(v.size());
  for (double x : v) m2 += (x - m) * (x - m);
  return {m, std::sqrt(m2 / double(v.size() - 1) / double(v.size()))};
}

}  // namespace

TEST_CASE("closed forms: at ω = 0 the MSD is ABP's 4Dt + (2v0²/D_r²)(D_r t + e^{-D_r t} - 1)", "[chiral_abp]") {
  const Model abp{1.0, 0.0, 0.5, 0.05};
  for (double t : {0.1, 1.0, 10.0}) {
    const double g = abp.Dr;
    const double want = 4 * abp.D * t + 2 * abp.v0 * abp.v0 / (g * g) * (g * t + std::exp(-g * t) - 1);
    INFO("t = " << t);
    CHECK(closed_form(abp, t)[2] == Approx(want).epsilon(1e-12));
  }
}

TEST_CASE("chiral_abp.integrate: the orientations it adds lie in [-π, π) with a uniform mean e(θ)", "[chiral_abp]") {
  Run run(Backend::cpu, Precision::f64, Model{1, 1, 1, 0}, 20000, 50, 5);
  const auto th = run.orientation();
  std::vector<double> c(th.size()), s(th.size());
  std::size_t outside = 0;
  for (std::size_t i = 0; i < th.size(); ++i) {
    outside += !(th[i] >= -M_PI && th[i] < M_PI);
    c[i] = std::cos(th[i]);
    s[i] = std::sin(th[i]);
  }
  CHECK(outside == 0);
  const auto mc = mean_se(c), ms = mean_se(s);
  INFO("<cos θ0> = " << mc.mean << " ± " << mc.se << ", <sin θ0> = " << ms.mean << " ± " << ms.se);
  CHECK(std::fabs(mc.mean) < 4 * mc.se);
  CHECK(std::fabs(ms.mean) < 4 * ms.se);
}

TEST_CASE("chiral_abp.integrate: circle swimmers (D = D_r = 0) run their polygon and close it after one turn",
          "[chiral_abp]") {
  const Backend b = GENERATE(from_range(test::backends()));
  INFO(to_string(b));
  const Model m{1.0, 2.0, 0.0, 0.0};
  const double dt = 0.01;
  const std::uint64_t steps = 314;  // ωt = 6.28: one turn
  Run run(b, Precision::f64, m, 100, 20, 7);
  const auto r0 = run.unwrapped();
  const auto th0 = run.orientation();
  run.steps(0, steps, dt);
  const auto r = run.unwrapped();
  double worst = 0, furthest = 0;
  for (std::size_t i = 0; i < 100; ++i) {
    double sx = 0, sy = 0;  // v0 Δt Σ e(θ0 + ωkΔt)
    for (std::uint64_t k = 0; k < steps; ++k) {
      sx += m.v0 * dt * std::cos(th0[i] + m.omega * dt * double(k));
      sy += m.v0 * dt * std::sin(th0[i] + m.omega * dt * double(k));
    }
    worst = std::fmax(worst, std::hypot(r[2 * i] - r0[2 * i] - sx, r[2 * i + 1] - r0[2 * i + 1] - sy));
    furthest = std::fmax(furthest, std::hypot(r[2 * i] - r0[2 * i], r[2 * i + 1] - r0[2 * i + 1]));
  }
  INFO("largest deviation from the polygon " << worst << ", farthest from the start after one turn " << furthest);
  CHECK(worst < 1e-9);
  CHECK(furthest < m.v0 * dt);
}

TEST_CASE("chiral_abp.integrate: mean displacement and MSD of 20000 particles match the closed forms",
          "[chiral_abp]") {
  const Backend b = GENERATE(from_range(test::backends()));
  // ω = 0 (ABP) and ω = 2 in double, ω = 2 in float.
  const auto [p, m] = GENERATE(std::pair{Precision::f64, Model{1.0, 0.0, 0.5, 0.05}},
                               std::pair{Precision::f64, Model{1.0, 2.0, 0.5, 0.05}},
                               std::pair{Precision::f32, Model{1.0, 2.0, 0.5, 0.05}});
  INFO(to_string(b) << " " << to_string(p) << ", v0 = " << m.v0 << ", omega = " << m.omega << ", Dr = " << m.Dr
                    << ", D = " << m.D << ", N = 20000, dt = 0.001");
  const std::size_t n = 20000;
  const double dt = 0.001;
  // Any seed: over seeds 1-6 the deviations below looked like unit normals (largest 2.6 SE).
  Run run(b, p, m, n, 50, 1);
  const auto r0 = run.unwrapped();
  const auto th0 = run.orientation();
  std::uint64_t k = 0;
  for (std::uint64_t checkpoint : {500, 1000, 2000, 4000}) {
    run.steps(k, checkpoint, dt);
    k = checkpoint;
    const double t = double(checkpoint) * dt;
    const auto r = run.unwrapped();
    std::vector<double> X(n), Y(n), R2(n);
    for (std::size_t i = 0; i < n; ++i) {
      const double dx = r[2 * i] - r0[2 * i], dy = r[2 * i + 1] - r0[2 * i + 1];
      const double c = std::cos(th0[i]), s = std::sin(th0[i]);
      X[i] = dx * c + dy * s;
      Y[i] = -dx * s + dy * c;
      R2[i] = dx * dx + dy * dy;
    }
    const MeanSe got[3] = {mean_se(X), mean_se(Y), mean_se(R2)};
    const auto want = closed_form(m, t);
    const auto euler = scheme(m, dt, checkpoint);
    const char* names[3] = {"<dr.e(th0)>", "<dr.e_perp>", "<dr^2>"};
    for (int q = 0; q < 3; ++q) {
      INFO("t = " << t << ": " << names[q] << " = " << got[q].mean << " ± " << got[q].se << ", closed form "
                  << want[q] << " (" << (got[q].mean - want[q]) / got[q].se << " SE), Euler sum " << euler[q]);
      CHECK(std::fabs(got[q].mean - want[q]) < 4 * got[q].se);
      // The scheme's own sums lie close to the closed forms (else reduce dt): the check above
      // then tests the model, not the step size.
      CHECK(std::fabs(euler[q] - want[q]) < 0.3 * got[q].se);
    }
  }
}
