// Host-side checks of a half-edge triangulation (header-only; for tests and debugging):
// structure (a torus triangulation with consistent half-edges), orientation, the local
// Delaunay property, and the undirected edge set.
#pragma once
#include <algorithm>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "stages/delaunay/common/mesh.h"

namespace ff::delaunay {

// Empty string when `he` (2 x 6n) and `vedge` (n) describe a triangulation of the torus with
// n vertices, 3n edges and 2n triangles: next cycles of length 3, twins consistent, every
// vertex's half-edges forming one fan, vertex_edge leaving its vertex, no edge twice.
inline std::string check_structure(const std::int32_t* he, const std::int32_t* vedge, std::size_t n) {
  const int H = int(6 * n);
  auto org = [&](int h) { return he[2 * h]; };
  auto nxt = [&](int h) { return he[2 * h + 1]; };
  for (int h = 0; h < H; ++h) {
    const int n1 = nxt(h);
    if (n1 < 0 || n1 >= H) return "half-edge " + std::to_string(h) + ": next out of range";
    if (org(h) < 0 || org(h) >= int(n)) return "half-edge " + std::to_string(h) + ": origin out of range";
    if (nxt(nxt(n1)) != h) return "half-edge " + std::to_string(h) + ": not in a triangle";
    if (org(n1) != org(twin(h))) return "half-edge " + std::to_string(h) + ": twin does not end at next's origin";
    if (org(h) == org(twin(h))) return "half-edge " + std::to_string(h) + ": loop";
  }
  std::vector<int> degree(n, 0);
  for (int h = 0; h < H; ++h) ++degree[org(h)];
  for (std::size_t v = 0; v < n; ++v) {
    const int h0 = vedge[v];
    if (h0 < 0 || h0 >= H || org(h0) != int(v)) return "vertex " + std::to_string(v) + ": vertex_edge does not leave it";
    int h = h0, steps = 0;
    do {  // rotate CCW around v: twin(prev(h))
      h = twin(nxt(nxt(h)));
      if (org(h) != int(v)) return "vertex " + std::to_string(v) + ": fan leaves the vertex";
      ++steps;
    } while (h != h0 && steps <= degree[v]);
    if (steps != degree[v]) return "vertex " + std::to_string(v) + ": half-edges do not form one fan";
  }
  std::vector<std::pair<int, int>> edges;
  for (int e = 0; e < H / 2; ++e) edges.emplace_back(std::min(org(2 * e), org(2 * e + 1)), std::max(org(2 * e), org(2 * e + 1)));
  std::sort(edges.begin(), edges.end());
  if (std::adjacent_find(edges.begin(), edges.end()) != edges.end()) return "an edge appears twice";
  return {};
}

// Empty string when `opp` (6n) holds, for every half-edge, the vertex opposite it in its
// triangle (fields::opposite; kept by every flip).
inline std::string check_opposite(const std::int32_t* he, const std::int32_t* opp, std::size_t n) {
  for (int h = 0; h < int(6 * n); ++h)
    if (opp[h] != opposite_of(he, h))
      return "half-edge " + std::to_string(h) + ": opposite vertex " + std::to_string(opp[h]) + ", triangle says " +
             std::to_string(opposite_of(he, h));
  return {};
}

// Sorted undirected edges (lower, higher).
inline std::vector<std::pair<int, int>> edge_set(const std::int32_t* he, std::size_t n) {
  std::vector<std::pair<int, int>> edges;
  for (std::size_t e = 0; e < 3 * n; ++e) {
    const int a = he[4 * e], b = he[4 * e + 2];
    edges.emplace_back(std::min(a, b), std::max(a, b));
  }
  std::sort(edges.begin(), edges.end());
  return edges;
}

// Triangles that are not positively oriented (minimum image from their first vertex), or that
// do not close under minimum image.
inline std::size_t count_bad_triangles(const std::int32_t* he, std::size_t n, const double* xy, double Lx, double Ly) {
  double L[3] = {Lx, Ly, 0};
  const Points<double> pts{xy, PeriodicBox<double>::make(L)};
  const Mesh m{const_cast<std::int32_t*>(he), nullptr};
  std::size_t bad = 0;
  for (int h = 0; h < int(6 * n); ++h) {
    if (!m.canonical(h)) continue;
    const int a = m.origin(h), b = m.origin(m.next(h)), c = m.origin(m.next(m.next(h)));
    const V2 ab = pts.rel(a, b), ac = pts.rel(a, c);
    if (!(cross(ab, ac) > 0) || !closes(ab, ac, pts.rel(b, c), pts.box)) ++bad;
  }
  return bad;
}

// Edges whose opposite vertex d lies inside the circle of (a, b, c) by more than tol x the
// in-circle permanent (0 for a Delaunay triangulation, up to co-circular ties).
inline std::size_t count_non_delaunay(const std::int32_t* he, std::size_t n, const double* xy, double Lx, double Ly,
                                      double tol) {
  double L[3] = {Lx, Ly, 0};
  const Points<double> pts{xy, PeriodicBox<double>::make(L)};
  const Mesh m{const_cast<std::int32_t*>(he), nullptr};
  std::size_t bad = 0;
  for (int e = 0; e < int(3 * n); ++e) {
    const Quad q = quad(m, e);
    double perm;
    const double det = incircle({0, 0}, pts.rel(q.a, q.b), pts.rel(q.a, q.c), pts.rel(q.a, q.d), perm);
    if (det > tol * perm) ++bad;
  }
  return bad;
}

// |in-circle| / permanent of the quad around the edge (a, b) if it exists: how co-circular the
// four points are (0 = exactly). -1 when (a, b) is not an edge.
inline double cocircularity(const std::int32_t* he, std::size_t n, const double* xy, double Lx, double Ly, int a, int b) {
  double L[3] = {Lx, Ly, 0};
  const Points<double> pts{xy, PeriodicBox<double>::make(L)};
  const Mesh m{const_cast<std::int32_t*>(he), nullptr};
  for (int e = 0; e < int(3 * n); ++e) {
    const Quad q = quad(m, e);
    if (!((q.a == a && q.b == b) || (q.a == b && q.b == a))) continue;
    double perm;
    const double det = incircle({0, 0}, pts.rel(q.a, q.b), pts.rel(q.a, q.c), pts.rel(q.a, q.d), perm);
    return std::fabs(det) / perm;
  }
  return -1;
}

}  // namespace ff::delaunay
