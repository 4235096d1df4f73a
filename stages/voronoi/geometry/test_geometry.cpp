// voronoi.geometry: the cells of lattices (exact values), of random states (CGAL's periodic
// Delaunay triangulation of the same points, Σ areas = box area, closure of every cell) and
// Poisson–Voronoi statistics (Okabe et al.), on every backend, and CPU == CUDA bit for bit.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Periodic_2_Delaunay_triangulation_2.h>
#include <CGAL/Periodic_2_Delaunay_triangulation_traits_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "stages/delaunay/test_support.h"
#include "stages/voronoi/geometry/stage.h"
#include "support/backends.h"
#include "support/fields.h"

namespace {

using namespace ff;
using ff::test::values;
namespace vf = ff::voronoi::fields;
namespace dl = ff::test::dl;

const Registry& registry() {
  static const std::unique_ptr<Registry> r = test::registry_of({"delaunay", "voronoi"});
  return *r;
}

std::unique_ptr<Stage> make(const std::string& name, Backend b, Precision p, const test::ParamSettings& set = {}) {
  return test::make_stage(registry(), name, b, p, 2, set);
}

// A state with the triangulation delaunay.build makes of xy (CPU; the topology fields then
// move to the device with the rest when a CUDA stage acquires them).
std::unique_ptr<State> built(const std::vector<double>& xy, double Lx, double Ly, Precision p = Precision::f64) {
  auto s = dl::make_state(xy, Lx, Ly, p);
  auto build = make("delaunay.build", Backend::cpu, p);
  build->configure(*s);
  test::StageDriver d(Backend::cpu, p, 2);
  REQUIRE_FALSE(d.run(*build, *s).rollback);
  return s;
}

// The settings that write the per-edge faces (off by default), for the tests that read them.
const test::ParamSettings with_faces{{"faces", true}};

// voronoi.geometry once on backend b; its metrics.
std::map<std::string, double> cells(State& s, Backend b, const test::ParamSettings& set = {}) {
  auto g = make("voronoi.geometry", b, s.precision(), set);
  g->configure(s);
  test::StageDriver d(b, s.precision(), 2);
  REQUIRE_FALSE(d.run(*g, s).rollback);
  return d.metrics.values();
}

std::vector<std::int32_t> ints(State& s, const char* name) {
  Field& f = s.field(name);
  f.acquire(Where::host, Mode::read);
  return std::vector<std::int32_t>(f.host<std::int32_t>(), f.host<std::int32_t>() + f.size());
}

double min_image(double d, double L) { return d - L * std::rint(d / L); }

// Σ_j A_ij e_ij for every cell i, e_ij = (r_i − r_j)/r_ij, from the face lengths per edge.
std::vector<double> closure(State& s) {
  const auto x = dl::positions(s);
  const auto A = values(s, vf::face_length);
  const auto he = dl::topology(s).he;
  std::vector<double> sum(2 * s.n(), 0.0);
  for (std::size_t e = 0; e < 3 * s.n(); ++e) {
    const int a = he[4 * e], b = he[4 * e + 2];
    const double dx = min_image(x[2 * a] - x[2 * b], s.box.L[0]), dy = min_image(x[2 * a + 1] - x[2 * b + 1], s.box.L[1]);
    const double r = std::hypot(dx, dy);
    sum[2 * a] += A[e] * dx / r, sum[2 * a + 1] += A[e] * dy / r;
    sum[2 * b] -= A[e] * dx / r, sum[2 * b + 1] -= A[e] * dy / r;
  }
  return sum;
}

// The cells of CGAL's periodic Delaunay triangulation of xy (square box L), computed apart from
// the stage: each triangle gives each corner the kite (corner, edge midpoint, circumcentre, edge
// midpoint), with CGAL's own circumcentre, in the triangle's unwrapped coordinates.
struct CgalCells {
  std::vector<double> area, perimeter, cx, cy;  // centroid relative to the site
  std::vector<int> sides;
};
CgalCells cgal_cells(const std::vector<double>& xy, double L) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  using Gt = CGAL::Periodic_2_Delaunay_triangulation_traits_2<K>;
  using Vb = CGAL::Triangulation_vertex_base_with_info_2<int, Gt, CGAL::Periodic_2_triangulation_vertex_base_2<Gt>>;
  using Tds = CGAL::Triangulation_data_structure_2<Vb, CGAL::Periodic_2_triangulation_face_base_2<Gt>>;
  using PDT = CGAL::Periodic_2_Delaunay_triangulation_2<Gt, Tds>;
  using P = K::Point_2;
  const std::size_t n = xy.size() / 2;
  PDT T(PDT::Iso_rectangle(0, 0, L, L));
  for (std::size_t i = 0; i < n; ++i) T.insert(P(xy[2 * i], xy[2 * i + 1]))->info() = int(i);
  if (!T.is_triangulation_in_1_sheet()) T.convert_to_1_sheeted_covering();
  REQUIRE(T.is_triangulation_in_1_sheet());
  CgalCells c{std::vector<double>(n), std::vector<double>(n), std::vector<double>(n), std::vector<double>(n),
              std::vector<int>(n)};
  auto cross = [](double ax, double ay, double bx, double by) { return ax * by - ay * bx; };
  for (auto f = T.faces_begin(); f != T.faces_end(); ++f) {
    const auto tri = T.triangle(T.periodic_triangle(f));
    const P o = CGAL::circumcenter(tri[0], tri[1], tri[2]);
    for (int k = 0; k < 3; ++k) {
      const P a = tri[k], b = tri[(k + 1) % 3], cc = tri[(k + 2) % 3];
      const int id = f->vertex(k)->info();
      // Relative to a: midpoints of ab and ac, circumcentre.
      const double mbx = 0.5 * (b.x() - a.x()), mby = 0.5 * (b.y() - a.y());
      const double mcx = 0.5 * (cc.x() - a.x()), mcy = 0.5 * (cc.y() - a.y());
      const double ox = o.x() - a.x(), oy = o.y() - a.y();
      const double t1 = 0.5 * cross(mbx, mby, ox, oy), t2 = 0.5 * cross(ox, oy, mcx, mcy);
      c.area[id] += t1 + t2;
      c.cx[id] += t1 * (mbx + ox) / 3 + t2 * (ox + mcx) / 3;
      c.cy[id] += t1 * (mby + oy) / 3 + t2 * (oy + mcy) / 3;
      // Signed half-faces: + when the circumcentre is on the triangle's side of the edge.
      const double hb = std::hypot(ox - mbx, oy - mby) * (cross(mbx, mby, ox, oy) >= 0 ? 1 : -1);
      const double hc = std::hypot(ox - mcx, oy - mcy) * (cross(ox, oy, mcx, mcy) >= 0 ? 1 : -1);
      c.perimeter[id] += hb + hc;
    }
  }
  for (auto v = T.vertices_begin(); v != T.vertices_end(); ++v) {
    auto circ = T.adjacent_vertices(v), end = circ;
    int deg = 0;
    do ++deg;
    while (++circ != end);
    c.sides[v->info()] = deg;
  }
  for (std::size_t i = 0; i < n; ++i) c.cx[i] /= c.area[i], c.cy[i] /= c.area[i];
  return c;
}

}  // namespace

