// The Delaunay stages in a decomposed team (issue 21 item 2, docs/multi-gpu.md "The Delaunay
// pipelines"): host helpers over a rank's local triangulation of its held particles (owned
// [0, n_owned), ghosts, then the fixed vertices that fill the gap beyond the band, all in global
// coordinates: common/slab.h's global_with_gap).
//
// Which local elements a rank may trust: a triangle with an owned vertex is a triangle of the
// global triangulation when its circumdiameter is below the band less twice the distance δ the
// particles moved since the migration (slab.h's proof). detect_inversion's
// decisions also read the marks of every edge of such a triangle, whose quads reach one triangle
// further: the triangles with a vertex that is owned or a neighbour of an owned one ("near").
// Their circumdisks lie within D_owned + D_near of an owned particle, so with
//     D_owned + D_near + 2 δ < band
// (the largest circumdiameters over the two sets; δ the largest distance any particle moved
// since the migration, which chose the held particles) every element those decisions read is
// the global one (for points in general position). band_check measures it.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/backend/comm.h"
#include "core/base/error.h"
#include "core/stage/stage.h"
#include "stages/delaunay/common/fields.h"
#include "stages/delaunay/common/mesh.h"

namespace ff::delaunay {

// The local triangulation on the host (the fields acquired there for reading; nothing here
// writes through the view).
struct HostMesh {
  Mesh view;
  std::size_t n;  // vertices held (particles and fill)

