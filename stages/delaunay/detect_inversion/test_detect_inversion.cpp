// delaunay.detect_inversion alone, on hand-made moves of Carter et al. 2017 figs. 4–6: a vertex
// across one edge is marked for a flip; across two edges, through another particle, or an edge
// crossed from both sides requests a rollback naming the particles.
#include "core/base/error.h"
#include <algorithm>

#include "stages/delaunay/detect_inversion/kernel.h"
#include "stages/delaunay/test_support.h"

using namespace ff;
using namespace ff::test::dl;

namespace {
std::vector<std::uint8_t> marks(State& s) {
  Field& f = s.field(ff::delaunay::fields::flip_mark);
  f.acquire(Where::host, Mode::read);
  return std::vector<std::uint8_t>(f.host<std::uint8_t>(), f.host<std::uint8_t>() + f.size());
}
bool contains(const std::vector<std::uint64_t>& v, int x) { return std::find(v.begin(), v.end(), std::uint64_t(x)) != v.end(); }
}  // namespace

TEST_CASE("detect_inversion: nothing moved, nothing found", "[delaunay][detect]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  Scene sc;
  auto st = make_stage("delaunay.detect_inversion", b);
  st->configure(*sc.s);
  Runner r(*sc.s, b);
  const Outcome o = r.run(*st);
  CHECK_FALSE(o.rollback);
  CHECK(r.metric("inversions") == 0);
  CHECK(status_of(*sc.s)[ff::delaunay::kPending] == 0);
  const auto m = marks(*sc.s);
  CHECK(std::count(m.begin(), m.end(), 1) == 0);
}

TEST_CASE("detect_inversion: one vertex across one edge is marked for a flip (fig. 5)", "[delaunay][detect]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  Scene sc(p);
  const auto f = sc.fan(45);
  sc.cross_one_edge(f);
  auto st = make_stage("delaunay.detect_inversion", b, p);
  st->configure(*sc.s);
  Runner r(*sc.s, b);
  const Outcome o = r.run(*st);
  INFO(o.reason);
  REQUIRE_FALSE(o.rollback);
  CHECK(r.metric("inversions") == 1);
  CHECK(r.metric("repairable") == 1);
  const auto m = marks(*sc.s);
  CHECK(std::count(m.begin(), m.end(), 1) == 1);
  CHECK(m[f.pq] == 1);
  CHECK(status_of(*sc.s)[ff::delaunay::kPending] == 1);
  // position_prev now holds the accepted positions (the next step's r0).
  Field& prev = sc.s->field(ff::delaunay::fields::position_prev);
  prev.acquire(Where::host, Mode::read);
  const auto xy = positions(*sc.s);
  for (std::size_t i = 0; i < xy.size(); ++i)
    REQUIRE((p == Precision::f64 ? prev.host<double>()[i] : double(prev.host<float>()[i])) == xy[i]);
}