TEST_CASE("voronoi.geometry: triangular lattice — area √3/2 a², faces a/√3, 6 sides, centroid = site", "[voronoi]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int nx = 16, ny = 16;
  const double a = 1.7;
  auto s = built(dl::triangular_lattice(nx, ny, a), nx * a, ny * a * std::sqrt(3.0) / 2);
  const auto m = cells(*s, b, with_faces);
  const auto x = dl::positions(*s);
  const auto area = values(*s, vf::area), per = values(*s, vf::perimeter), g = values(*s, vf::centroid);
  const auto faces = values(*s, vf::face_length);
  const auto sides = ints(*s, vf::sides);
  for (std::size_t i = 0; i < s->n(); ++i) {
    REQUIRE(area[i] == Approx(std::sqrt(3.0) / 2 * a * a).epsilon(1e-12));
    REQUIRE(per[i] == Approx(6 * a / std::sqrt(3.0)).epsilon(1e-12));
    REQUIRE(sides[i] == 6);
    REQUIRE(std::fabs(min_image(g[2 * i] - x[2 * i], s->box.L[0])) < 1e-12);
    REQUIRE(std::fabs(min_image(g[2 * i + 1] - x[2 * i + 1], s->box.L[1])) < 1e-12);
  }
  for (double A : faces) REQUIRE(A == Approx(a / std::sqrt(3.0)).epsilon(1e-12));
  CHECK(m.at("area_mean") == Approx(std::sqrt(3.0) / 2 * a * a).epsilon(1e-12));
  CHECK(std::fabs(m.at("area_variance")) < 1e-9);
  CHECK(m.at("sides_variance") == 0.0);
  CHECK(std::fabs(m.at("area_sum_error")) < 1e-12);
}

