// delaunay.triangles (observer): the field delaunay.triangles holds the maintained
// triangulation's 2N triangles, each positively oriented, every directed edge once; in a
// pipeline observe.h5md writes it under /connectivity/delaunay.triangles, and the file (read
// with h5py) holds exactly the maintained triangles, positively oriented against the positions
// of the same frame.
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "core/run/simulation.h"
#include "stages/delaunay/common/mesh.h"
#include "support/h5py.h"
#include "support/spec.h"
#include "support/temp_dir.h"
#include "support/test_plugins.h"
#include "stages/delaunay/test_support.h"

using namespace ff;
using namespace ff::test::dl;
namespace fs = std::filesystem;

namespace {

constexpr const char* kTriangles = "delaunay.triangles";

std::vector<std::int32_t> triangles_of(State& s) {
  Field& f = s.field(kTriangles);
  f.acquire(Where::host, Mode::read);
  REQUIRE(f.dtype() == DType::i32);
  REQUIRE(f.components() == 3);
  return {f.host<std::int32_t>(), f.host<std::int32_t>() + f.size()};
}

// Every triangle positive under minimum image, every directed edge once, the undirected edges
// those of the half-edges.
void require_consistent(State& s, const std::vector<std::int32_t>& tri) {
  const std::size_t n = s.n();
  REQUIRE(tri.size() == 3 * 2 * n);
  const auto xy = positions(s);
  double L[3] = {s.box.L[0], s.box.L[1], 0};
  const ff::delaunay::Points<double> pts{xy.data(), PeriodicBox<double>::make(L)};
  std::set<std::pair<int, int>> directed;
  std::size_t negative = 0;
  for (std::size_t t = 0; t < 2 * n; ++t) {
    const int a = tri[3 * t], b = tri[3 * t + 1], c = tri[3 * t + 2];
    if (!(ff::delaunay::cross(pts.rel(a, b), pts.rel(a, c)) > 0)) ++negative;
    for (int k = 0; k < 3; ++k) directed.insert({tri[3 * t + k], tri[3 * t + (k + 1) % 3]});
  }
  CHECK(negative == 0);
  CHECK(directed.size() == 6 * n);
  std::vector<std::pair<int, int>> undirected;
  for (auto& d : directed)
    if (d.first < d.second) {
      CHECK(directed.count({d.second, d.first}) == 1);
      undirected.push_back(d);
    }
  const Topo t = topology(s);
  CHECK(undirected == ff::delaunay::edge_set(t.he.data(), n));
}

using ff::test::TempDir;

}  // namespace

TEST_CASE("triangles: 2N positive triangles with the half-edges' edges, built at step 0 if needed",
          "[delaunay][triangles]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  INFO("backend " << to_string(b));
  const double L = std::sqrt(2500 / 0.6);
  auto s = make_state(random_points(2500, L, L, 21), L, L);
  auto st = make_stage(kTriangles, b);
  st->configure(*s);
  CHECK(status_of(*s)[ff::delaunay::kBuilt] == 0);
  Runner r(*s, b);
  REQUIRE_FALSE(r.run(*st, 0).rollback);
  CHECK(status_of(*s)[ff::delaunay::kBuilt] == 1);
  CHECK(r.metric("triangles") == 2 * 2500);
  const auto first = triangles_of(*s);
  require_consistent(*s, first);
  // Each triangle starts at its lowest half-edge, in half-edge order.
  const Topo t = topology(*s);
  const ff::delaunay::Mesh m{const_cast<std::int32_t*>(t.he.data()), nullptr};
  std::size_t k = 0;
  bool same = true;
  for (int h = 0; h < int(6 * s->n()); ++h)
    if (m.canonical(h)) {
      same = same && first[3 * k] == m.origin(h) && first[3 * k + 1] == m.origin(m.next(h)) &&
             first[3 * k + 2] == m.origin(m.next(m.next(h)));
      ++k;
    }
  CHECK(same);
  // After flips the field follows the half-edges (it is refilled on every call).
  auto detect = make_stage("delaunay.detect_inversion", b);
  auto flip = make_stage("delaunay.flip", b);
  auto lawson = make_stage("delaunay.lawson", b);
  for (Stage* x : {detect.get(), flip.get(), lawson.get()}) x->configure(*s);
  double flips = 0;
  for (int step = 1; step <= 10; ++step) {  // small smooth moves (random points have close pairs)
    auto xy = positions(*s);
    for (std::size_t i = 0; i < xy.size(); ++i) xy[i] += 0.003 * std::sin(0.7 * double(i) + step);
    set_positions(*s, xy);
    REQUIRE_FALSE(r.run(*detect, step).rollback);
    REQUIRE_FALSE(r.run(*flip, step).rollback);
    REQUIRE_FALSE(r.run(*lawson, step).rollback);
    flips += r.metric("lawson_flips");
  }
  REQUIRE(flips > 0);
  REQUIRE_FALSE(r.run(*st, 1).rollback);
  const auto second = triangles_of(*s);
  CHECK(second != first);
  require_consistent(*s, second);
}