TEST_CASE("detect_inversion: a vertex across two edges requests a rollback (fig. 6)", "[delaunay][detect]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  // Fig. 6: v crosses (p, q) and then (q, w) of the triangle T = (q, p, w), passing close to q.
  // In a lattice that turns v around q by more than 90 degrees (the r0.r1 test fires first), so
  // look for a vertex of a random point set whose two triangles at q are thin enough that every
  // edge of v keeps r0.r1 > 0: then only the inversion analysis can catch it.
  const double L = 14;
  int found = 0;
  for (std::uint64_t seed = 1; seed <= 20 && found < 3; ++seed) {
    Scene sc(Precision::f64, 10, 10);
    sc.s = make_state(random_points(196, L, L, seed), L, L);
    auto build = make_stage("delaunay.build", Backend::cpu);
    build->configure(*sc.s);
    Runner rb(*sc.s, Backend::cpu);
    REQUIRE_FALSE(rb.run(*build).rollback);
    sc.t = topology(*sc.s);
    sc.xy = positions(*sc.s);
    for (int v = 0; v < int(sc.n()) && found < 3; ++v) {
      const auto f = sc.fan(v);
      // Just past (q, w), 30% of the way from q to w.
      const auto q = sc.near(f.v, f.q), w = sc.near(f.v, f.w), z = sc.near(f.v, f.z);
      const auto on = sc.lerp(q, w, 0.3);
      const std::array<double, 2> to{on[0] + 0.05 * (z[0] - on[0]), on[1] + 0.05 * (z[1] - on[1])};
      const auto from = sc.near(f.v, f.v);
      bool keeps_sign = true;
      for (int h = 0; h < int(6 * sc.n()); ++h) {
        if (sc.origin(h) != v) continue;
        const auto y = sc.near(f.v, sc.origin(h ^ 1));
        keeps_sign = keeps_sign && (y[0] - from[0]) * (y[0] - to[0]) + (y[1] - from[1]) * (y[1] - to[1]) > 0.05;
      }
      if (!keeps_sign) continue;
      ++found;
      const auto saved = sc.xy;
      sc.move(v, to);
      auto st = make_stage("delaunay.detect_inversion", b);
      st->configure(*sc.s);
      Runner r(*sc.s, b);
      const Outcome o = r.run(*st);
      INFO("seed " << seed << ", v = " << v << ": " << o.reason);
      REQUIRE(o.rollback);
      CHECK(r.metric("inversions") >= 1);
      CHECK_THAT(o.reason, Catch::Contains("no single edge flip repairs it"));
      CHECK(contains(o.particles, f.v));
      CHECK(status_of(*sc.s)[ff::delaunay::kPending] == 0);
      sc.move(v, {saved[2 * v], saved[2 * v + 1]});
      REQUIRE_FALSE(rb.run(*build).rollback);  // the next candidate starts from a fresh build
      REQUIRE(topology(*sc.s).he == sc.t.he);
    }
  }
  CHECK(found == 3);
}

TEST_CASE("detect_inversion: particles through each other request a rollback", "[delaunay][detect]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  Scene sc;
  const auto f = sc.fan(45);
  // v jumps over its neighbour p: the edge vector v->p reverses (r0.r1 < 0).
  const auto v = sc.near(f.p, f.v), pp = sc.near(f.p, f.p);
  sc.move(f.v, {pp[0] + 0.3 * (pp[0] - v[0]), pp[1] + 0.3 * (pp[1] - v[1])});
  auto st = make_stage("delaunay.detect_inversion", b);
  st->configure(*sc.s);
  Runner r(*sc.s, b);
  const Outcome o = r.run(*st);
  INFO(o.reason);
  REQUIRE(o.rollback);
  CHECK_THAT(o.reason, Catch::Contains("passed through each other"));
  REQUIRE(o.particles.size() == 2);
  CHECK(contains(o.particles, f.v));
  CHECK(contains(o.particles, f.p));
}

TEST_CASE("detect_inversion: an edge crossed from both sides requests a rollback", "[delaunay][detect]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  Scene sc;
  const auto f = sc.fan(45);  // edge (p, q) between v and w: move both across it
  const auto m = sc.mid(f.p, f.p, f.q);
  const auto v = sc.near(f.p, f.v), w = sc.near(f.p, f.w);
  sc.move(f.v, sc.lerp(m, w, 0.25));
  sc.move(f.w, sc.lerp(m, v, 0.25));
  auto st = make_stage("delaunay.detect_inversion", b);
  st->configure(*sc.s);
  Runner r(*sc.s, b);
  const Outcome o = r.run(*st);
  INFO(o.reason);
  REQUIRE(o.rollback);
  CHECK_THAT(o.reason, Catch::Contains("crossed from both sides"));
  CHECK(contains(o.particles, f.p));
  CHECK(contains(o.particles, f.q));
}