TEST_CASE("voronoi.geometry: square lattice — area a² whatever diagonals Lawson chose; the diagonals' faces 0",
          "[voronoi]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int n = 12;
  const double a = 1.3;
  auto s = built(dl::square_lattice(n, n, a), n * a, n * a);
  cells(*s, b, with_faces);
  const auto x = dl::positions(*s);
  const auto he = dl::topology(*s).he;
  const auto area = values(*s, vf::area), per = values(*s, vf::perimeter), faces = values(*s, vf::face_length);
  for (std::size_t i = 0; i < s->n(); ++i) {
    REQUIRE(area[i] == Approx(a * a).epsilon(1e-12));
    REQUIRE(per[i] == Approx(4 * a).epsilon(1e-12));
  }
  int diagonals = 0;
  for (std::size_t e = 0; e < 3 * s->n(); ++e) {
    const int p = he[4 * e], q = he[4 * e + 2];
    const double r = std::hypot(min_image(x[2 * p] - x[2 * q], s->box.L[0]), min_image(x[2 * p + 1] - x[2 * q + 1], s->box.L[1]));
    if (r > 1.2 * a) {
      ++diagonals;
      REQUIRE(std::fabs(faces[e]) < 1e-12 * a);
    } else {
      REQUIRE(faces[e] == Approx(a).epsilon(1e-12));
    }
  }
  CHECK(diagonals == int(s->n()));  // one diagonal per square
}

TEST_CASE("voronoi.geometry: random states equal CGAL's periodic Voronoi cells; Σ areas = box; every cell closes",
          "[voronoi]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const std::uint64_t seed = GENERATE(1, 2, 3);
  const std::size_t n = 1500;
  const double L = std::sqrt(double(n));
  const auto xy = dl::random_points(n, L, L, seed);
  auto s = built(xy, L, L);
  const auto m = cells(*s, b, with_faces);
  const auto x = dl::positions(*s);
  const CgalCells ref = cgal_cells(x, L);
  const auto area = values(*s, vf::area), per = values(*s, vf::perimeter), g = values(*s, vf::centroid);
  const auto sides = ints(*s, vf::sides);
  double total = 0;
  for (std::size_t i = 0; i < n; ++i) {
    INFO("particle " << i);
    REQUIRE(std::fabs(area[i] - ref.area[i]) < 1e-10);
    REQUIRE(std::fabs(per[i] - ref.perimeter[i]) < 1e-10);
    REQUIRE(sides[i] == ref.sides[i]);
    REQUIRE(std::fabs(min_image(g[2 * i] - x[2 * i], L) - ref.cx[i]) < 1e-10);
    REQUIRE(std::fabs(min_image(g[2 * i + 1] - x[2 * i + 1], L) - ref.cy[i]) < 1e-10);
    total += area[i];
  }
  CHECK(std::fabs(total / (L * L) - 1) < 1e-12);
  CHECK(std::fabs(m.at("area_sum_error")) < 1e-12);
  CHECK(m.at("area_mean") == Approx(1.0).epsilon(1e-12));
  for (double c : closure(*s)) REQUIRE(std::fabs(c) < 1e-12);
  // Every face of a Delaunay edge is ≥ 0 (up to rounding).
  for (double A : values(*s, vf::face_length)) REQUIRE(A > -1e-12);
}

