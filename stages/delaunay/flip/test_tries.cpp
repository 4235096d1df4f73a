// delaunay.flip: decide_next (flip/tries.h), what the untangling of a sub-step does next, on
// counters set by hand. The host's loop and the device's kernel both call it, so this table is
// what both backends decide.
#include <catch2/catch.hpp>

#include "stages/delaunay/flip/tries.h"

TEST_CASE("flip substep: decide_next, what the untangling does next on both backends", "[delaunay][flip][substep]") {
  // The decisions of flip/tries.h alone, from counters as a round's marking leaves them (f: the
  // try's first block, r: the round's): the host's loop and the device's kernel both call it.
  using namespace ff::delaunay;
  unsigned f[kSubstepCounters] = {}, r[kSubstepCounters] = {};
  const UntangleLimits rollback{64, 3, false}, passing{64, 3, true};
  TryState s{};
  SECTION("something marked: another round, over the round's troubled list") {
    r[kMarked] = 2;
    r[kRepairFlips] = 4;
    r[kTroubledCount] = 5;
    CHECK(decide_next(f, r, rollback, s) == kPhaseRound);
    CHECK(s.list == 1);  // trouble_[0], which the round just wrote
    CHECK(s.n_list == 5);
    CHECK(s.out == 1);
    CHECK(s.flips == 4);
    CHECK(s.try_rounds == 1);
    CHECK(s.tries == 0);
  }
  SECTION("max_rounds flipping rounds end the try; still inverted: a failed try") {
    s.try_rounds = 63;
    r[kMarked] = 1;
    r[kRepairFlips] = 1;
    r[kInverted] = 1;
    f[kTouchedEdgeCount] = 7;
    CHECK(decide_next(f, r, rollback, s) == kPhaseFail);
    CHECK(s.rounds == 64);
    CHECK(s.try_rounds == 0);
    CHECK(s.halvings == 1);
    CHECK(s.tries == 1);
    CHECK(s.n_touched_edges == 7);
    CHECK(s.list == 0);  // the next try's first marking
    CHECK(s.out == 0);
  }
  SECTION("nothing inverted or reversed and nobody on the way: at the targets") {
    CHECK(decide_next(f, r, rollback, s) == kPhaseStop);
    CHECK(s.stop == kStopTargets);
    CHECK(s.tries == 0);
  }
  SECTION("nothing inverted, particles on their way: accepted tries") {
    f[kActiveCount] = 3;
    CHECK(decide_next(f, r, rollback, s) == kPhaseAccept);
    CHECK(s.first_accept == 1);  // V ← every position
    CHECK(s.cur == 0);
    CHECK(s.now == 1);
    CHECK(s.n_shallowed == 3);
    f[kActiveCount] = 2;
    CHECK(decide_next(f, r, rollback, s) == kPhaseAccept);
    CHECK(s.first_accept == 0);  // V ← the listed ones
    CHECK(s.n_copied == 3);
    CHECK(s.n_active == 2);
    CHECK(s.cur == 1);
    CHECK(s.halvings == 0);
    CHECK(s.tries == 2);
  }
  SECTION("a reversed edge: a rollback, or with passing: substep a failed try") {
    f[kThrough] = 1;
    TryState t = s;
    CHECK(decide_next(f, r, rollback, s) == kPhaseStop);
    CHECK(s.stop == kStopThrough);
    CHECK(decide_next(f, r, passing, t) == kPhaseFail);
    CHECK(t.halvings == 1);
  }
  SECTION("still in trouble after max_substeps halvings: a rollback") {
    r[kInverted] = 1;
    s.halvings = 3;
    CHECK(decide_next(f, r, passing, s) == kPhaseStop);
    CHECK(s.stop == kStopSubsteps);
    CHECK(s.halvings == 3);
  }
  SECTION("a triangle that does not close: stop before anything else (the host throws)") {
    r[kMarked] = 1;
    r[kTooLong] = 1;
    CHECK(decide_next(f, r, passing, s) == kPhaseStop);
    CHECK(s.stop == kStopTooLong);
    CHECK(s.flips == 0);
  }
  SECTION("a generation that wraps around asks for its stamps to be cleared") {
    r[kMarked] = 1;
    s.work_gen = 0xFFFFFFEFu;
    CHECK(decide_next(f, r, rollback, s) == kPhaseRound);
    CHECK(s.wg_round == 1);
    CHECK(s.clear == kClearEdges);
    CHECK(decide_next(f, r, rollback, s) == kPhaseRound);
    CHECK(s.clear == 0);
  }
}