TEST_CASE("detect_inversion: an edge longer than half the box is a RunError", "[delaunay][detect]") {
  // 4 x 4 square lattice: spacing = L/4. Shifting one row by 0.6 L makes the minimum image of
  // the edges to the next rows point the other way, so their triangles no longer close.
  auto s = make_state(square_lattice(4, 4, 1.0), 4.0, 4.0);
  auto build = make_stage("delaunay.build", Backend::cpu);
  build->configure(*s);
  Runner r(*s, Backend::cpu);
  REQUIRE_FALSE(r.run(*build).rollback);
  auto xy = positions(*s);
  for (int i = 0; i < 4; ++i) xy[2 * i] += 2.4;
  set_positions(*s, xy);
  auto st = make_stage("delaunay.detect_inversion", Backend::cpu);
  st->configure(*s);
  CHECK_THROWS_WITH(r.run(*st), Catch::Contains("longer than half the box"));
}

TEST_CASE("detect_inversion: builds the triangulation when none exists", "[delaunay][detect]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  const double L = 20;
  auto s = make_state(random_points(300, L, L, 9), L, L);
  auto st = make_stage("delaunay.detect_inversion", b);
  st->configure(*s);
  CHECK(status_of(*s)[ff::delaunay::kBuilt] == 0);
  Runner r(*s, b);
  REQUIRE_FALSE(r.run(*st).rollback);
  CHECK(status_of(*s)[ff::delaunay::kBuilt] == 1);
  CHECK(r.metric("inversions") == 0);
  require_valid(*s);
}

TEST_CASE("detect_inversion: the candidates' cheap in-circle determinant has incircle()'s sign", "[delaunay][detect]") {
  // Random convex-ish quads around an edge (a at the origin, c left, d right) at the scales of
  // a triangulation: wherever incircle() is clear of its rounding scale, the 3x3 form agrees.
  using namespace ff::delaunay;
  const RngKey key = make_rng_key(7, "incircle");
  int agree = 0, inside = 0;
  for (std::uint32_t i = 0; i < 200000; ++i) {
    auto u = [&](std::uint32_t k) { return uniform01(key, i, 0, 0, k); };
    const double scale = std::pow(10.0, 4 * u(0) - 2);  // edges 0.01 ... 100
    const V2 o{0, 0}, ab{scale * (0.5 + u(1)), scale * (u(2) - 0.5)};
    const V2 ac{scale * (2 * u(3) - 0.5), scale * (0.05 + u(4))}, ad{scale * (2 * u(5) - 0.5), -scale * (0.05 + u(6))};
    const double left = orient(o, ab, ac), right = orient(ab, o, ad);
    if (!(left > 0 && right > 0)) continue;  // not a quad around a valid edge
    double perm;
    const double ref = incircle(o, ab, ac, ad, perm);
    if (std::fabs(ref) <= 1e-12 * perm) continue;
    const double cheap = incircle_from_a(ab, ac, ad, left, right);
    agree += (cheap > 0) == (ref > 0);
    inside += ref > 0;
    if ((cheap > 0) != (ref > 0)) FAIL_CHECK("quad " << i << ": " << cheap << " vs " << ref << " (perm " << perm << ")");
  }
  INFO("agreeing " << agree << ", d inside " << inside);
  CHECK(agree > 100000);
  CHECK(inside > 10000);
  CHECK(agree - inside > 10000);
}

