// delaunay.lawson alone (with detect_inversion + flip in front where particles move): after
// Brownian steps the maintained triangulation equals CGAL's Delaunay triangulation of the new
// points (up to co-circular ties), every triangle stays positive with 3N edges, the result does
// not depend on the thread count, square lattices (co-circular everywhere) terminate, and the
// round limit is a clear error.
#include <oneapi/tbb/global_control.h>

#include "core/base/error.h"
#include "core/input/init.h"
#include "stages/delaunay/test_support.h"

using namespace ff;
using namespace ff::test::dl;

namespace {

// x += sqrt(2 D dt) xi per component (truncated Gaussians, as brownian.integrate), on the host.
void brownian_step(State& s, double D, double dt, std::uint64_t step, std::uint32_t attempt = 0) {
  auto xy = positions(s);
  const RngKey key = make_rng_key(42, "brownian");
  const double amp = std::sqrt(2 * D * dt);
  for (std::size_t i = 0; i < s.n(); ++i) {
    double z[2];
    gaussians(key, std::uint32_t(i), step, attempt, 0, 2, z);
    xy[2 * i] += amp * z[0];
    xy[2 * i + 1] += amp * z[1];
  }
  set_positions(s, xy);
}

struct Pipeline {
  std::unique_ptr<Stage> detect, flip, lawson;
  Pipeline(State& s, Backend b, std::int64_t max_rounds = 1000) {
    detect = make_stage("delaunay.detect_inversion", b, s.precision());
    flip = make_stage("delaunay.flip", b, s.precision());
    lawson = make_stage("delaunay.lawson", b, s.precision(), {{"max_rounds", max_rounds}});
    for (Stage* st : {detect.get(), flip.get(), lawson.get()}) st->configure(s);
  }
  struct Counts {
    double inversions = 0, flips = 0, lawson_flips = 0, lawson_rounds = 0;
  };
  Counts step(Runner& r, std::uint64_t k) {
    Counts c;
    Outcome o = r.run(*detect, k);
    INFO(o.reason);
    REQUIRE_FALSE(o.rollback);
    c.inversions = r.metric("inversions");
    o = r.run(*flip, k);
    REQUIRE_FALSE(o.rollback);
    c.flips = r.metric("flips");
    REQUIRE_FALSE(r.run(*lawson, k).rollback);
    c.lawson_flips = r.metric("lawson_flips");
    c.lawson_rounds = r.metric("lawson_rounds");
    return c;
  }
};

std::unique_ptr<State> initial(double phi, std::size_t n, std::uint64_t seed, Precision p = Precision::f64) {
  SystemSpec sys;
  sys.dimensions = 2;
  sys.N = n;
  sys.packing_fraction = phi;
  sys.init = phi > 0.54 ? "triangular_lattice_sample" : "random";
  return make_initial_state(sys, p, seed);
}

void require_delaunay(State& s) {
  const Topo t = topology(s);
  const auto xy = positions(s);
  CHECK(ff::delaunay::count_non_delaunay(t.he.data(), s.n(), xy.data(), s.box.L[0], s.box.L[1], 1e-9) == 0);
  CHECK(real_differences(t, cgal_reference(s), s) == 0);
}

}  // namespace

TEST_CASE("lawson: Brownian steps keep CGAL's Delaunay triangulation", "[delaunay][lawson]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  const double phi = GENERATE(0.1, 0.5, 0.8);
  const std::size_t n = 2000;
  const int steps = 200;
  INFO("phi = " << phi << ", backend " << to_string(b));
  auto s = initial(phi, n, 17);
  Pipeline p(*s, b);
  Runner r(*s, b);
  double inversions = 0, flips = 0, lawson_flips = 0, max_rounds = 0;
  for (int k = 0; k < steps; ++k) {
    brownian_step(*s, 0.01, 0.01, std::uint64_t(k));
    const auto c = p.step(r, std::uint64_t(k));
    inversions += c.inversions;
    flips += c.flips;
    lawson_flips += c.lawson_flips;
    max_rounds = std::max(max_rounds, c.lawson_rounds);
    require_valid(*s);
    if (k % 20 == 19) require_delaunay(*s);
  }
  INFO("inversions " << inversions << ", repair flips " << flips << ", Lawson flips " << lawson_flips
                     << ", most rounds " << max_rounds);
  CHECK(lawson_flips > 0);
  CHECK(flips == inversions);
}

