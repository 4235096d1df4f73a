// overlap_correct: exact two-particle moves (reflect, contact, cap; oblique, unequal diameters,
// coincident centres), no overlaps left after correcting random overlaps up to packing fraction
// 0.8 in a bounded number of iterations, an ideal gas pushed apart, float runs, and mark: true.
// The bits against the naive definition and across threads: test_determinism.cpp; errors:
// test_errors.cpp; CPU vs CUDA: test_cpu_cuda.cpp; walls: test_walls.cpp (helpers: test_support.h).
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "stages/overlap_correct/kernel.h"
#include "stages/overlap_correct/params.h"
#include "stages/overlap_correct/test_support.h"
#include "support/backends.h"

using namespace ff;
using namespace ff::overlap_test;

TEST_CASE("overlap_correct: exact moves of an isolated overlapping pair", "[overlap]") {
  // 64 particles on a lattice at η = 0.05 (spacing ≈ 4.3σ); particle b is put next to particle
  // a along x, both on a grid of 1/64, so every number below is exact in double.
  struct Case {
    const char* mode;
    double cap, r;   // parameters; initial separation (σ = 1)
    double r_after;  // expected separation
    double iterations, pairs, correction;
  };
  const Case cases[] = {
      {"reflect", 0.25, 0.75, 1.25, 1, 1, 0.5},    // δ = σ − r = 0.25 each: r' = 2σ − r
      {"contact", 0.25, 0.75, 1.0, 1, 1, 0.25},    // δ/2 = 0.125 each: r' = σ
      {"reflect", 0.25, 0.25, 1.25, 2, 2, 1.0},    // 0.75 capped to 0.25: r = 0.75; then 0.25: 1.25
      {"contact", 0.25, 0.25, 1.0, 2, 2, 0.75},    // 0.375 capped to 0.25: r = 0.75; then 0.125: 1.0
      {"reflect", 1.0, 0.25, 1.75, 1, 1, 1.5},     // cap out of the way: r' = 2σ − r
      {"reflect", 0.125, 0.75, 1.0, 1, 1, 0.25},   // 0.25 capped to 0.125: r = 1.0, contact, done
      {"reflect", 0.125, 0.5, 1.0, 2, 2, 0.5},     // 0.5 -> 0.125: r = 0.75; 0.25 -> 0.125: r = 1.0
      {"contact", 0.25, 0.984375, 1.0, 1, 1, 0.015625},  // shallow overlap (1/64): one iteration
  };
  for (const Case& c : cases) {
    INFO("mode " << c.mode << ", cap " << c.cap << ", r " << c.r);
    const auto spec = correct_spec(64, 0.05, {{"mode", std::string(c.mode)}, {"cap", c.cap}});
    auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
    auto xy = positions(*state);
    const double L = state->box.L[0];
    std::size_t a = 0;
    while (!(xy[2 * a] > 2 && xy[2 * a] < L - 3 && xy[2 * a + 1] > 2 && xy[2 * a + 1] < L - 3)) ++a;
    const std::size_t b = a == 0 ? 1 : 0;
    const double x0 = std::round(xy[2 * a] * 64) / 64, y0 = std::round(xy[2 * a + 1] * 64) / 64;
    xy[2 * a] = x0;
    xy[2 * a + 1] = y0;
    xy[2 * b] = x0 + c.r;
    xy[2 * b + 1] = y0;
    set_positions(*state, xy);
    REQUIRE(min_gap(*state) == c.r);
    Simulation sim(spec, registry(), dry(), std::move(state));
    sim.advance();
    const auto after = positions(sim.state());
    CHECK(after[2 * b] - after[2 * a] == c.r_after);
    CHECK(after[2 * a] + after[2 * b] == 2 * x0 + c.r);  // symmetric moves
    CHECK(after[2 * a + 1] == y0);
    CHECK(after[2 * b + 1] == y0);
    CHECK(metric(sim, "iterations") == c.iterations);
    CHECK(metric(sim, "pairs") == c.pairs);
    CHECK(metric(sim, "correction") == Approx(c.correction).epsilon(1e-9));
    std::size_t moved = 0;
    for (std::size_t i = 0; i < after.size() / 2; ++i)
      if (i != a && i != b && (after[2 * i] != xy[2 * i] || after[2 * i + 1] != xy[2 * i + 1])) ++moved;
    CHECK(moved == 0);
  }
}