TEST_CASE("voronoi.geometry: Poisson–Voronoi statistics at N = 2e5 (Okabe et al.: var(area) 0.280, perimeter 4, "
          "sides 6, var(sides) 1.781, within 1 %)",
          "[voronoi]") {
  const std::size_t n = 200000;
  const double L = std::sqrt(double(n));
  auto s = built(dl::random_points(n, L, L, 11), L, L);
  const auto m = cells(*s, Backend::cpu);
  const auto area = values(*s, vf::area), per = values(*s, vf::perimeter);
  const auto sides = ints(*s, vf::sides);
  double a1 = 0, a2 = 0, p1 = 0, s1 = 0, s2 = 0;
  for (std::size_t i = 0; i < n; ++i) {
    a1 += area[i], a2 += area[i] * area[i], p1 += per[i];
    s1 += sides[i], s2 += double(sides[i]) * sides[i];
  }
  a1 /= n, a2 /= n, p1 /= n, s1 /= n, s2 /= n;
  CHECK(a1 == Approx(1.0).epsilon(1e-12));
  CHECK(a2 - a1 * a1 == Approx(0.280).epsilon(0.01));
  CHECK(p1 == Approx(4.0).epsilon(0.01));
  CHECK(s1 == 6.0);  // exact on the torus
  CHECK(s2 - s1 * s1 == Approx(1.781).epsilon(0.01));
  // The metrics (integer sums) agree with the sums above.
  CHECK(m.at("area_variance") == Approx(a2 - a1 * a1).epsilon(1e-6));
  CHECK(m.at("sides_variance") == Approx(s2 - s1 * s1).epsilon(1e-12));
  CHECK(std::fabs(m.at("area_sum_error")) < 1e-12);
}

TEST_CASE("voronoi.geometry: positions delaunay (position_prev) or current", "[voronoi]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const std::size_t n = 600;
  const double L = std::sqrt(double(n));
  auto xy = dl::random_points(n, L, L, 5);
  auto s = built(xy, L, L);
  cells(*s, b);
  const auto before = values(*s, vf::area);
  // Small moves that keep every triangle positive: position_prev keeps the built positions.
  const RngKey key = make_rng_key(9, "voronoi-move");
  for (std::size_t i = 0; i < xy.size(); ++i) xy[i] += 0.01 * (uniform01(key, std::uint32_t(i), 0, 0, 0) - 0.5);
  dl::set_positions(*s, xy);
  cells(*s, b);
  CHECK(values(*s, vf::area) == before);  // the cells of delaunay.position_prev, bit for bit
  const auto m = cells(*s, b, {{"positions", std::string("current")}, {"faces", true}});
  const auto now = values(*s, vf::area);
  CHECK(now != before);
  CHECK(std::fabs(m.at("area_sum_error")) < 1e-12);  // the cells of the moved points still tile the box
  for (double c : closure(*s)) REQUIRE(std::fabs(c) < 1e-12);
}

TEST_CASE("voronoi.geometry: single precision stores the double computation rounded", "[voronoi]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const std::size_t n = 400;
  const double L = std::sqrt(double(n));
  const auto xy = dl::random_points(n, L, L, 4);
  auto s64 = built(xy, L, L);
  auto s32 = built(dl::positions(*s64), L, L, Precision::f32);
  cells(*s64, b);
  cells(*s32, b);
  const auto a64 = values(*s64, vf::area), a32 = values(*s32, vf::area);
  for (std::size_t i = 0; i < n; ++i) REQUIRE(a32[i] == Approx(a64[i]).epsilon(1e-4));
}

