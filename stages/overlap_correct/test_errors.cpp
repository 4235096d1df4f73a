// overlap_correct's errors: a corrupt triangulation (also away from any overlap), no triangulation
// before it, 3D, max_iterations reached (the step and the worst pair named), and the diameter
// ratio below √2 − 1 refused (naming the bound, overlap_correct.verlet and the opt-out), with what
// the check guards against shown on its motif.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <string>

#include "core/base/error.h"
#include "stages/delaunay/common/fields.h"
#include "stages/overlap_correct/test_support.h"
#include "support/backends.h"

using namespace ff;
using namespace ff::overlap_test;

TEST_CASE("overlap_correct: a corrupt triangulation is an error, also away from any overlap", "[overlap][errors]") {
  // A lattice at η = 0.3 has no overlaps; each corruption below is one half-edge record. At 2000
  // particles the CUDA loop is the dense cluster (dense_block.cuh, 8 blocks), which checks the
  // records as the CPU's edge pass does, the next pointers' permutation included. (Larger runs
  // walk around every particle in iteration 0 and find a corrupt mesh by fans that do not close or
  // indices out of range: a next pointer duplicated where every walk still closes passes there.)
  const Backend backend = GENERATE(from_range(test::backends()));
  struct Case {
    const char* what;
    int field;  // 0: origin, 1: next
    int value;  // -1: out of range; -2: the next of another half-edge; -3: the edge's other end
  };
  const Case cases[] = {{"origin out of range", 0, -1},
                        {"next out of range", 1, -1},
                        {"next not a permutation", 1, -2},
                        {"loop edge", 0, -3}};
  for (const Case& c : cases) {
    INFO(to_string(backend) << ": " << c.what);
    auto sim = triangulated(2000, 0.3, [](State&) {}, [&](State& s) {
      Field& f = s.field(delaunay::fields::halfedge);
      f.acquire(Where::host, Mode::readwrite);
      std::int32_t* he = f.host<std::int32_t>();
      const std::size_t h = 2 * 1234;  // edge 1234's first half-edge
      he[2 * h + c.field] = c.value == -1   ? std::int32_t(6 * s.n() + 5)
                            : c.value == -2 ? he[2 * (h + 10) + 1]
                                            : he[2 * (h + 1)];
    });
    State& s = sim->state();
    auto d = corrector(s, backend);
    try {
      d.run(s, 0, 0.01);  // returns the outcome; a throw propagates (step() would report it)
      FAIL("expected a RunError");
    } catch (const RunError& e) {
      const std::string m = e.what();
      INFO(m);
      CHECK(m.find("corrupt") != std::string::npos);
    }
  }
}

TEST_CASE("overlap_correct: errors name what to change", "[overlap][errors]") {
  const Registry& r = registry();
  SECTION("no triangulation before it") {
    auto s = test::spec(2, 200, 0.3, 1, 0.01, {entry(r, "overlap_correct")});
    try {
      Simulation sim(s, r, dry());
      FAIL("expected an InputError");
    } catch (const InputError& e) {
      const std::string m = e.what();
      CHECK(m.find("delaunay") != std::string::npos);
      CHECK(m.find("before") != std::string::npos);
    }
  }
  SECTION("3D") {
    auto s = test::spec(3, 200, 0.3, 1, 0.01, {entry(r, "overlap_correct")});
    CHECK_THROWS_AS(Simulation(s, r, dry()), InputError);
  }
  // The RunError of the first step of 2000 disks at φ = 0.8, jiggled, with max_iterations 2 and `more`.
  auto max_iterations_error = [&](std::map<std::string, ParamValue> more) {
    more["max_iterations"] = std::int64_t(2);
    const auto spec = correct_spec(2000, 0.8, more);
    auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
    jiggle(*state, 0.1, 11);
    Simulation sim(spec, r, dry(), std::move(state));
    try {
      sim.advance();
    } catch (const RunError& e) {
      return std::string(e.what());
    }
    FAIL("expected a RunError");
    return std::string();
  };
  SECTION("max_iterations reached: the step and the worst pair are named") {
    const std::string m = max_iterations_error({});
    INFO(m);
    CHECK(m.find("step 0") != std::string::npos);
    CHECK(m.find("max_iterations = 2") != std::string::npos);
    CHECK(m.find("worst is particles") != std::string::npos);
    CHECK(m.find("mode: contact") == std::string::npos);  // reflect's error: nothing about contact
  }
  SECTION("max_iterations reached in mode: contact: the error says that reflect is the mode for dense systems") {
    const std::string m = max_iterations_error({{"mode", std::string("contact")}});
    INFO(m);
    CHECK(m.find("max_iterations = 2") != std::string::npos);
    CHECK(m.find("mode: contact needs ~15 times the iterations of mode: reflect") != std::string::npos);
  }
}