TEST_CASE("overlap_correct: oblique pair, unequal diameters, and coincident centres", "[overlap]") {
  SECTION("along (3, 4)/5 with σ_a = 1, σ_b = 2: σ_ab = 1.5, reflect gives r' = 2σ_ab − r") {
    const auto spec = correct_spec(64, 0.02, {{"cap", 1.0}});
    auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
    auto xy = positions(*state);
    const double L = state->box.L[0];
    std::size_t a = 0;
    while (!(xy[2 * a] > 3 && xy[2 * a] < L - 4 && xy[2 * a + 1] > 3 && xy[2 * a + 1] < L - 4)) ++a;
    const std::size_t b = a == 0 ? 1 : 0;
    xy[2 * b] = xy[2 * a] + 0.6;  // r = 1.0 along (0.6, 0.8)
    xy[2 * b + 1] = xy[2 * a + 1] + 0.8;
    set_positions(*state, xy);
    Field& d = state->field(fields::diameter);
    d.host<double>()[b] = 2.0;
    Simulation sim(spec, registry(), dry(), std::move(state));
    sim.advance();
    const auto after = positions(sim.state());
    const double dx = after[2 * b] - after[2 * a], dy = after[2 * b + 1] - after[2 * a + 1];
    CHECK(std::hypot(dx, dy) == Approx(2.0).epsilon(1e-14));  // 2·1.5 − 1.0
    CHECK(dx / dy == Approx(0.75).epsilon(1e-14));            // still along (3, 4)
    // Each moved by δ = 0.5 (cap = 1·σ_a is not reached).
    CHECK(std::hypot(after[2 * a] - xy[2 * a], after[2 * a + 1] - xy[2 * a + 1]) == Approx(0.5).epsilon(1e-13));
  }
  SECTION("coincident centres separate along x, the lower index towards −x") {
    double dxa = 0, dya = 0, dxb = 0, dyb = 0;
    CHECK(overlap::pair_push(0.0, 0.0, 1.0, 1.0, 1.0, 1e-3, 3, 7, dxa, dya) == overlap::kBeyond);
    CHECK(overlap::pair_push(-0.0, 0.0, 1.0, 1.0, 1.0, 1e-3, 7, 3, dxb, dyb) == overlap::kBeyond);
    CHECK(dxa == -1.0);
    CHECK(dxb == 1.0);
    CHECK(dya == 0.0);
    CHECK(dyb == 0.0);
    double dx = 0, dy = 0;
    CHECK(overlap::pair_push(1.0, 0.0, 1.0, 1.0, 1.0, 1e-3, 3, 7, dx, dy) == overlap::kApart);  // contact
    CHECK(dx == 0.0);
  }
  SECTION("a pair's depth σ − r against tol·σ: within the tolerance, beyond it, apart") {
    // σ = (1 + 3)/2 = 2, tol = 1e-3: beyond when σ − r > 2e-3.
    const double tol = 1e-3;
    double dx = 0, dy = 0;
    CHECK(overlap::pair_push(0.0, 1.999, 1.0, 3.0, 1.0, tol, 3, 7, dx, dy) == overlap::kWithin);
    CHECK(overlap::pair_push(0.0, -1.997, 1.0, 3.0, 1.0, tol, 3, 7, dx, dy) == overlap::kBeyond);
    CHECK(overlap::pair_push(2.0, 0.0, 1.0, 3.0, 1.0, tol, 3, 7, dx, dy) == overlap::kApart);
    CHECK(overlap::pair_push(1.2, 1.6, 1.0, 3.0, 1.0, tol, 3, 7, dx, dy) == overlap::kApart);  // r = 2
    // Reflect moves v by δ = σ − r away from u along the line of centres: −0.001 from u above,
    // +0.003 from u below.
    CHECK(dx == 0.0);
    CHECK(dy == Approx(-0.001 + 0.003).margin(1e-15));
    // At contact up to rounding: r² < σ² in double, yet sqrt(r²) rounds to σ (a pair found by a
    // search over random directions; it is common). A zero push, and not a pair the counters count.
    const double sigma = 0.584827051590213, rx = 0.5796375852253713, ry = 0.07773641402715939;
    REQUIRE(rx * rx + ry * ry < sigma * sigma);
    REQUIRE(std::sqrt(rx * rx + ry * ry) == sigma);
    double cx = 0.25, cy = -0.5;
    const overlap::PairOverlap at = overlap::pair_push(rx, ry, sigma, sigma, 1.0, tol, 3, 7, cx, cy);
    CHECK(at == overlap::kAtContact);
    CHECK_FALSE(overlap::counted(at));
    CHECK(cx == 0.25);
    CHECK(cy == -0.5);
  }
}