// The metrics come from integer terms summed in the cells' pass (on CUDA per block, then the last
// block publishes the totals and zeroes its words for the next call): they must equal the same
// fixed-point sums taken here over the stored fields, exactly, call after call.
TEST_CASE("voronoi.geometry: the metrics are the fixed-point sums of the stored cells, on every call", "[voronoi]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const std::size_t n = 5000;  // 20 blocks of 256 threads on CUDA
  const double L = 1.3 * std::sqrt(double(n));
  auto s = built(dl::random_points(n, L, L, 21), L, L);
  auto g = make("voronoi.geometry", b, s->precision());
  g->configure(*s);
  test::StageDriver d(b, s->precision(), 2);
  const int log2n = int(std::ceil(std::log2(double(n))));
  const double mean = L * L / double(n), one = std::ldexp(1.0, 61 - log2n), one2 = std::ldexp(1.0, 61 - 2 * log2n);
  for (int call = 0; call < 3; ++call) {
    INFO("call " << call);
    REQUIRE_FALSE(d.run(*g, *s).rollback);
    const auto m = d.metrics.values();
    const auto area = values(*s, vf::area);
    const auto sides = ints(*s, vf::sides);
    std::int64_t q = 0, q2 = 0, s2 = 0;
    for (std::size_t i = 0; i < n; ++i) {
      q += std::int64_t(std::rint(area[i] * (one / mean)));
      const double a = area[i] * (1.0 / mean);
      q2 += std::int64_t(std::rint(a * a * one2));
      s2 += std::int64_t(sides[i]) * sides[i];
    }
    const double qm = double(q) / one / double(n);
    CHECK(m.at("area_mean") == qm * mean);
    CHECK(m.at("area_variance") == double(q2) / one2 / double(n) - qm * qm);
    CHECK(m.at("sides_variance") == double(s2) / double(n) - 36.0);
    CHECK(m.at("area_sum_error") == qm - 1.0);
    CHECK(std::fabs(m.at("area_sum_error")) < 1e-12);
  }
}

TEST_CASE("voronoi.geometry: a fan that does not close stops the run (metrics on) or gives sides 0", "[voronoi]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const std::size_t n = 3000;
  const double L = std::sqrt(double(n));
  auto s = built(dl::random_points(n, L, L, 3), L, L);
  {  // particle 1234 names a half-edge that does not exist
    Field& ve = s->field("delaunay.vertex_edge");
    ve.acquire(Where::host, Mode::readwrite);
    ve.host<std::int32_t>()[1234] = std::int32_t(6 * n + 5);
  }
  test::StageDriver d(b, s->precision(), 2);
  auto quiet = make("voronoi.geometry", b, s->precision(), {{"metrics", false}});
  quiet->configure(*s);
  REQUIRE_FALSE(d.run(*quiet, *s).rollback);
  const auto sides = ints(*s, vf::sides);
  CHECK(sides[1234] == 0);
  CHECK(std::count(sides.begin(), sides.end(), 0) == 1);
  auto g = make("voronoi.geometry", b, s->precision());
  g->configure(*s);
  CHECK_THROWS_WITH(d.run(*g, *s), Catch::Contains("1 particle(s) do not form a closed fan"));
}

// delaunay.build names each vertex's lowest half-edge, where the cells' second walk starts:
// name another (v mod 4 steps on in the fan), as after flips, so that it starts mid-fan.
void start_walks_mid_fan(State& s) {
  Field& he = s.field(ff::delaunay::fields::halfedge);
  Field& ve = s.field(ff::delaunay::fields::vertex_edge);
  he.acquire(Where::host, Mode::read);
  ve.acquire(Where::host, Mode::readwrite);
  const std::int32_t* h = he.host<std::int32_t>();
  std::int32_t* vedge = ve.host<std::int32_t>();
  for (std::size_t v = 0; v < s.n(); ++v)
    for (std::size_t k = 0; k < v % 4; ++k) vedge[v] = h[2 * (vedge[v] ^ 1) + 1];
}

// cell() as geometry/cuda.cu runs it, the fan's far ends kept between its two walks (here in a
// host array), must give the bits of the plain cell(), for fans that fit the cache and for
// longer ones (which walk again): every output and the metric terms.
template <int K>
struct HostFan {
  static constexpr int capacity = K;
  int* slots;
  void put(int k, int u) const { slots[k] = u; }
  int get(int k) const { return slots[k]; }
};

