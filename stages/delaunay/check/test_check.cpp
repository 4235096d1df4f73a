// delaunay.check (observer): the maintained triangulation is compared with CGAL's Delaunay
// triangulation of the current positions. A fresh or Lawson-maintained triangulation passes; an
// edge flipped by hand away from Delaunay, broken half-edges and an inverted triangle stop the
// run with a RunError naming the step and the edges; co-circular ties (square lattice diagonals)
// pass, and the tolerance decides what counts as co-circular. In a pipeline it runs every k
// accepted steps (CPU and CUDA) and, with positions: delaunay.position_prev, after overlap
// correction too.
#include <algorithm>

#include "core/base/error.h"
#include "core/run/simulation.h"
#include "stages/delaunay/common/mesh.h"
#include "support/spec.h"
#include "support/test_plugins.h"
#include "stages/delaunay/test_support.h"

using namespace ff;
using namespace ff::test::dl;
using Catch::Matchers::Contains;

namespace {

State& built(std::unique_ptr<State>& s) {
  auto build = make_stage("delaunay.build", Backend::cpu, s->precision());
  build->configure(*s);
  Runner r(*s, Backend::cpu);
  REQUIRE_FALSE(r.run(*build).rollback);
  return *s;
}

// Runs delaunay.check on `s` as the core would after accepted step `step`; returns the runner's
// metrics through `r`.
Outcome check(State& s, Backend b, Runner& r, std::uint64_t step, double tolerance = 1e-9,
              const std::string& positions = "position") {
  auto st = make_stage("delaunay.check", b, s.precision(), {{"tolerance", tolerance}, {"positions", positions}});
  st->configure(s);
  return r.run(*st, step);
}

// Host view of the topology for editing by hand (marks the device copy stale).
ff::delaunay::Mesh host_mesh(State& s) {
  Field& he = s.field(dfields::halfedge);
  Field& ve = s.field(dfields::vertex_edge);
  Field& op = s.field(dfields::opposite);
  he.acquire(Where::host, Mode::readwrite);
  ve.acquire(Where::host, Mode::readwrite);
  op.acquire(Where::host, Mode::readwrite);
  return {he.host<std::int32_t>(), ve.host<std::int32_t>(), op.host<std::int32_t>()};
}

// In-circle / permanent of edge e's quad, and whether flipping it keeps both triangles positive.
double cocircularity(State& s, int e, bool& convex) {
  const auto xy = positions(s);
  double L[3] = {s.box.L[0], s.box.L[1], 0};
  const ff::delaunay::Points<double> pts{xy.data(), PeriodicBox<double>::make(L)};
  const ff::delaunay::Quad q = ff::delaunay::quad(host_mesh(s), e);
  const ff::delaunay::V2 o{0, 0}, ab = pts.rel(q.a, q.b), ac = pts.rel(q.a, q.c), ad = pts.rel(q.a, q.d);
  convex = ff::delaunay::orient(ac, o, ad) > 0 && ff::delaunay::orient(ad, ab, ac) > 0;
  double perm;
  return std::fabs(ff::delaunay::incircle(o, ab, ac, ad, perm)) / perm;
}

std::string pair_text(int a, int b) { return std::to_string(std::min(a, b)) + "-" + std::to_string(std::max(a, b)); }

}  // namespace

TEST_CASE("check: a CGAL-built triangulation passes, and is built at step 0 when none exists", "[delaunay][check]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  INFO("backend " << to_string(b));
  const double L = std::sqrt(3000 / 0.6);
  auto s = make_state(random_points(3000, L, L, 11), L, L);
  Runner r(*s, b);
  SECTION("nothing built yet: the observer builds what the first topology stage would") {
    auto st = make_stage("delaunay.check", b);
    st->configure(*s);
    CHECK(status_of(*s)[ff::delaunay::kBuilt] == 0);
    REQUIRE_FALSE(r.run(*st, 0).rollback);
    CHECK(status_of(*s)[ff::delaunay::kBuilt] == 1);
  }
  SECTION("built by delaunay.build") {
    built(s);
    REQUIRE_FALSE(check(*s, b, r, 7).rollback);
  }
  CHECK(r.metric("checked") == 1);
  CHECK(r.metric("mismatches") == 0);
  CHECK(r.metric("ties") == 0);  // random points: no co-circular quads
  require_valid(*s);
}

