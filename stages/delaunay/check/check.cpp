#include "stages/delaunay/check/check.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "stages/delaunay/build/build.h"
#include "stages/delaunay/build/cgal.h"
#include "stages/delaunay/common/mesh.h"
#include "stages/delaunay/common/mesh_check.h"

namespace ff::delaunay {

namespace {

struct KeyedEdge {
  int lo, hi, e;
  bool operator<(const KeyedEdge& o) const { return lo != o.lo ? lo < o.lo : hi < o.hi; }
};

std::vector<KeyedEdge> keyed_edges(const std::int32_t* he, std::size_t n) {
  std::vector<KeyedEdge> v(3 * n);
  for (std::size_t e = 0; e < 3 * n; ++e) {
    const int a = he[4 * e], b = he[4 * e + 2];
    v[e] = {std::min(a, b), std::max(a, b), int(e)};
  }
  std::sort(v.begin(), v.end());
  return v;
}

EdgeDifference difference(const std::int32_t* he, int e, const Points<double>& pts, bool maintained) {
  const Mesh m{const_cast<std::int32_t*>(he), nullptr};
  const Quad q = quad(m, e);
  double perm = 0;
  const double det = incircle({0, 0}, pts.rel(q.a, q.b), pts.rel(q.a, q.c), pts.rel(q.a, q.d), perm);
  EdgeDifference d;
  d.a = q.a;
  d.b = q.b;
  d.c = q.c;
  d.d = q.d;
  d.maintained = maintained;
  d.cocircularity = perm > 0 ? std::fabs(det) / perm : 0;
  return d;
}

}  // namespace

CheckReport compare_with_cgal(const std::int32_t* he, const std::int32_t* vedge, std::size_t n,
                              const std::vector<double>& xy, double Lx, double Ly, double tolerance) {
  CheckReport r;
  r.structure = check_structure(he, vedge, n);
  if (!r.structure.empty()) return r;  // edges cannot be compared meaningfully
  r.inverted = count_bad_triangles(he, n, xy.data(), Lx, Ly);

  const PeriodicTriangles cgal = periodic_delaunay(xy, Lx, Ly);
  r.method = cgal.method;
  const HalfEdges ref = assemble(cgal.triangles, n);

  double L[3] = {Lx, Ly, 0};
  const Points<double> pts{xy.data(), PeriodicBox<double>::make(L)};
  const auto mine = keyed_edges(he, n), theirs = keyed_edges(ref.he.data(), n);
  auto consider = [&](const EdgeDifference& d) {
    if (d.cocircularity <= tolerance) {
      ++r.ties;
      return;
    }
    ++r.mismatches;
    if (r.first.size() < CheckReport::kShown) r.first.push_back(d);
  };
  std::size_t i = 0, j = 0;
  while (i < mine.size() || j < theirs.size()) {
    if (j == theirs.size() || (i < mine.size() && mine[i] < theirs[j])) {
      ++r.edges_only_maintained;
      consider(difference(he, mine[i++].e, pts, true));
    } else if (i == mine.size() || theirs[j] < mine[i]) {
      ++r.edges_only_cgal;
      consider(difference(ref.he.data(), theirs[j++].e, pts, false));
    } else {
      ++i;
      ++j;
    }
  }
  return r;
}

std::string describe(const EdgeDifference& d) {
  char buf[200];
  std::snprintf(buf, sizeof buf, "%s has edge %d-%d (opposite vertices %d and %d; in-circle/permanent %.3g)",
                d.maintained ? "the maintained triangulation" : "CGAL's", std::min(d.a, d.b), std::max(d.a, d.b),
                d.c, d.d, d.cocircularity);
  return buf;
}

}  // namespace ff::delaunay