// Returns how many fans fit the cache.
template <int K>
int same_cells_with_cache(State& s) {
  const std::size_t n = s.n();
  const auto x = dl::positions(s);
  start_walks_mid_fan(s);
  const auto t = dl::topology(s);
  struct Out {
    std::vector<double> area, per, g, A, m, o;
    std::vector<std::int32_t> sides;
    std::vector<voronoi::MetricTerms> terms;
    explicit Out(std::size_t n)
        : area(n), per(n), g(2 * n), A(3 * n), m(6 * n), o(12 * n), sides(n), terms(n) {}
  };
  int fits = 0;
  for (const bool edges : {false, true}) {
    INFO((edges ? "faces and circumcentres" : "cells only") << ", cache of " << K);
    Out plain(n), cached(n);
    auto geometry = [&](Out& out) {
      return voronoi::CellGeometry<double>{t.he.data(), t.vedge.data(), {x.data(), PeriodicBox<double>::make(s.box.L)},
                                           int(n), out.area.data(), out.per.data(), out.g.data(), out.sides.data(),
                                           edges ? out.A.data() : nullptr, edges ? out.m.data() : nullptr,
                                           edges ? out.o.data() : nullptr, {1e6, 1.0, 1e6}};
    };
    const auto f = geometry(plain), fc = geometry(cached);
    int slots[K];
    fits = 0;
    for (std::size_t v = 0; v < n; ++v) {
      plain.terms[v] = f.cell(int(v));
      // Edges = false as geometry/cuda.cu instantiates it when nothing is written per edge.
      cached.terms[v] = edges ? fc.template cell<true>(int(v), HostFan<K>{slots})
                              : fc.template cell<false>(int(v), HostFan<K>{slots});
      fits += plain.sides[v] <= K;
    }
    CHECK(std::memcmp(plain.area.data(), cached.area.data(), n * sizeof(double)) == 0);
    CHECK(std::memcmp(plain.per.data(), cached.per.data(), n * sizeof(double)) == 0);
    CHECK(std::memcmp(plain.g.data(), cached.g.data(), 2 * n * sizeof(double)) == 0);
    CHECK(plain.sides == cached.sides);
    CHECK(plain.A == cached.A);
    CHECK(plain.m == cached.m);
    CHECK(plain.o == cached.o);
    for (std::size_t v = 0; v < n; ++v) {
      REQUIRE(plain.terms[v].area == cached.terms[v].area);
      REQUIRE(plain.terms[v].area2 == cached.terms[v].area2);
      REQUIRE(plain.terms[v].sides2 == cached.terms[v].sides2);
    }
  }
  return fits;
}

TEST_CASE("voronoi.geometry: cell() with the far ends cached gives the bits of cell() without", "[voronoi]") {
  const std::size_t n = 3000;
  const double L = std::sqrt(double(n));
  auto s = built(dl::random_points(n, L, L, 31), L, L);
  const int fit6 = same_cells_with_cache<6>(*s);
  CHECK(fit6 > int(n) / 4);  // both walks taken
  CHECK(fit6 < int(n) * 3 / 4);
  CHECK(same_cells_with_cache<voronoi::kFanCache>(*s) > int(n) * 99 / 100);
}