namespace {

// One accepted step as the core takes it: a Brownian move of Δt = dt, detect + flip; a rollback
// restores the snapshot and retries at Δt/2 with the next attempt's noise; then Lawson. Adds
// the step's inversions, repair flips, Lawson flips and rollbacks to `c`.
struct Totals {
  double inversions = 0, flips = 0, lawson_flips = 0, rollbacks = 0;
};
void accepted_step(State& s, Pipeline& p, Runner& r, std::uint64_t k, double D, double dt, Totals& c) {
  TopologySnapshot snap;
  snap.take(s);
  for (std::uint32_t attempt = 0;; ++attempt) {
    REQUIRE(attempt < 30);
    brownian_step(s, D, dt, k, attempt);
    Outcome o = r.run(*p.detect, k);
    const double inv = r.metric("inversions");
    if (!o.rollback) o = r.run(*p.flip, k);
    if (o.rollback) {
      ++c.rollbacks;
      snap.restore(s);
      dt /= 2;
      continue;
    }
    c.inversions += inv;
    c.flips += r.metric("flips");
    REQUIRE_FALSE(r.run(*p.lawson, k).rollback);
    c.lawson_flips += r.metric("lawson_flips");
    return;
  }
}
}  // namespace

TEST_CASE("lawson: large steps with repairs and rollbacks stay valid and Delaunay", "[delaunay][lawson]") {
  // Δt 50x the test above at φ = 0.8: vertices cross edges (repaired by delaunay.flip) or pass
  // through each other / cross several edges (rolled back, retried at Δt/2 with fresh noise, as
  // the core does). Every accepted step ends valid and Delaunay.
  const Backend b = GENERATE(from_range(ff::test::backends()));
  auto s = initial(0.8, 1000, 3);
  Pipeline p(*s, b);
  Runner r(*s, b);
  Totals c;
  for (int k = 0; k < 60; ++k) {
    accepted_step(*s, p, r, std::uint64_t(k), 0.01, 0.5, c);
    require_valid(*s);
    if (k % 10 == 9) require_delaunay(*s);
  }
  INFO("inversions " << c.inversions << ", repair flips " << c.flips << ", rollbacks " << c.rollbacks);
  CHECK(c.inversions > 0);
  CHECK(c.flips == c.inversions);
  CHECK(c.rollbacks > 0);
}

