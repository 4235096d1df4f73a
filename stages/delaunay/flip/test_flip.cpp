// delaunay.flip alone: repairs marked inversions (Carter et al. 2017 figs. 5–6) by parallel,
// conflict-free flips; conflicting repairs on one triangle take two rounds; with detection in
// front, random large moves either end in a valid triangulation or in a rollback, never in an
// inverted triangle.
#include "core/base/error.h"
#include "stages/delaunay/test_support.h"

using namespace ff;
using namespace ff::test::dl;

namespace {
void mark_by_hand(State& s, const std::vector<int>& edges) {
  Field& f = s.field(ff::delaunay::fields::flip_mark);
  f.acquire(Where::host, Mode::write);
  std::fill(f.host<std::uint8_t>(), f.host<std::uint8_t>() + f.size(), std::uint8_t(0));
  for (int e : edges) f.host<std::uint8_t>()[e] = 1;
  status_of(s)[ff::delaunay::kPending] = int(edges.size());
}
}  // namespace

TEST_CASE("flip: one vertex across one edge is repaired by one flip (fig. 5)", "[delaunay][flip]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  Scene sc(p);
  const auto f = sc.fan(45);
  sc.cross_one_edge(f);
  mark_by_hand(*sc.s, {f.pq});
  auto st = make_stage("delaunay.flip", b, p);
  st->configure(*sc.s);
  Runner r(*sc.s, b);
  const Outcome o = r.run(*st);
  INFO(o.reason);
  REQUIRE_FALSE(o.rollback);
  CHECK(r.metric("flips") == 1);
  CHECK(r.metric("flip_rounds") == 1);
  CHECK(status_of(*sc.s)[ff::delaunay::kPending] == 0);
  require_valid(*sc.s);
  // The crossed edge (p, q) became (v, w).
  const Topo t = topology(*sc.s);
  const auto e = ff::delaunay::edge_set(t.he.data(), sc.n());
  CHECK(std::binary_search(e.begin(), e.end(), std::make_pair(std::min(f.v, f.w), std::max(f.v, f.w))));
  CHECK_FALSE(std::binary_search(e.begin(), e.end(), std::make_pair(std::min(f.p, f.q), std::max(f.p, f.q))));
}

TEST_CASE("flip: independent repairs run in one round", "[delaunay][flip]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  Scene sc(Precision::f64, 20, 20);
  std::vector<int> edges;
  for (int v : {21, 66, 111, 156, 201, 246, 291, 336}) {
    const auto f = sc.fan(v);
    sc.cross_one_edge(f);
    edges.push_back(f.pq);
  }
  auto detect = make_stage("delaunay.detect_inversion", b);
  auto st = make_stage("delaunay.flip", b);
  detect->configure(*sc.s);
  st->configure(*sc.s);
  Runner r(*sc.s, b);
  REQUIRE_FALSE(r.run(*detect).rollback);
  CHECK(r.metric("inversions") == 8);
  REQUIRE_FALSE(r.run(*st).rollback);
  CHECK(r.metric("flips") == 8);
  CHECK(r.metric("flip_rounds") == 1);
  require_valid(*sc.s);
}

TEST_CASE("flip: two repairs on one triangle: the lower edge id goes first", "[delaunay][flip]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  Scene sc;
  // Triangle T = (q, p, w) beyond v's edge (p, q). v crosses (p, q) into T near that edge; u, the
  // vertex beyond (q, w), crosses (q, w) into T near that edge. Both edges are marked and share T.
  const auto f = sc.fan(45);
  const int u = f.z;
  sc.move(f.v, sc.lerp(sc.mid(f.v, f.p, f.q), sc.near(f.v, f.w), 0.12));
  sc.move(u, sc.lerp(sc.mid(u, f.q, f.w), sc.near(u, f.p), 0.12));
  auto detect = make_stage("delaunay.detect_inversion", b);
  auto st = make_stage("delaunay.flip", b);
  detect->configure(*sc.s);
  st->configure(*sc.s);
  Runner r(*sc.s, b);
  const Outcome od = r.run(*detect);
  INFO(od.reason);
  REQUIRE_FALSE(od.rollback);
  CHECK(r.metric("inversions") == 2);
  CHECK(r.metric("repairable") == 2);
  const Outcome o = r.run(*st);
  INFO(o.reason);
  REQUIRE_FALSE(o.rollback);
  CHECK(r.metric("flips") == 2);
  CHECK(r.metric("flip_rounds") == 2);
  require_valid(*sc.s);
}

TEST_CASE("flip: nothing pending, nothing done", "[delaunay][flip]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  Scene sc;
  const Topo before = topology(*sc.s);
  auto st = make_stage("delaunay.flip", b);
  st->configure(*sc.s);
  Runner r(*sc.s, b);
  REQUIRE_FALSE(r.run(*st).rollback);
  CHECK(r.metric("flips") == 0);
  CHECK(topology(*sc.s).he == before.he);
}

TEST_CASE("flip: random large moves end valid or rolled back, never inverted", "[delaunay][flip]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  int repaired = 0, rolled_back = 0, untouched = 0;
  for (std::uint32_t trial = 0; trial < 80; ++trial) {
    Scene sc;
    const RngKey key = make_rng_key(trial, "moves");
    auto xy = sc.xy;
    // Even trials: every particle moves (std 0.12 .. 0.44 of the spacing); odd trials:
    // a few particles jump far (std 0.55).
    const bool all = trial % 2 == 0;
    const double amp = all ? 0.12 + 0.004 * trial : 0.55;
    for (std::size_t i = 0; i < sc.n(); ++i) {
      if (!all && uniform01(key, std::uint32_t(i), trial, 1, 0) > 0.06) continue;
      double z[2];
      gaussians(key, std::uint32_t(i), trial, 0, 0, 2, z);
      xy[2 * i] += amp * z[0];
      xy[2 * i + 1] += amp * z[1];
    }
    set_positions(*sc.s, xy);
    auto detect = make_stage("delaunay.detect_inversion", b);
    auto st = make_stage("delaunay.flip", b);
    detect->configure(*sc.s);
    st->configure(*sc.s);
    Runner r(*sc.s, b);
    if (r.run(*detect).rollback) {
      ++rolled_back;
      continue;
    }
    const double inv = r.metric("inversions");
    if (r.run(*st).rollback) {
      ++rolled_back;
      continue;
    }
    inv > 0 ? ++repaired : ++untouched;
    require_valid(*sc.s);
  }
  INFO("repaired " << repaired << ", rolled back " << rolled_back << ", untouched " << untouched);
  CHECK(repaired > 0);
  CHECK(rolled_back > 0);
}