  static HostMesh of(State& s, CUstream_st* stream) {
    for (const char* f : {fields::halfedge, fields::opposite, fields::vertex_edge})
      s.field(f).acquire(Where::host, Mode::read, stream);
    return {{s.field(fields::halfedge).host<std::int32_t>(), s.field(fields::vertex_edge).host<std::int32_t>(),
             s.field(fields::opposite).host<std::int32_t>()},
            s.n()};
  }
  const Mesh& mesh() const { return view; }
};

template <class R>
const R* host_positions(State& s, Field& f, CUstream_st* stream) {
  f.acquire(Where::host, Mode::read, stream);
  return f.host<R>();
}

// The largest circumdiameters of the triangles with an owned vertex (owned) and with a near
// vertex (near), at positions p.
struct BandMeasure {
  double owned = 0, near = 0;
};

template <class R>
BandMeasure band_measure(const HostMesh& hm, const R* p, std::size_t n_owned, const PeriodicBox<double>& box) {
  const Mesh m = hm.mesh();
  const Points<R> pts{p, box};
  std::vector<std::uint8_t> near(hm.n, 0);
  for (std::size_t v = 0; v < n_owned; ++v) near[v] = 1;
  for (std::size_t e = 0; e < 3 * hm.n; ++e) {
    const int a = m.origin(int(2 * e)), b = m.origin(int(2 * e + 1));
    if (std::size_t(a) < n_owned) near[std::size_t(b)] = 1;
    if (std::size_t(b) < n_owned) near[std::size_t(a)] = 1;
  }
  BandMeasure out;
  for (int h = 0; h < int(6 * hm.n); ++h) {
    if (!m.canonical(h)) continue;
    const int hn = m.next(h), hp = m.next(hn);
    const int a = m.origin(h), b = m.origin(hn), c = m.origin(hp);
    const bool own = std::size_t(a) < n_owned || std::size_t(b) < n_owned || std::size_t(c) < n_owned;
    if (!(own || near[std::size_t(a)] || near[std::size_t(b)] || near[std::size_t(c)])) continue;
    const V2 ab = pts.rel(a, b), ac = pts.rel(a, c);
    const double cr = std::fabs(cross(ab, ac));
    const double d = std::hypot(ab.x, ab.y) * std::hypot(ac.x, ac.y) * std::hypot(ac.x - ab.x, ac.y - ab.y) /
                     (cr > 0 ? cr : 1e-300);
    out.near = std::max(out.near, d);
    if (own) out.owned = std::max(out.owned, d);
  }
  return out;
}

// The band condition for the triangulation at `positions` (a field where it is Delaunay: see the
// top of this file), δ the largest distance of those positions from the migration's
// (GhostExchange::displacement: one all-reduce, so every rank calls this at the same point): a
// RunError when it fails (the owned stars may not be the global ones), and a request for a wider
// band when it holds with less than a fifth of the band to spare (the next step migrates with it).
template <class R>
void band_check(StepContext& ctx, const char* stage, const char* positions) {
  State& s = ctx.state;
  const double band = ctx.ghosts->band();
  const double moved = ctx.ghosts->displacement(s, positions);
  const R* p = host_positions<R>(s, s.field(positions), ctx.stream);
  const BandMeasure b =
      band_measure<R>(HostMesh::of(s, ctx.stream), p, s.n_owned(), PeriodicBox<double>::make(s.box.L));
  const double need = b.owned + b.near + 2 * moved;
  if (!(need < band))
    throw RunError(std::string(stage) + ": step " + std::to_string(ctx.host_params.step) +
                   ": in a decomposed team the triangles near a rank's particles grew too large for its ghosts "
                   "(largest circumdiameters " + std::to_string(b.owned) + " with an owned vertex, " +
                   std::to_string(b.near) + " one ring further, particles moved up to " + std::to_string(moved) +
                   " since the migration: they need a band wider than " + std::to_string(need) + ", the band is " +
                   std::to_string(band) + "); raise delaunay.detect_inversion's band");
  if (need > 0.8 * band) ctx.ghosts->request_band(1.5 * need);
}

// Whether this rank's detect_inversion found a reason to roll back in an element it can trust:
// an edge with an owned end that reversed (r⁰·r¹ < 0; prev null: not tested) or whose two
// triangles are both inverted, or an inverted triangle with an owned vertex without exactly one
// marked edge. The same predicates, in the same arithmetic, as MarkInversions and CheckInverted.
template <class R>
bool owned_rollback_reason(const HostMesh& hm, const R* p, const R* prev, const std::uint8_t* mark,
                           std::size_t n_owned, const PeriodicBox<double>& box) {
  const Mesh m = hm.mesh();
  const Points<R> pts{p, box};
  const V2 o{0, 0};
  for (int e = 0; e < int(3 * hm.n); ++e) {
    const QuadVertices q = quad_vertices(m, e);
    if (!(std::size_t(q.a) < n_owned || std::size_t(q.b) < n_owned)) continue;
    const V2 ab = pts.rel(q.a, q.b), ac = pts.rel(q.a, q.c), ad = pts.rel(q.a, q.d);
    if (prev) {
      const Points<R> before{prev, box};
      if (dot(before.rel(q.a, q.b), ab) < 0) return true;
    }
    if (orient(o, ab, ac) <= 0 && orient(ab, o, ad) <= 0) return true;
  }
  for (int h = 0; h < int(6 * hm.n); ++h) {
    if (!m.canonical(h)) continue;
    const int hn = m.next(h), hp = m.next(hn);
    const int a = m.origin(h), b = m.origin(hn), c = m.origin(hp);
    if (!(std::size_t(a) < n_owned || std::size_t(b) < n_owned || std::size_t(c) < n_owned)) continue;
    if (orient(o, pts.rel(a, b), pts.rel(a, c)) > 0) continue;
    if (!mark || mark[h >> 1] + mark[hn >> 1] + mark[hp >> 1] != 1) return true;
  }
  return false;
}

// Whether some triangle with an owned vertex is inverted at positions p (after delaunay.flip's
// repair rounds; detect_inversion's test of the start of the step).
template <class R>
bool owned_inverted(const HostMesh& hm, const R* p, std::size_t n_owned, const PeriodicBox<double>& box) {
  return owned_rollback_reason<R>(hm, p, nullptr, nullptr, n_owned, box);
}

// One all-reduce (max) of a flag over the team: whether any rank raised it.
inline bool any_rank(Communicator* team, bool mine) {
  std::int64_t v = mine ? 1 : 0;
  team->all_reduce(&v, 1, ReduceOp::max);
  return v != 0;
}

}  // namespace ff::delaunay