TEST_CASE("lawson: 10^4 Brownian steps at N = 10^4 stay CGAL's Delaunay triangulation", "[delaunay][lawson][long]") {
  // The case: D = 0.01, Δt = 0.01 at packing fractions 0.1, 0.5 and 0.8, 10^4
  // consecutive steps at N = 10^4. After every accepted step the triangulation is valid
  // (every triangle positive and closed; structure and 3N edges every 100 steps) and locally
  // Delaunay at every edge — which for a triangulation of the torus means it *is* the Delaunay
  // triangulation, up to co-circular ties — and every 1000 steps it is compared with CGAL's
  // triangulation of the same points edge by edge. Free disks pass through each other now and
  // then; such steps roll back and are retried at Δt/2 with fresh noise, as the core does.
  const Backend b = GENERATE(from_range(ff::test::backends()));
  const double phi = GENERATE(0.1, 0.5, 0.8);
  const std::size_t n = 10000;
  const int steps = 10000;
  INFO("phi = " << phi << ", backend " << to_string(b));
  auto s = initial(phi, n, 29);
  Pipeline p(*s, b);
  Runner r(*s, b);
  Totals c;
  std::size_t not_delaunay = 0, bad_triangles = 0, cgal_checks = 0;
  for (int k = 0; k < steps; ++k) {
    accepted_step(*s, p, r, std::uint64_t(k), 0.01, 0.01, c);
    const Topo t = topology(*s);
    const auto xy = positions(*s);
    not_delaunay += ff::delaunay::count_non_delaunay(t.he.data(), n, xy.data(), s->box.L[0], s->box.L[1], 1e-9);
    bad_triangles += ff::delaunay::count_bad_triangles(t.he.data(), n, xy.data(), s->box.L[0], s->box.L[1]);
    if (not_delaunay || bad_triangles) {
      FAIL_CHECK("step " << k << ": not Delaunay or not valid");
      break;
    }
    if (k % 100 == 99) {
      REQUIRE(ff::delaunay::check_structure(t.he.data(), t.vedge.data(), n) == "");
      REQUIRE(ff::delaunay::check_opposite(t.he.data(), t.opp.data(), n) == "");
    }
    if (k % 1000 == 999) {
      REQUIRE(real_differences(t, cgal_reference(*s), *s) == 0);
      ++cgal_checks;
    }
  }
  INFO("Lawson flips " << c.lawson_flips << ", repair flips " << c.flips << ", rollbacks " << c.rollbacks);
  CHECK(not_delaunay == 0);
  CHECK(bad_triangles == 0);
  CHECK(cgal_checks == 10);
  CHECK(c.flips == c.inversions);
  CHECK(c.lawson_flips > 1000);  // the triangulation really changed
}

TEST_CASE("lawson: float precision (predicates in double) keeps CGAL's Delaunay", "[delaunay][lawson]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  auto s = initial(0.5, 2000, 23, Precision::f32);
  Pipeline p(*s, b);
  Runner r(*s, b);
  double lawson_flips = 0;
  for (int k = 0; k < 100; ++k) {
    brownian_step(*s, 0.01, 0.01, std::uint64_t(k));
    lawson_flips += p.step(r, std::uint64_t(k)).lawson_flips;
    require_valid(*s);
  }
  CHECK(lawson_flips > 0);
  require_delaunay(*s);
}