TEST_CASE("check: an edge flipped away from Delaunay is a mismatch naming the step and both edges",
          "[delaunay][check]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  INFO("backend " << to_string(b));
  const double L = std::sqrt(2000 / 0.6);
  auto s = make_state(random_points(2000, L, L, 5), L, L);
  built(s);
  // The first edge whose quad is convex and clearly not co-circular.
  int e = -1;
  for (int k = 0; k < int(3 * s->n()) && e < 0; ++k) {
    bool convex = false;
    if (cocircularity(*s, k, convex) > 1e-3 && convex) e = k;
  }
  REQUIRE(e >= 0);
  const ff::delaunay::Mesh m = host_mesh(*s);
  const ff::delaunay::Quad q = ff::delaunay::quad(m, e);
  ff::delaunay::flip_edge(m, e);
  require_valid(*s);  // still a valid, positively oriented triangulation: only not Delaunay
  Runner r(*s, b);
  try {
    check(*s, b, r, 1234);
    FAIL("no RunError");
  } catch (const RunError& err) {
    const std::string msg = err.what();
    INFO(msg);
    CHECK_THAT(msg, Contains("delaunay.check: step 1234"));
    CHECK_THAT(msg, Contains("in 2 edge(s) that are not co-circular ties"));
    CHECK_THAT(msg, Contains("the maintained triangulation has edge " + pair_text(q.c, q.d)));
    CHECK_THAT(msg, Contains("CGAL's has edge " + pair_text(q.a, q.b)));
  }
  CHECK(r.metric("checked") == 1);
  CHECK(r.metric("mismatches") == 2);
  // Flipping it back restores CGAL's triangulation.
  ff::delaunay::flip_edge(host_mesh(*s), e);
  Runner r2(*s, b);
  REQUIRE_FALSE(check(*s, b, r2, 1235).rollback);
  CHECK(r2.metric("mismatches") == 0);
}

TEST_CASE("check: co-circular ties pass; the tolerance decides what is co-circular", "[delaunay][check]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  INFO("backend " << to_string(b));
  auto s = make_state(square_lattice(12, 12, 1.0), 12, 12);
  built(s);
  // A diagonal of a unit square: its quad is exactly co-circular.
  int e = -1;
  for (int k = 0; k < int(3 * s->n()) && e < 0; ++k) {
    bool convex = false;
    if (cocircularity(*s, k, convex) == 0 && convex) e = k;
  }
  REQUIRE(e >= 0);
  const ff::delaunay::Mesh m = host_mesh(*s);
  const ff::delaunay::Quad q = ff::delaunay::quad(m, e);
  ff::delaunay::flip_edge(m, e);  // the other diagonal: just as Delaunay
  {
    Runner r(*s, b);
    REQUIRE_FALSE(check(*s, b, r, 3).rollback);
    CHECK(r.metric("mismatches") == 0);
    CHECK(r.metric("ties") == 2);  // (c, d) only in ours, (a, b) only in CGAL's
  }
  // Push c out of the circle of (a, b, d) by 1e-6: now only (a, b) is Delaunay, by a relative
  // in-circle margin of order 1e-6 (neighbouring squares around c change by as little).
  auto xy = positions(*s);
  const double L = 12;
  double dx = 0, dy = 0;  // from the square's centre (midpoint of a, b) to c, minimum image
  for (int k = 0; k < 2; ++k) {
    double mid = xy[2 * q.a + k] + 0.5 * std::remainder(xy[2 * q.b + k] - xy[2 * q.a + k], L);
    (k ? dy : dx) = std::remainder(xy[2 * q.c + k] - mid, L);
  }
  const double len = std::hypot(dx, dy);
  xy[2 * q.c] += 1e-6 * dx / len;
  xy[2 * q.c + 1] += 1e-6 * dy / len;
  set_positions(*s, xy);
  bool convex = false;
  const double off = cocircularity(*s, e, convex);
  INFO("in-circle / permanent after the push: " << off);
  REQUIRE(off > 1e-8);
  REQUIRE(off < 1e-5);
  {
    Runner r(*s, b);
    REQUIRE_THROWS_WITH(check(*s, b, r, 4), Contains("step 4: ") && Contains("that are not co-circular ties"));
    CHECK(r.metric("mismatches") >= 2);
  }
  {
    Runner r(*s, b);
    REQUIRE_FALSE(check(*s, b, r, 5, 1e-4).rollback);
    CHECK(r.metric("mismatches") == 0);
    CHECK(r.metric("ties") >= 2);
  }
}

TEST_CASE("check: broken half-edges and inverted triangles are errors", "[delaunay][check]") {
  SECTION("a next pointer out of its triangle") {
    const double L = std::sqrt(500 / 0.6);
    auto s = make_state(random_points(500, L, L, 3), L, L);
    built(s);
    const ff::delaunay::Mesh m = host_mesh(*s);
    std::swap(m.he[2 * 0 + 1], m.he[2 * 7 + 1]);
    Runner r(*s, Backend::cpu);
    REQUIRE_THROWS_WITH(check(*s, Backend::cpu, r, 9),
                        Contains("step 9: the maintained half-edges are not a triangulation of the torus"));
  }
  SECTION("a vertex moved across an edge without repair") {
    Scene sc;
    const auto f = sc.fan(0);
    sc.cross_one_edge(f);
    Runner r(*sc.s, Backend::cpu);
    REQUIRE_THROWS_WITH(check(*sc.s, Backend::cpu, r, 11),
                        Contains("step 11: ") && Contains("triangle(s) of the maintained triangulation are not positively oriented"));
  }
}