namespace {
// The CPU loop settles quiet edges four at a time (AVX2) and hands the others to
// MarkInversions::test; the result must be what test() alone gives for every edge: marks,
// counts, lowest event ids, the candidate set. Random moves of growing size make every kind of
// edge: quiet, Lawson candidates, crossed (marked), inverted twice, reversed, across the
// periodic boundary; edges come in groups of four, mixed.
template <class R>
void check_cpu_loop_against_test(double amplitude) {
  using namespace ff::delaunay;
  namespace df = ff::delaunay::fields;
  const Precision precision = sizeof(R) == 8 ? Precision::f64 : Precision::f32;
  Scene sc(precision, 24, 24);
  const RngKey key = make_rng_key(11, "moves");
  std::vector<double> xy = sc.xy;
  for (std::size_t i = 0; i < sc.n(); ++i)
    for (int k = 0; k < 2; ++k) {
      const double L = sc.s->box.L[k];
      double x = xy[2 * i + k] + amplitude * (2 * uniform01(key, std::uint32_t(i), 0, 0, std::uint32_t(k)) - 1);
      x -= L * std::floor(x / L);
      xy[2 * i + k] = x;
    }
  set_positions(*sc.s, xy);

  // The reference: test() edge by edge, on the host fields, before the stage writes anything.
  State& s = *sc.s;
  const std::size_t E = edge_count(s.n());
  for (const char* f : {df::halfedge, df::opposite, df::vertex_edge, df::position_prev})
    s.field(f).acquire(Where::host, Mode::read);
  const Mesh m{s.field(df::halfedge).host<std::int32_t>(), s.field(df::vertex_edge).host<std::int32_t>(),
               s.field(df::opposite).host<std::int32_t>()};
  const Points<R> pts{s.field(ff::fields::position).host<R>(), PeriodicBox<double>::make(s.box.L)};
  std::vector<std::uint8_t> ref_mark(E, 7);
  std::vector<unsigned> c(kInversionCounters, 0);
  for (int k = kThroughAt; k < kInversionCounters; ++k) c[std::size_t(k)] = ~0u;
  std::vector<std::int32_t> cand(E);
  const MarkInversions<R> f{m, pts, s.field(df::position_prev).host<R>(), ref_mark.data(), c.data(),
                                 cand.data(), unsigned(E), int(E)};
  std::vector<int> ref_cand;
  for (int e = 0; e < int(E); ++e)
    if (f.test(e)) ref_cand.push_back(e);
  INFO("amplitude " << amplitude << ": inverted " << c[kInverted] << ", marked " << c[kMarked] << ", through "
                    << c[kThrough] << ", twice " << c[kTwice] << ", candidates " << ref_cand.size());

  auto st = make_stage("delaunay.detect_inversion", Backend::cpu, precision);
  st->configure(s);
  Runner r(s, Backend::cpu);
  const Outcome o = r.run(*st);
  CHECK(marks(s) == ref_mark);
  CHECK(r.metric("inversions") == c[kInverted]);
  CHECK(r.metric("repairable") == c[kMarked]);
  CHECK(r.metric("lawson_candidates") == ref_cand.size());
  Field& lc = s.field(df::lawson_candidates);
  lc.acquire(Where::host, Mode::read);
  std::vector<int> got(lc.host<std::int32_t>(), lc.host<std::int32_t>() + std::min(ref_cand.size(), lc.count()));
  std::sort(got.begin(), got.end());
  CHECK(got == std::vector<int>(ref_cand.begin(), ref_cand.begin() + std::ptrdiff_t(got.size())));
  if (c[kThrough]) {  // the first reason checked, naming the ends of the lowest such edge
    REQUIRE(o.rollback);
    CHECK_THAT(o.reason, Catch::Contains("passed through each other") &&
                             Catch::Contains("; " + std::to_string(c[kThrough]) + " such pair(s))"));
    CHECK(contains(o.particles, m.origin(2 * int(c[kThroughAt]))));
  } else if (c[kTwice]) {
    REQUIRE(o.rollback);
    CHECK_THAT(o.reason, Catch::Contains("(both its triangles inverted; " + std::to_string(c[kTwice])));
  }
  // Each amplitude makes what it is meant to (so the comparison above covers it).
  if (amplitude == 0.02) CHECK(c[kInverted] == 0);
  if (amplitude >= 0.3) CHECK(ref_cand.size() > 20);
  if (amplitude >= 0.45) CHECK(c[kMarked] > 0);
  if (amplitude == 0.6) CHECK(c[kThrough] > 0);
}
}  // namespace

TEST_CASE("detect_inversion: the CPU loop agrees with the per-edge test on every edge", "[delaunay][detect]") {
  const double amplitude = GENERATE(0.02, 0.3, 0.45, 0.6);
  SECTION("double") { check_cpu_loop_against_test<double>(amplitude); }
  SECTION("float") { check_cpu_loop_against_test<float>(amplitude); }
}