TEST_CASE("overlap_correct: random overlaps up to η = 0.8 are removed in a bounded number of iterations",
          "[overlap][physics]") {
  // A lattice sample (no overlaps) jiggled by a Gaussian of `amplitude`·σ per component: the
  // overlaps one large time step makes. Iteration bounds are ~2.5x what this seed needs.
  struct Case {
    double eta, amplitude;
    const char* mode;
    double max_iterations;
  };
  const Case cases[] = {{0.3, 0.3, "reflect", 5},   {0.5, 0.15, "reflect", 8},  {0.7, 0.05, "reflect", 5},
                        {0.7, 0.1, "reflect", 10},  {0.8, 0.05, "reflect", 12}, {0.8, 0.1, "reflect", 18},
                        {0.3, 0.3, "contact", 40},  {0.7, 0.1, "contact", 50},  {0.8, 0.1, "contact", 200}};
  for (const Case& c : cases) {
    const auto spec = correct_spec(2000, c.eta, {{"mode", std::string(c.mode)}});
    auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
    jiggle(*state, c.amplitude, 11);
    const double before = min_gap(*state);
    Simulation sim(spec, registry(), dry(), std::move(state));
    sim.advance();
    const double after = min_gap(sim.state());
    INFO("η " << c.eta << " jiggle " << c.amplitude << " " << c.mode << ": min r/σ " << before << " -> " << after
              << ", iterations " << metric(sim, "iterations") << ", pairs " << metric(sim, "pairs")
              << ", correction " << metric(sim, "correction"));
    REQUIRE(before < 0.9);
    CHECK(after >= 1 - 1e-6);
    CHECK(metric(sim, "iterations") >= 1);
    CHECK(metric(sim, "iterations") <= c.max_iterations);
    CHECK(metric(sim, "pairs") >= 1);
  }
}

TEST_CASE("overlap_correct: an ideal gas is pushed apart by repeated triangulate + correct steps", "[overlap][physics]") {
  // Uniform random points overlap everywhere; corrections this large outrun the triangulation
  // (it is no longer Delaunay for the moved points, and some overlapping pairs are not edges),
  // so a step of rebuild + correct is repeated until none is left.
  for (const char* mode : {"reflect", "contact"})
    for (double eta : {0.3, 0.5}) {
      const auto spec = correct_spec(2000, eta, {{"mode", std::string(mode)}});
      auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
      scatter(*state, 12);
      Simulation sim(spec, registry(), dry(), std::move(state));
      int steps = 0;
      double gap = 0, its = 0;
      std::string trace;
      while (steps < 50) {
        sim.advance();
        ++steps;
        gap = min_gap(sim.state());
        its += metric(sim, "iterations");
        trace += " " + std::to_string(gap);
        if (gap >= 1 - 1e-6) break;
      }
      INFO(mode << " η " << eta << ": " << steps << " steps, " << its << " iterations; min r/σ after each:" << trace);
      CHECK(gap >= 1 - 1e-6);
      CHECK(steps <= 5);
    }
}

TEST_CASE("overlap_correct: float runs end within the float tolerance", "[overlap]") {
  const auto spec = correct_spec(2000, 0.7, {}, Precision::f32);
  auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
  jiggle(*state, 0.1, 11);
  Simulation sim(spec, registry(), dry(), std::move(state));
  sim.advance();
  // 4·ε_f32·L/σ: the position resolution (L ≈ 47 here, so ≈ 2.2e-5).
  const double tol = 4 * 1.1920929e-7 * sim.state().box.L[0];
  INFO("min r/σ " << min_gap(sim.state()) << ", tolerance " << tol);
  CHECK(min_gap(sim.state()) >= 1 - tol);
  CHECK(metric(sim, "iterations") <= 10);
}

TEST_CASE("overlap_correct: mark: true marks exactly the particles of overlapping pairs (both variants)",
          "[overlap][verlet][mark]") {
  // Two overlapping pairs on the grid (9 at 0.75 from 10, 20 at 0.9 from 21): the step marks those
  // four and no other; the next step (nothing overlaps any more) clears every mark.
  const Backend backend = GENERATE(from_range(test::backends()));
  for (const char* variant : {"delaunay", "verlet"}) {
    INFO(to_string(backend) << ": " << variant);
    auto xy = grid64();
    xy[2 * 9] = 9.25;
    xy[2 * 20] = 21.1;
    auto sim = hand_made(variant_steps(variant, {{"mark", true}}), xy, {}, backend);
    const std::string name = variant == std::string("delaunay") ? "overlap_correct/" : "overlap_correct.verlet/";
    auto marked = [&] {
      Field& f = sim->state().field(overlap::touched_field);
      f.acquire(Where::host, Mode::read);
      std::vector<std::size_t> who;
      for (std::size_t i = 0; i < 64; ++i)
        if (f.host<std::uint8_t>()[i]) who.push_back(i);
      return who;
    };
    sim->advance();
    CHECK(marked() == std::vector<std::size_t>{9, 10, 20, 21});
    CHECK(sim->stats().metrics.at(name + "touched") == 4);
    CHECK(sim->stats().metrics.at(name + "touched_fraction") == 4.0 / 64);
    CHECK(sim->stats().metrics.at(name + "iterations") == 1);
    sim->advance();
    CHECK(marked().empty());
    CHECK(sim->stats().metrics.at(name + "touched") == 0);
  }
}