TEST_CASE("check: positions: delaunay.position_prev checks what Lawson saw", "[delaunay][check]") {
  Scene sc;
  // Move one particle far enough to spoil the Delaunay property of its fan (not across an edge):
  // `position` no longer matches, `delaunay.position_prev` (the build's positions) still does.
  const auto f = sc.fan(0);
  sc.move(0, sc.lerp(sc.near(0, 0), sc.mid(0, f.p, f.q), 0.85));  // w enters the circle of (0, p, q)
  require_valid(*sc.s);
  Runner r(*sc.s, Backend::cpu);
  REQUIRE_THROWS_WITH(check(*sc.s, Backend::cpu, r, 2), Contains("differs from CGAL's Delaunay triangulation of 'position'"));
  REQUIRE_FALSE(check(*sc.s, Backend::cpu, r, 2, 1e-9, "delaunay.position_prev").rollback);
  CHECK(r.metric("mismatches") == 0);
}

TEST_CASE("check: in pipelines, every k accepted steps, on every backend", "[delaunay][check][pipeline]") {
  const Backend backend = GENERATE(from_range(ff::test::backends()));
  INFO("backend " << to_string(backend));
  auto reg = test::registry_with({"brownian"});
  using ff::test::entry;
  SECTION("free Brownian disks (the brownian-delaunay pipeline, small)") {
    auto spec = test::spec(2, 3000, 0.5, 400, 0.01,
                           {entry(*reg, "brownian.integrate", {{"D", 0.01}}), entry(*reg, "delaunay.detect_inversion"),
                            entry(*reg, "delaunay.flip"), entry(*reg, "delaunay.lawson"),
                            entry(*reg, "delaunay.check", {}, {"", {}, false, 100})},
                           42);
    spec.system.init = "random";
    RunOptions o;
    o.dry_run = true;
    o.backend = backend;
    Simulation sim(spec, *reg, o);
    // The rollback snapshot: positions and detection's reference (swapped, not copied) and the
    // triangulation when a stage announces a write; never the per-step scratch (flip marks,
    // Lawson candidates).
    const auto every = sim.snapshot_fields(), on_demand = sim.snapshot_on_demand_fields();
    CHECK(std::count(every.begin(), every.end(), "position") == 0);
    CHECK(std::count(on_demand.begin(), on_demand.end(), "position") == 1);
    CHECK(std::count(on_demand.begin(), on_demand.end(), "delaunay.position_prev") == 1);
    CHECK(std::count(on_demand.begin(), on_demand.end(), "delaunay.halfedge") == 1);
    for (const char* scratch : {"delaunay.flip_mark", "delaunay.lawson_candidates"}) {
      CHECK(std::count(every.begin(), every.end(), scratch) == 0);
      CHECK(std::count(on_demand.begin(), on_demand.end(), scratch) == 0);
    }
    sim.run();
    CHECK(sim.slots()[4].calls == 5);  // steps 0, 100, 200, 300, 400
    CHECK(sim.stats().metrics.at("delaunay.check/checked") == 1);
    CHECK(sim.stats().metrics.at("delaunay.check/mismatches") == 0);
    CHECK(sim.stats().metrics.at("delaunay.lawson/lawson_flips") > 0);  // the triangulation did change
  }
  SECTION("hard disks: overlap correction after Lawson, checked against delaunay.position_prev") {
    auto spec = test::spec(2, 1000, 0.5, 300, 3e-4,
                           {entry(*reg, "brownian.integrate", {{"D", 1.0}}), entry(*reg, "delaunay.detect_inversion"),
                            entry(*reg, "delaunay.flip"), entry(*reg, "delaunay.lawson"), entry(*reg, "overlap_correct"),
                            entry(*reg, "delaunay.check", {{"positions", std::string("delaunay.position_prev")}},
                                  {"", {}, false, 50})},
                           7);
    spec.system.init = "random";
    RunOptions o;
    o.dry_run = true;
    o.backend = backend;
    Simulation sim(spec, *reg, o);
    sim.run();
    CHECK(sim.stats().metrics.at("delaunay.check/checked") == 1);
    CHECK(sim.stats().metrics.at("delaunay.check/mismatches") == 0);
  }
}