TEST_CASE("triangles: observe.h5md writes /connectivity/delaunay.triangles, equal to the maintained ones",
          "[delaunay][triangles][h5md]") {
  const Backend backend = GENERATE(from_range(ff::test::backends()));
  INFO("backend " << to_string(backend));
  auto reg = test::registry_with({"brownian"});
  using ff::test::entry;
  TempDir dir(to_string(backend));
  const std::uint64_t n = 1000;
  auto spec = test::spec(
      2, n, 0.5, 60, 0.01,
      {entry(*reg, "brownian.integrate", {{"D", 0.02}}), entry(*reg, "delaunay.detect_inversion"),
       entry(*reg, "delaunay.flip"), entry(*reg, "delaunay.lawson"), entry(*reg, kTriangles, {}, {"", {}, false, 20}),
       entry(*reg, "observe.h5md",
             {{"file", std::string("t.h5")}, {"fields", std::vector<std::string>{"position", kTriangles}}},
             {"", {}, false, 20})},
      42);
  spec.system.init = "random";
  spec.file = dir / "pipeline.yaml";  // observe.h5md records the pipeline text
  std::ofstream(spec.file) << "# test_delaunay_triangles\n";
  RunOptions o;
  o.backend = backend;
  o.out_dir = dir.path.string();
  Simulation sim(spec, *reg, o);
  sim.run();
  CHECK(sim.slots()[4].calls == 4);  // steps 0, 20, 40, 60
  const auto tri = triangles_of(sim.state());
  require_consistent(sim.state(), tri);
  {
    std::ofstream out(dir / "last.txt");
    for (std::size_t t = 0; t < 2 * n; ++t) out << tri[3 * t] << " " << tri[3 * t + 1] << " " << tri[3 * t + 2] << "\n";
  }
  if (!ff::test::can_check_h5md("h5py check of /connectivity/delaunay.triangles")) return;
  const std::string script = dir / "check.py";
  std::ofstream(script) << R"(import sys
import numpy as np
import h5py
f = h5py.File(sys.argv[1], "r")
n = int(sys.argv[3])
g = f["connectivity/delaunay.triangles"]
tri = g["value"][:]
assert tri.dtype == np.int32, tri.dtype
assert tri.shape == (4, 2 * n, 3), tri.shape
assert list(g["step"][:]) == [0, 20, 40, 60], g["step"][:]
assert list(f["particles/all/position/step"][:]) == [0, 20, 40, 60]
assert "particles_group" in g.attrs
last = np.loadtxt(sys.argv[2], dtype=np.int32)
assert np.array_equal(tri[-1], last), "last frame differs from the maintained triangles"
assert not np.array_equal(tri[0], tri[-1]), "the triangulation never changed"
L = f["particles/all/box/edges"][:]
pos = f["particles/all/position/value"][:]
for k in range(tri.shape[0]):
    x = pos[k]
    t = tri[k]
    assert t.min() == 0 and t.max() == n - 1
    ab = x[t[:, 1]] - x[t[:, 0]]
    ac = x[t[:, 2]] - x[t[:, 0]]
    ab -= L * np.rint(ab / L)
    ac -= L * np.rint(ac / L)
    cross = ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0]
    assert (cross > 0).all(), "frame %d: %d triangles not positively oriented" % (k, (cross <= 0).sum())
    directed = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    keys = directed[:, 0].astype(np.int64) * n + directed[:, 1]
    assert len(np.unique(keys)) == 6 * n, "frame %d: a directed edge twice" % k
    rev = directed[:, 1].astype(np.int64) * n + directed[:, 0]
    assert np.array_equal(np.sort(keys), np.sort(rev)), "frame %d: an edge without its twin" % k
print("ok", tri.shape)
)";
  std::fflush(nullptr);
  const int rc = std::system(("/usr/bin/python3 '" + script + "' '" + (dir / "t.h5") + "' '" + (dir / "last.txt") +
                              "' " + std::to_string(n))
                                 .c_str());
  CHECK((WIFEXITED(rc) ? WEXITSTATUS(rc) : -1) == 0);
}
