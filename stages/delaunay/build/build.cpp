#include "stages/delaunay/build/build.h"

#include <algorithm>
#include <cstring>

#include "core/base/error.h"
#include "stages/delaunay/build/cgal.h"
#include "stages/delaunay/common/host.h"

namespace ff::delaunay {

HalfEdges assemble(const std::vector<std::array<int, 3>>& triangles, std::size_t n, const std::vector<std::int32_t>* rank) {
  if (triangles.size() != 2 * n)
    throw RunError("delaunay: " + std::to_string(triangles.size()) + " triangles for " + std::to_string(n) +
                   " particles; a periodic triangulation has 2N");
  struct Side {
    std::int64_t key;  // lower * n + higher (by rank when ranks are given)
    int tri, k;        // side k of triangle tri goes t[k] -> t[k+1]
  };
  if (rank && rank->size() != n) throw RunError("delaunay: assemble: one rank per vertex expected");
  auto order = [&](std::int64_t v) { return rank ? std::int64_t((*rank)[std::size_t(v)]) : v; };
  std::vector<Side> sides;
  sides.reserve(6 * n);
  for (std::size_t t = 0; t < triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const std::int64_t u = triangles[t][k], v = triangles[t][(k + 1) % 3];
      if (u < 0 || v < 0 || u >= std::int64_t(n) || v >= std::int64_t(n) || u == v)
        throw RunError("delaunay: triangle " + std::to_string(t) + " has an invalid vertex");
      const std::int64_t ru = order(u), rv = order(v);
      sides.push_back({std::min(ru, rv) * std::int64_t(n) + std::max(ru, rv), int(t), k});
    }
  std::sort(sides.begin(), sides.end(), [](const Side& x, const Side& y) {
    return x.key != y.key ? x.key < y.key : (x.tri != y.tri ? x.tri < y.tri : x.k < y.k);
  });
  HalfEdges out;
  out.he.assign(2 * 6 * n, -1);
  out.vedge.assign(n, -1);
  std::vector<int> id_of(6 * n);  // (tri, k) -> half-edge
  auto name = [&](const Side& sd) {  // "lower-higher" vertex ids of a side's edge
    const int u = triangles[sd.tri][sd.k], v = triangles[sd.tri][(sd.k + 1) % 3];
    return std::to_string(std::min(u, v)) + "-" + std::to_string(std::max(u, v));
  };
  for (std::size_t s = 0; s < sides.size(); s += 2) {
    if (s + 1 >= sides.size() || sides[s + 1].key != sides[s].key ||
        (s + 2 < sides.size() && sides[s + 2].key == sides[s].key))
      throw RunError("delaunay: edge " + name(sides[s]) +
                     " does not border exactly two triangles; the triangles are not a periodic triangulation");
    const int e = int(s / 2);
    const std::int64_t first = sides[s].key / std::int64_t(n);  // the lower order of the two endpoints
    for (int j = 0; j < 2; ++j) {
      const Side& sd = sides[s + j];
      const int u = triangles[sd.tri][sd.k];
      const int h = 2 * e + (order(u) == first ? 0 : 1);
      if (out.he[2 * h] != -1)
        throw RunError("delaunay: edge " + name(sd) +
                       " is used twice in the same direction; triangles are not consistently oriented");
      out.he[2 * h] = u;
      id_of[3 * sd.tri + sd.k] = h;
    }
  }
  for (std::size_t t = 0; t < triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) out.he[2 * id_of[3 * t + k] + 1] = id_of[3 * t + (k + 1) % 3];
  for (int h = int(6 * n) - 1; h >= 0; --h) out.vedge[out.he[2 * h]] = h;
  for (std::size_t v = 0; v < n; ++v)
    if (out.vedge[v] < 0) throw RunError("delaunay: particle " + std::to_string(v) + " is in no triangle");
  return out;
}

std::string build_topology(State& s, CUstream_st* stream) {
  return build_topology(s, s.field(ff::fields::position), stream);
}

std::string build_topology(State& s, Field& pos, CUstream_st* stream) {
  add_topology_fields(s, "delaunay.build");
  const std::size_t n = s.n();
  pos.acquire(Where::host, Mode::read, stream);
  std::vector<double> xy(2 * n);
  if (pos.dtype() == DType::f32)
    std::copy(pos.host<float>(), pos.host<float>() + 2 * n, xy.begin());
  else
    std::copy(pos.host<double>(), pos.host<double>() + 2 * n, xy.begin());

  const PeriodicTriangles tri = periodic_delaunay(xy, s.box.L[0], s.box.L[1]);
  // Edge ids in Hilbert order of their endpoints: the edge loops then walk the box region by
  // region, and the positions and half-edges an edge reads were mostly just read by its
  // neighbours (in cache), whatever the particles' order in memory.
  const std::vector<std::int32_t> rank = hilbert_ranks(xy, s.box.L[0], s.box.L[1]);
  const HalfEdges h = assemble(tri.triangles, n, &rank);

  Field& he = s.field(fields::halfedge);
  he.acquire(Where::host, Mode::write, stream);
  std::memcpy(he.host<std::int32_t>(), h.he.data(), h.he.size() * sizeof(std::int32_t));
  Field& op = s.field(fields::opposite);
  op.acquire(Where::host, Mode::write, stream);
  for (std::size_t k = 0; k < halfedge_count(n); ++k) op.host<std::int32_t>()[k] = opposite_of(h.he.data(), int(k));
  Field& ve = s.field(fields::vertex_edge);
  ve.acquire(Where::host, Mode::write, stream);
  std::memcpy(ve.host<std::int32_t>(), h.vedge.data(), h.vedge.size() * sizeof(std::int32_t));
  Field& prev = s.field(fields::position_prev);
  if (&prev != &pos) {  // a decomposed team's rank builds at position_prev itself (detect_inversion)
    prev.acquire(Where::host, Mode::write, stream);
    std::memcpy(prev.host_raw(), pos.host_raw(), pos.bytes());
  }
  Field& st = s.field(fields::status);
  st.acquire(Where::host, Mode::readwrite, stream);
  st.host<std::int32_t>()[kBuilt] = 1;
  st.host<std::int32_t>()[kPending] = 0;
  st.host<std::int32_t>()[kCandidates] = 0;
  st.host<std::int32_t>()[kPrevKept] = 0;  // valid at position_prev = these positions
  return tri.method;
}

}  // namespace ff::delaunay
