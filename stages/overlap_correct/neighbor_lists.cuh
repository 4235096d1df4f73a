// overlap_correct's per-step neighbour lists on the device, and the gathers and checks of one
// particle that read them (by one thread, or by a group of kGroup lanes): cuda.cu's persistent
// kernel calls them. The per-particle math is kernel.h's (Overlaps::gather_pair_at,
// Overlaps::overlaps_after_move_at); this file only arranges the loads. Include only from cuda.cu.
#pragma once
#include <cuda_runtime.h>

#include <cstdint>

#include "stages/overlap_correct/kernel.h"

namespace ff::overlap {

// Neighbour lists of the step. Iteration 0 walks every particle's fan (checking that it
// closes) and copies its neighbours, up to kCached, to nb (one 32-byte sector per particle;
// in a Delaunay triangulation the mean degree is 6), and the fan's half-edges to fan; later walks
// read them from there: one load for the ids instead of a chain of one dependent half-edge load
// per neighbour, and one sector instead of ~6 (the triangulation does not change during the
// stage). The arrays outlive the step: the next step's iteration 0 walks again only the fans that
// changed (kept_fan). A particle with more neighbours walks its fan each time.
constexpr int kCached = 8;
constexpr std::uint8_t kWalk = 0xff;

// v's listed neighbours (d ≤ kCached of them) into ids: both 16-byte halves of its 32-byte
// sector, whatever d is (entries from d on are left from earlier lists and never used), so the
// loads need not wait for the degree: they go out with it.
__device__ inline void load_ids(const int* nb, int v, int (&ids)[kCached]) {
  const int4* p = reinterpret_cast<const int4*>(nb + std::size_t(kCached) * v);
  const int4 lo = p[0];
  const int4 hi = p[1];
  ids[0] = lo.x, ids[1] = lo.y, ids[2] = lo.z, ids[3] = lo.w;
  ids[4] = hi.x, ids[5] = hi.y, ids[6] = hi.z, ids[7] = hi.w;
}

// Calls f(k, u, xu, yu) for each neighbour u = ids[k], k in [0, d) (d ≤ kCached), with its position,
// loading the positions kInFlight at a time: independent loads in flight together, not one
// after the other (one thread's gathers and checks).
constexpr int kInFlight = 4;
template <class R, bool W, class F>
__device__ void for_each_loaded(const Overlaps<R, W>& ov, const int (&ids)[kCached], int d, F&& f) {
#pragma unroll
  for (int h = 0; h < kCached; h += kInFlight) {
    double xu[kInFlight], yu[kInFlight];
#pragma unroll
    for (int i = 0; i < kInFlight; ++i)
      if (h + i < d) load_xy(ov.pos, ids[h + i], xu[i], yu[i]);
#pragma unroll
    for (int i = 0; i < kInFlight; ++i)
      if (h + i < d) f(h + i, ids[h + i], xu[i], yu[i]);
  }
}

// A gather of v by one thread from its neighbours ids[0 .. d) (from neighbor_ids below), in two
// passes: the first loads the positions (kInFlight at a time) and only tests which neighbours
// overlap v (Overlaps::overlaps_at: pair_term's own test, the same bits); the second runs the
// pair math (a square root, a division, two roundings to fixed point) for those alone, one
// after the other, reloading each one's position (in this SM's L1 now). A warp then runs that
// math as often as its lane with the most overlaps needs (~3-4 times at 2^20), where an unrolled
// slot per neighbour ran it in ~98 % of the slots with 4 of 32 lanes active (ncu, session 18).
// The same pushes, summed in fixed point, so the same bits in any order.
template <class R, bool W>
__device__ VertexPush gather_ids(const Overlaps<R, W>& ov, int v, const int (&ids)[kCached], int d) {
  VertexPush out;
  double xv, yv;
  load_xy(ov.pos, v, xv, yv);
  const double sv = ov.diameter_of(v);
  unsigned near = 0;
  for_each_loaded(ov, ids, d, [&](int k, int u, double xu, double yu) {
    if (ov.overlaps_at(xv, yv, sv, u, xu, yu)) near |= 1u << k;
  });
  std::int64_t qx = 0, qy = 0;
  while (near) {
    const int slot = __ffs(near) - 1;
    near &= near - 1;
    int u = ids[0];
#pragma unroll
    for (int j = 1; j < kCached; ++j)  // u = ids[slot] with a register index
      if (slot == j) u = ids[j];
    ov.gather_pair(v, xv, yv, sv, u, qx, qy, out);
  }
  ov.gather_wall(v, xv, yv, sv, qx, qy, out);
  ov.finish(qx, qy, sv, out);
  out.x = xv;
  out.y = yv;
  return out;
}

// Whether last step's fan of v (its outgoing half-edges hs[0 .. d), in walk order, kept in fan
// by iteration 0's walk) is still v's fan in the mesh now, with ids[0 .. d) its neighbours: the
// half-edges' twins are loaded all at once (independent loads) instead of one after the other as
// the walk does. It is when every hs[i] and next(twin(hs[i])) is in range and equals
// hs[i + 1 mod d], and vertex_edge[v] is one of them: then hs is the orbit of next ∘ twin through
// vertex_edge[v], which is what the walk follows (Overlaps::for_each_neighbor), so the same
// neighbours, each neighbour origin(twin(hs[i])) being in range and not v (the walk's checks).
// A stored fan is always an orbit a walk found, in some step's mesh (distinct half-edges), or
// d = 0 (a fresh array): nothing else is accepted. Most particles keep their fan from one step to
// the next (a flip changes the fans of its quad's four vertices only); the others walk again.
template <class R, bool W>
__device__ bool kept_fan(const Overlaps<R, W>& ov, int v, int d, const int* nb, const int* fan, int (&ids)[kCached]) {
  if (d < 1 || d > kCached) return false;
  const unsigned nh = 6u * unsigned(ov.n);
  const int4* p = reinterpret_cast<const int4*>(fan + std::size_t(kCached) * v);
  const int4 lo = p[0];
  const int4 hi = d > 4 ? p[1] : make_int4(0, 0, 0, 0);
  const int hs[kCached] = {lo.x, lo.y, lo.z, lo.w, hi.x, hi.y, hi.z, hi.w};
  load_ids(nb, v, ids);
  const int h0 = ov.vedge[v];
  bool ok = true, has_h0 = false;
#pragma unroll
  for (int i = 0; i < kCached; ++i) {
    if (i >= d) break;
    const int h = hs[i];
    const int after = i + 1 < d ? hs[i + 1] : hs[0];
    if (unsigned(h) >= nh) return false;  // (nothing out of range is loaded)
    int u, hn;
    delaunay::load_halfedge(ov.he, h ^ 1, u, hn);
    ok = ok && hn == after && u == ids[i] && unsigned(u) < unsigned(ov.n) && u != v;
    has_h0 = has_h0 || h == h0;
  }
  return ok && has_h0;
}

// v's neighbours for a gather by one thread, into ids[0 .. d): from the list (later
// iterations), or (iteration 0) from last step's fan if it is still v's (kept_fan), else from a
// walk around v's fan that only collects them (a chain of half-edge loads and nothing else,
// checking that the fan closes) and copies them to the list and the half-edges to fan.
// Walking and gathering at once made every step of the chain wait for a position load too
// (bench/overlap_correct-PERF.md). False: gather by Overlaps::gather's walk instead (more than
// kCached neighbours, or, in iteration 0, a fan that does not close, which that walk reports).
template <class R, bool W>
__device__ bool neighbor_ids(const Overlaps<R, W>& ov, int v, bool first, int* nb, std::uint8_t* degree, int* fan,
                              int (&ids)[kCached], int& d) {
  if (!first) {
    d = degree[v];
    load_ids(nb, v, ids);
    return d != kWalk;
  }
  d = degree[v];  // last step's
  if (kept_fan(ov, v, d, nb, fan, ids)) return true;  // nb and degree hold it already
  d = 0;
  int hs[kCached];
#pragma unroll
  for (int k = 0; k < kCached; ++k) ids[k] = hs[k] = 0;
  const bool closed = ov.for_each_neighbor(v, [&](int u, int h) {
#pragma unroll
    for (int k = 0; k < kCached; ++k)  // ids[d] = u, hs[d] = h with a register index
      if (k == d) ids[k] = u, hs[k] = h;
    ++d;
  });
  const bool fits = closed && d <= kCached;
  degree[v] = fits ? std::uint8_t(d) : kWalk;
  if (!fits) return false;
  int4* p = reinterpret_cast<int4*>(nb + std::size_t(kCached) * v);
  int4* f = reinterpret_cast<int4*>(fan + std::size_t(kCached) * v);
  p[0] = make_int4(ids[0], ids[1], ids[2], ids[3]);
  f[0] = make_int4(hs[0], hs[1], hs[2], hs[3]);
  if (d > 4) {
    p[1] = make_int4(ids[4], ids[5], ids[6], ids[7]);
    f[1] = make_int4(hs[4], hs[5], hs[6], hs[7]);
  }
  return true;
}

// What the check of moved particle v by one thread finds among its listed neighbours ids[0 .. d)
// (d ≤ kCached), loading as gather_ids: bit k of `near` for each ids[k] that overlaps v at the new
// positions (Overlaps::overlapping_neighbors' test), and `self`: v overlaps one of them or a wall.
struct CheckedList {
  unsigned near = 0;
  bool self = false;
};
template <class R, bool W>
__device__ CheckedList check_listed(const Overlaps<R, W>& ov, int v, const int (&ids)[kCached], int d) {
  double xv, yv;
  load_xy(ov.pos, v, xv, yv);
  const double sv = ov.diameter_of(v);
  CheckedList out;
  for_each_loaded(ov, ids, d, [&](int k, int u, double xu, double yu) {
    if (ov.overlaps_after_move_at(xv, yv, sv, u, xu, yu)) out.near |= 1u << k;
  });
  out.self = ov.wall_after_move(v, xv, yv, sv) || out.near != 0;
  return out;
}

// The check of moved particle v by one thread: calls f(u) for each neighbour u that overlaps v at
// the new positions and returns whether v overlaps anything (a fan that did not fit the list is
// walked).
template <class R, bool W, class F>
__device__ bool thread_check(const Overlaps<R, W>& ov, int v, const int* nb, const std::uint8_t* degree, F&& f) {
  const int d = degree[v];
  int ids[kCached];
  load_ids(nb, v, ids);
  if (d == kWalk) return ov.overlapping_neighbors(v, f);
  const CheckedList c = check_listed(ov, v, ids, d);
#pragma unroll
  for (int k = 0; k < kCached; ++k)
    if ((c.near >> k) & 1u) f(ids[k]);
  return c.self;
}

// Later iterations read the lists with a group of kGroup lanes per particle: lane l takes
// neighbour l, so the group loads all of them at once instead of one after the other (a
// thread's walk was a chain of dependent loads), and the parts are added across the group.
// Fixed-point sums do not depend on the order, so the result is the same bits as one thread's
// walk. A particle whose list did not fit is walked by the group's first lane alone.
constexpr int kGroup = kCached;
static_assert(32 % kGroup == 0, "a lane group lies within one warp");

// Sum (int64 / unsigned) or OR across the kGroup lanes of each group; every lane gets the result.
template <class T>
__device__ T group_sum(T x) {
#pragma unroll
  for (int o = 1; o < kGroup; o <<= 1) x += __shfl_xor_sync(0xffffffffu, x, o);
  return x;
}
__device__ inline unsigned group_or(unsigned x) {
#pragma unroll
  for (int o = 1; o < kGroup; o <<= 1) x |= __shfl_xor_sync(0xffffffffu, x, o);
  return x;
}

// The gather of particle v by its lane group (lane l of kGroup); `has` false: the group has no
// particle but its lanes still take part in the shuffles. Every lane of the group returns v's
// VertexPush (meaningful when `has`).
template <class R, bool W, class Id>
__device__ VertexPush group_gather(const Overlaps<R, W>& ov, int v, bool has, int l, const Id* nb,
                                   const std::uint8_t* degree) {
  VertexPush part;
  std::int64_t qx = 0, qy = 0;
  double sv = 0, xv = 0, yv = 0;
  if (has) {
    load_xy(ov.pos, v, xv, yv);
    sv = ov.diameter_of(v);
    const int d = degree[v];
    if (d == kWalk) {
      if (l == 0) part.broken = !ov.fan_of(v)([&](int u) { ov.gather_pair(v, xv, yv, sv, u, qx, qy, part); });
    } else if (l < d) {
      ov.gather_pair(v, xv, yv, sv, int(nb[std::size_t(kCached) * v + l]), qx, qy, part);
    }
    if (l == 0) ov.gather_wall(v, xv, yv, sv, qx, qy, part);  // one lane adds v's wall term
  }
  // pairs and bad are at most kMaxFan each (< 2^16): one word carries both.
  const unsigned counts = group_sum(part.pairs | (part.bad << 16));
  const unsigned flags = group_or(unsigned(part.touched) | (unsigned(part.broken) << 1));
  qx = group_sum(qx);
  qy = group_sum(qy);
  VertexPush out;
  out.pairs = counts & 0xffffu;
  out.bad = counts >> 16;
  out.touched = flags & 1u;
  out.broken = flags & 2u;
  ov.finish(qx, qy, sv, out);
  out.x = xv;
  out.y = yv;
  return out;
}

// The check of moved particle v by its lane group: calls f(u) for each neighbour u that
// overlaps v at the new positions (Overlaps::overlapping_neighbors_by's test); every lane of the
// group returns whether any did.
template <class R, bool W, class Id, class F>
__device__ bool group_check(const Overlaps<R, W>& ov, int v, bool has, int l, const Id* nb, const std::uint8_t* degree,
                            F&& f) {
  bool any = false;
  if (has) {
    const int d = degree[v];
    if (d == kWalk) {
      if (l == 0) any = ov.overlapping_neighbors_by(v, ov.fan_of(v), f);
    } else if (l < d) {
      double xv, yv;
      load_xy(ov.pos, v, xv, yv);
      const int u = int(nb[std::size_t(kCached) * v + l]);
      if (ov.overlaps_after_move(xv, yv, ov.diameter_of(v), u)) {
        f(u);
        any = true;
      }
      if (l == 0 && ov.wall_after_move(v, xv, yv, ov.diameter_of(v))) any = true;  // lane 0 (d ≥ 1) tests the walls
    }
  }
  return group_or(unsigned(any)) != 0;
}

}  // namespace ff::overlap