TEST_CASE("lawson: the result does not depend on the thread count", "[delaunay][lawson]") {
  std::vector<std::vector<std::int32_t>> results;
  for (int threads : {1, 2, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
    auto s = initial(0.5, 3000, 5);
    Pipeline p(*s, Backend::cpu);
    Runner r(*s, Backend::cpu);
    // Larger steps (D dt 4x the test above) so that more flips compete every round.
    for (int k = 0; k < 30; ++k) {
      brownian_step(*s, 0.02, 0.02, std::uint64_t(k));
      p.step(r, std::uint64_t(k));
    }
    results.push_back(topology(*s).he);
  }
  CHECK(results[0] == results[1]);
  CHECK(results[0] == results[2]);
}

TEST_CASE("lawson: square lattices (co-circular everywhere) terminate", "[delaunay][lawson]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  const double noise = GENERATE(0.0, 1e-13, 1e-6, 1e-3);
  INFO("noise " << noise << ", backend " << to_string(b));
  auto s = make_state(square_lattice(30, 30, 1.0), 30, 30);
  auto build = make_stage("delaunay.build", Backend::cpu);
  build->configure(*s);
  Runner rb(*s, Backend::cpu);
  REQUIRE_FALSE(rb.run(*build).rollback);
  auto xy = positions(*s);
  const RngKey key = make_rng_key(8, "noise");
  for (std::size_t i = 0; i < xy.size(); ++i) xy[i] += noise * (uniform01(key, std::uint32_t(i), 0, 0, 0) - 0.5);
  set_positions(*s, xy);
  auto lawson = make_stage("delaunay.lawson", b);
  lawson->configure(*s);
  Runner r(*s, b);
  REQUIRE_FALSE(r.run(*lawson).rollback);
  if (noise < 1e-12) CHECK(r.metric("lawson_flips") == 0);  // ties are left alone
  if (noise >= 1e-3) CHECK(r.metric("lawson_flips") > 0);
  CHECK(r.metric("lawson_rounds") < 20);
  require_valid(*s);
  require_delaunay(*s);
  // A second pass finds nothing to do: no cycling between the two diagonals of a square.
  REQUIRE_FALSE(r.run(*lawson).rollback);
  CHECK(r.metric("lawson_flips") == 0);
}

namespace {
// A shear x += A sin(2 pi y / L) of a built random triangulation: triangles stay positive, many
// edges stop being Delaunay, and the flips of one round compete for triangles.
std::unique_ptr<State> sheared(double amplitude, std::size_t n = 1600) {
  const double L = 40 * std::sqrt(double(n) / 1600);
  auto s = make_state(random_points(n, L, L, 21), L, L);
  auto build = make_stage("delaunay.build", Backend::cpu);
  build->configure(*s);
  Runner rb(*s, Backend::cpu);
  REQUIRE_FALSE(rb.run(*build).rollback);
  auto xy = positions(*s);
  for (std::size_t i = 0; i < s->n(); ++i) xy[2 * i] += amplitude * std::sin(2 * M_PI * xy[2 * i + 1] / L);
  set_positions(*s, xy);
  return s;
}
}  // namespace

TEST_CASE("lawson: a sheared triangulation is flipped back to Delaunay over several rounds", "[delaunay][lawson]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  auto s = sheared(1.5);
  {
    const Topo t = topology(*s);
    const auto xy = positions(*s);
    REQUIRE(ff::delaunay::count_bad_triangles(t.he.data(), s->n(), xy.data(), 40, 40) == 0);
    REQUIRE(ff::delaunay::count_non_delaunay(t.he.data(), s->n(), xy.data(), 40, 40, 1e-9) > 100);
  }
  auto lawson = make_stage("delaunay.lawson", b);
  lawson->configure(*s);
  Runner r(*s, b);
  REQUIRE_FALSE(r.run(*lawson).rollback);
  INFO("flips " << r.metric("lawson_flips") << ", rounds " << r.metric("lawson_rounds"));
  CHECK(r.metric("lawson_flips") > 100);
  CHECK(r.metric("lawson_rounds") > 2);
  require_valid(*s);
  require_delaunay(*s);
}

TEST_CASE("lawson: errors", "[delaunay][lawson]") {
  SECTION("max_rounds reached") {
    auto s = sheared(1.5);
    auto lawson = make_stage("delaunay.lawson", Backend::cpu, Precision::f64, {{"max_rounds", std::int64_t(1)}});
    lawson->configure(*s);
    Runner r(*s, Backend::cpu);
    CHECK_THROWS_WITH(r.run(*lawson), Catch::Contains("max_rounds = 1"));
  }
  SECTION("max_rounds reached in CUDA's tail kernel (read after the step)") {
    if (!ff::test::have_cuda("lawson max_rounds on CUDA")) return;
    auto s = sheared(1.5);
    auto lawson = make_stage("delaunay.lawson", Backend::cuda, Precision::f64, {{"max_rounds", std::int64_t(2)}});
    lawson->configure(*s);
    Runner r(*s, Backend::cuda);
    CHECK_THROWS_WITH(r.run(*lawson), Catch::Contains("max_rounds = 2"));
  }
  SECTION("max_rounds reached in CUDA's tail kernel on a cluster (40 000 particles)") {
    if (!ff::test::have_cuda("lawson max_rounds on CUDA's cluster")) return;
    auto s = sheared(25, 40000);
    auto lawson = make_stage("delaunay.lawson", Backend::cuda, Precision::f64, {{"max_rounds", std::int64_t(3)}});
    lawson->configure(*s);
    Runner r(*s, Backend::cuda);
    CHECK_THROWS_WITH(r.run(*lawson), Catch::Contains("max_rounds = 3"));
  }
  SECTION("unrepaired inversions (no delaunay.flip)") {
    auto s = make_state(random_points(200, 12, 12, 4), 12, 12);
    auto lawson = make_stage("delaunay.lawson", Backend::cpu);
    lawson->configure(*s);
    Runner r(*s, Backend::cpu);
    REQUIRE_FALSE(r.run(*lawson).rollback);
    status_of(*s)[ff::delaunay::kPending] = 1;
    CHECK_THROWS_WITH(r.run(*lawson), Catch::Contains("put delaunay.flip"));
  }
}

TEST_CASE("lawson: CPU and CUDA give the same triangulation", "[delaunay][lawson][cuda]") {
  if (!ff::test::have_cuda("lawson CPU-vs-CUDA")) return;
  std::vector<std::vector<std::int32_t>> he;
  std::vector<double> flips, rounds;
  for (Backend b : {Backend::cpu, Backend::cuda}) {
    auto s = initial(0.5, 3000, 5);
    Pipeline p(*s, b);
    Runner r(*s, b);
    for (int k = 0; k < 30; ++k) {
      brownian_step(*s, 0.02, 0.02, std::uint64_t(k));
      p.step(r, std::uint64_t(k));
    }
    he.push_back(topology(*s).he);
    // One Lawson run on a sheared triangulation: its result and metrics.
    auto flip_back = [&](std::unique_ptr<State> sh) {
      auto lawson = make_stage("delaunay.lawson", b);
      lawson->configure(*sh);
      Runner r2(*sh, b);
      REQUIRE_FALSE(r2.run(*lawson).rollback);
      he.push_back(topology(*sh).he);
      flips.push_back(r2.metric("lawson_flips"));
      rounds.push_back(r2.metric("lawson_rounds"));
    };
    flip_back(sheared(1.5));
    // A larger shear: on CUDA the tail kernel's cluster (at this size) runs every round, however
    // many edges one marks, when nothing can roll the step back, as here.
    flip_back(sheared(25, 40000));  // ~21,700 flips in 9 rounds
  }
  CHECK(he[0] == he[3]);
  CHECK(he[1] == he[4]);
  CHECK(he[2] == he[5]);
  // The metrics come from after_step on CUDA (the counters the tail kernel wrote to the host).
  CHECK(flips[0] == flips[2]);
  CHECK(rounds[0] == rounds[2]);
  CHECK(flips[1] == flips[3]);
  CHECK(rounds[1] == rounds[3]);
  CHECK(flips[1] > 10000);
}

namespace {
std::int32_t candidates_status(State& s) { return status_of(s)[ff::delaunay::kCandidates]; }

// The sheared set-up, but through detect_inversion: `amplitude` decides how many edges it lists.
std::unique_ptr<State> sheared_detected(double amplitude, Backend b, Runner*& r, std::unique_ptr<Stage>& detect) {
  auto s = sheared(amplitude);
  detect = make_stage("delaunay.detect_inversion", b);
  detect->configure(*s);
  r = new Runner(*s, b);
  REQUIRE_FALSE(r->run(*detect, 1).rollback);
  return s;
}
}  // namespace

TEST_CASE("lawson: the first round from detect_inversion's candidates gives the full pass's triangulation",
          "[delaunay][lawson]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  INFO("backend " << to_string(b));
  // Two copies, stepped identically; B's candidate list is withdrawn before every Lawson, so B
  // tests every edge in round 0 (the path before candidates existed).
  auto a = initial(0.5, 3000, 23), c = initial(0.5, 3000, 23);
  Pipeline pa(*a, b), pc(*c, b);
  Runner ra(*a, b), rc(*c, b);
  double listed = 0, used = 0;
  for (int k = 0; k < 60; ++k) {
    brownian_step(*a, 0.02, 0.02, std::uint64_t(k));
    brownian_step(*c, 0.02, 0.02, std::uint64_t(k));
    for (auto [s, p, r] : {std::tuple{a.get(), &pa, &ra}, std::tuple{c.get(), &pc, &rc}}) {
      REQUIRE_FALSE(r->run(*p->detect, k).rollback);
      if (s == a.get()) {
        listed += r->metric("lawson_candidates");
        used += candidates_status(*s) > 0;
      } else {
        status_of(*s)[ff::delaunay::kCandidates] = 0;
      }
      REQUIRE_FALSE(r->run(*p->flip, k).rollback);
      REQUIRE_FALSE(r->run(*p->lawson, k).rollback);
      CHECK(candidates_status(*s) == 0);  // consumed
    }
    REQUIRE(topology(*a).he == topology(*c).he);
  }
  INFO("candidates listed " << listed << ", steps that used them " << used);
  CHECK(listed > 0);
  CHECK(used > 30);
  require_delaunay(*a);
}

TEST_CASE("lawson: candidates are not trusted after positions moved, or when the list overflowed",
          "[delaunay][lawson]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  INFO("backend " << to_string(b));
  auto lawson = make_stage("delaunay.lawson", b);
  std::unique_ptr<Stage> detect;
  Runner* raw = nullptr;
  SECTION("positions moved between detection and Lawson") {
    // Detection on a Delaunay triangulation lists (almost) nothing; then a shear the detection
    // never saw. Lawson must notice (positions differ from position_prev) and test every edge.
    auto s = sheared_detected(0.0, b, raw, detect);
    std::unique_ptr<Runner> r(raw);
    REQUIRE(candidates_status(*s) > 0);
    CHECK(r->metric("lawson_candidates") == 0);
    auto xy = positions(*s);
    for (std::size_t i = 0; i < s->n(); ++i) xy[2 * i] += 1.5 * std::sin(2 * M_PI * xy[2 * i + 1] / 40);
    set_positions(*s, xy);
    lawson->configure(*s);
    REQUIRE_FALSE(r->run(*lawson, 1).rollback);
    CHECK(r->metric("lawson_flips") > 100);
    require_valid(*s);
    require_delaunay(*s);
  }
  SECTION("more candidates than the list holds") {
    // A square lattice (every quad co-circular, build picks either diagonal) jiggled by 1e-6:
    // about half the diagonals are now the wrong one, far more than the list holds.
    auto s = make_state(square_lattice(60, 60, 1.0), 60, 60);
    auto build = make_stage("delaunay.build", Backend::cpu);
    build->configure(*s);
    Runner rb(*s, Backend::cpu);
    REQUIRE_FALSE(rb.run(*build).rollback);
    auto xy = positions(*s);
    const RngKey key = make_rng_key(9, "jiggle");
    for (std::size_t i = 0; i < xy.size(); ++i) xy[i] += 1e-6 * (uniform01(key, std::uint32_t(i), 0, 0, 0) - 0.5);
    set_positions(*s, xy);
    detect = make_stage("delaunay.detect_inversion", b);
    detect->configure(*s);
    Runner r(*s, b);
    REQUIRE_FALSE(r.run(*detect, 1).rollback);
    const double listed = r.metric("lawson_candidates");
    INFO("listed " << listed << ", capacity " << ff::delaunay::candidate_capacity(s->n()));
    REQUIRE(listed > double(ff::delaunay::candidate_capacity(s->n())));
    CHECK(candidates_status(*s) == 0);
    lawson->configure(*s);
    REQUIRE_FALSE(r.run(*lawson, 1).rollback);
    CHECK(r.metric("lawson_flips") >= listed / 2);
    require_valid(*s);
    require_delaunay(*s);
  }
  SECTION("a few candidates, used") {
    auto s = sheared_detected(0.3, b, raw, detect);
    std::unique_ptr<Runner> r(raw);
    const double listed = r->metric("lawson_candidates");
    INFO("listed " << listed);
    REQUIRE(listed > 0);
    REQUIRE(candidates_status(*s) == std::int32_t(listed) + 1);
    lawson->configure(*s);
    REQUIRE_FALSE(r->run(*lawson, 1).rollback);
    CHECK(r->metric("lawson_flips") > 0);
    require_valid(*s);
    require_delaunay(*s);
  }
}