TEST_CASE("overlap_correct: the diameter-ratio limit σ_min/σ_max ≥ √2 − 1 (seed-gaps C5)", "[overlap][errors]") {
  // The motif: two large disks (σ = 1) overlapping at r = 0.99 about (16, 16), and two small ones
  // just inside the top and the bottom of their diametral circle (0.495·(1 − 10⁻³) from its
  // centre). Every circle through the two large centres holds a small one, so the large pair is no
  // Delaunay edge. Small disks of 0.3 overlap nothing (0.6997 from each large centre > 0.65): the
  // correction on Delaunay edges sees no overlap and leaves the large pair as it is. Small disks of
  // 0.42 do overlap the large ones (0.6997 < 0.71), and the correction leaves no overlap at all.
  auto motif = [] {
    auto xy = grid64();
    const double h = 0.495 * (1 - 1e-3);
    const double at[4][2] = {{16 - 0.495, 16}, {16 + 0.495, 16}, {16, 16 + h}, {16, 16 - h}};
    for (int i = 0; i < 4; ++i) {
      xy[2 * i] = at[i][0];
      xy[2 * i + 1] = at[i][1];
    }
    return xy;
  };
  auto pair_gap = [](Simulation& sim) {
    const auto xy = positions(sim.state());
    return std::hypot(xy[2] - xy[0], xy[3] - xy[1]);
  };
  SECTION("ratio 0.3 is refused, naming the bound, the Verlet variant and the opt-out") {
    for (double small : {0.3, 0.41}) {
      INFO("small " << small);
      try {
        hand_made(variant_steps("delaunay", {}), motif(), {{2, small}, {3, small}});
        FAIL("expected an InputError");
      } catch (const InputError& e) {
        const std::string m = e.what();
        INFO(m);
        CHECK(m.find("√2 − 1") != std::string::npos);
        CHECK(m.find("overlap_correct.verlet") != std::string::npos);
        CHECK(m.find("check_diameter_ratio: false") != std::string::npos);
      }
    }
  }
  SECTION("ratio 0.3 with the check off: the overlap survives; overlap_correct.verlet removes it") {
    auto sim = hand_made(variant_steps("delaunay", {{"check_diameter_ratio", false}}), motif(), {{2, 0.3}, {3, 0.3}});
    REQUIRE(min_gap(sim->state()) == Approx(0.99).epsilon(1e-12));
    sim->advance();
    CHECK(metric(*sim, "iterations") == 0);
    CHECK(pair_gap(*sim) == Approx(0.99).epsilon(1e-12));
    CHECK(min_gap(sim->state()) < 1 - 1e-6);
    auto verlet = hand_made(variant_steps("verlet", {}), motif(), {{2, 0.3}, {3, 0.3}});
    verlet->advance();
    CHECK(min_gap(verlet->state()) >= 1 - 1e-6);
  }
  SECTION("ratio 0.42 is accepted and leaves no overlap") {
    auto sim = hand_made(variant_steps("delaunay", {}), motif(), {{2, 0.42}, {3, 0.42}});
    REQUIRE(min_gap(sim->state()) < 0.99);
    sim->advance();
    INFO("iterations " << metric(*sim, "iterations") << ", large pair at " << pair_gap(*sim));
    CHECK(metric(*sim, "iterations") >= 1);
    CHECK(min_gap(sim->state()) >= 1 - 1e-6);
  }
}