// A site ringed by m points has a cell of m sides, a regular m-gon of apothem r/2: fans around
// kFanCache (CUDA keeps the far ends of at most that many) and a long one, on every backend, and
// on CUDA the CPU's bits with the cells only (the cached walk) and with every per-edge output.
TEST_CASE("voronoi.geometry: fans longer than the CUDA loop's cache give the same cells", "[voronoi]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int m = GENERATE(voronoi::kFanCache - 1, voronoi::kFanCache, voronoi::kFanCache + 1, 40);
  const std::size_t n = 1500;
  const double L = std::sqrt(double(n)), cx = 0.5 * L, cy = 0.5 * L, r = 1.5;
  std::vector<double> xy{cx, cy};  // the site first: particle 0
  const RngKey key = make_rng_key(17, "voronoi-ring");
  for (int k = 0; k < m; ++k) {  // radii jittered by 1e-4: no four points on one circle
    const double t = 2 * M_PI * k / m, rk = r * (1 + 1e-4 * (uniform01(key, std::uint32_t(k), 0, 0, 0) - 0.5));
    xy.push_back(cx + rk * std::cos(t));
    xy.push_back(cy + rk * std::sin(t));
  }
  for (std::size_t i = 0; xy.size() < 2 * n; ++i) {  // the rest at least 2r from the site
    const auto p = dl::random_points(1, L, L, 100 + i);
    if (std::hypot(p[0] - cx, p[1] - cy) > 2 * r) xy.insert(xy.end(), p.begin(), p.end());
  }
  for (const bool edges : {false, true}) {
    INFO(m << " sides, " << (edges ? "faces and circumcentres" : "cells only"));
    const test::ParamSettings set{{"faces", edges}, {"circumcenters", edges}};
    auto s = built(xy, L, L);
    const auto met = cells(*s, b, set);
    const auto area = values(*s, vf::area), per = values(*s, vf::perimeter);
    const auto sides = ints(*s, vf::sides);
    CHECK(sides[0] == m);
    const double apothem = 0.5 * r, side = 2 * apothem * std::tan(M_PI / m);
    CHECK(area[0] == Approx(0.5 * m * side * apothem).epsilon(1e-3));
    CHECK(per[0] == Approx(m * side).epsilon(1e-3));
    CHECK(std::fabs(met.at("area_sum_error")) < 1e-12);
    if (edges)
      for (double c : closure(*s)) REQUIRE(std::fabs(c) < 1e-12);
    if (b != Backend::cuda) continue;
    auto cpu = built(xy, L, L);
    CHECK(cells(*cpu, Backend::cpu, set) == met);
    std::vector<const char*> names{vf::area, vf::perimeter, vf::centroid, vf::sides};
    if (edges) names.insert(names.end(), {vf::face_length, vf::face_midpoint, vf::circumcenter});
    for (const char* f : names) {
      INFO(f);
      Field &a = cpu->field(f), &c = s->field(f);
      a.acquire(Where::host, Mode::read);
      c.acquire(Where::host, Mode::read);
      REQUIRE(a.bytes() == c.bytes());
      REQUIRE(std::memcmp(a.host_raw(), c.host_raw(), a.bytes()) == 0);
    }
  }
}

TEST_CASE("voronoi.geometry: CPU and CUDA give the same bits", "[voronoi][cuda]") {
  if (!test::have_cuda("voronoi.geometry CPU vs CUDA")) return;
  const std::size_t n = 5000;
  const double L = std::sqrt(double(n));
  const auto xy = dl::random_points(n, L, L, 8);
  // The cells alone (the default) and with every per-edge output: the CUDA loop may take another
  // path when it writes nothing per edge.
  for (const bool edges : {false, true})
    for (Precision p : {Precision::f64, Precision::f32}) {
      INFO((edges ? "faces and circumcentres" : "cells only") << (p == Precision::f64 ? ", double" : ", float"));
      const test::ParamSettings set{{"faces", edges}, {"circumcenters", edges}};
      auto cpu = built(xy, L, L, p), gpu = built(xy, L, L, p);
      start_walks_mid_fan(*cpu);
      start_walks_mid_fan(*gpu);
      const auto mc = cells(*cpu, Backend::cpu, set), mg = cells(*gpu, Backend::cuda, set);
      CHECK(mc == mg);
      std::vector<const char*> names{vf::area, vf::perimeter, vf::centroid, vf::sides};
      if (edges) names.insert(names.end(), {vf::face_length, vf::face_midpoint, vf::circumcenter});
      for (const char* f : names) {
        INFO(f);
        Field &a = cpu->field(f), &c = gpu->field(f);
        a.acquire(Where::host, Mode::read);
        c.acquire(Where::host, Mode::read);
        REQUIRE(a.bytes() == c.bytes());
        REQUIRE(std::memcmp(a.host_raw(), c.host_raw(), a.bytes()) == 0);
      }
    }
}
