// overlap_correct per-element math (Carter et al. 2017, sec. 2.3 eq. 4 and sec. 4.4), shared by
// the CPU and CUDA loops. FF_HD only; nvcc-clean.
//
// The push on particle v from an overlapping neighbour u (closer than σ_vu = (σ_v + σ_u)/2) has
// length δ, away from u along the line of centres:
//   reflect: δ = σ_vu − r   (both move by δ: r' = 2σ_vu − r, the pair bounces off contact)
//   contact: δ = (σ_vu − r)/2  (r' = σ_vu, tangential contact)
// Each push (pair_term, in double, the same bits from either end with the sign flipped) is
// rounded to a multiple of 2^-50·unit (unit: the largest diameter at configure), and v's pushes
// are summed as 64-bit integers: a sum that does not depend on the order, so an edge pass (each
// pair once, Carter's Algorithm 2, adding each push to both ends) and a walk around v's fan
// (Overlaps::gather) give the same bits, for any thread count and on either backend (cuda.cu is
// compiled without FMA contraction). The sum is capped at `cap`·σ_v in length (the paper's σ/4
// against runaway corrections) and applied: x_v += d_v, wrapped into the box (apply_one).
// Counters (pairs found, pairs beyond the tolerance, summed |d_v| in 64-bit fixed point) are
// integer sums, hence order-independent too.
//
// A particle's d_v depends only on its own position and its neighbours', and is zero with no
// pairs unless it has an overlapping edge or (with walls, wall_term) overlaps a wall; the loops
// use that to visit only particles that can have one (cpu.cpp, cuda.cu): the same values as
// visiting every particle. A wall contact is one more pair of the particle's own sum (with its
// mirror image), in the same fixed point, so it changes none of these arguments.
#pragma once
#include <cmath>
#include <cstdint>

#include "core/physics/box.h"
#include "core/base/hd.h"
#include "stages/delaunay/common/mesh.h"

namespace ff::overlap {

using delaunay::load_halfedge;

enum Counter : int {
  kBad = 0,     // pairs with (σ_ij − r)/σ_ij > tolerance (each pair once)
  kPairs,       // pairs with r < σ_ij (each pair once)
  kCorrection,  // Σ_v |d_v| in units of 2^-32 · length_unit
  kBroken,      // vertices whose fan of half-edges does not close (corrupt triangulation)
  kTouched,     // particles touched for the first time in the step (counted only with a touched field)
  kCounters
};

// No vertex of a sane triangulation has this many neighbours; a longer walk means a broken mesh.
inline constexpr int kMaxFan = 4096;
inline constexpr double kFixedOne = 4294967296.0;  // 2^32
// What a pair term found (pair_term_d, wall_term): apart (no push), or overlapping (a push) by a
// depth σ − r that is zero (at contact up to rounding: a zero push, not counted as a pair), within
// the tolerance (depth ≤ tol·σ) or beyond it. The depth is compared with tol·σ rather than the
// relative overlap (σ − r)/σ with tol: a division less in the gather's chain of dependent
// operations, where each double division costs ~100 cycles on the device (bench/experiments,
// "The pair math of a gather").
enum PairOverlap : int { kApart = -1, kAtContact = 0, kWithin = 1, kBeyond = 2 };
// Overlaps::edge's answers.
inline constexpr int kEdgeApart = 0, kEdgeOverlap = 1, kEdgeCorrupt = -1;
// Pushes are summed in units of 2^-50·unit: |d| up to 8192 units, resolution 8.9e-16 units.
inline constexpr double kPushOne = 1125899906842624.0;  // 2^50

FF_HD void add_u64(std::uint64_t* p, std::uint64_t v) {
#if defined(__CUDA_ARCH__)
  atomicAdd(reinterpret_cast<unsigned long long*>(p), static_cast<unsigned long long>(v));
#else
  __atomic_fetch_add(p, v, __ATOMIC_RELAXED);
#endif
}

// The push on particle v from neighbour u at minimum-image offset r = x_u − x_v (D components):
// the term t that v's displacement loses (d_v −= t), when |r|² < σ_vu² (else kApart, and t is left
// alone); the answer classifies the depth σ_vu − r against tol·σ_vu. The term on u from v is −t,
// bit for bit: r negates exactly, and so does the coincident-centres rule. One rule for the
// Delaunay variant (2D) and the Verlet-list variant (2D and 3D, verlet/kernel.h), so both push a
// pair by the same bits. (δ/r is one division for all components: the push is δ/r·r_k.)
template <int D>
FF_HD PairOverlap pair_term_d(const double* r, double sv, double su, double factor, double tol, int v, int u,
                              double* t) {
  const double s = 0.5 * (sv + su);
  double r2 = r[0] * r[0];
  for (int k = 1; k < D; ++k) r2 += r[k] * r[k];
  if (!(r2 < s * s)) return kApart;
  const double len = std::sqrt(r2);  // ≤ s: sqrt is monotone and sqrt(fl(s²)) = s
  const double depth = s - len;
  const double delta = factor * depth;
  if (len > 0) {
    const double per_length = delta / len;
    for (int k = 0; k < D; ++k) t[k] = per_length * r[k];
  } else {  // coincident centres: separate along x, the lower index towards −x
    t[0] = v < u ? delta : -delta;
    for (int k = 1; k < D; ++k) t[k] = 0;
  }
  return depth > tol * s ? kBeyond : depth > 0 ? kWithin : kAtContact;
}

// Whether a pair term's answer is a pair the counters count (an overlap deeper than rounding).
FF_HD bool counted(PairOverlap o) { return o >= kWithin; }

// Hard planar walls at 0 and L along one axis (seed-gaps D2, W1). A particle of diameter sv at
// distance h < sv/2 from a wall overlaps its mirror image (at 2h, σ = sv), and the pair rule
// above moves it by factor·(sv − 2h) away from the wall: reflect gives h' = sv − h, the reflection
// about the contact plane h = sv/2; contact gives h' = sv/2. h is taken on the unwrapped coordinate
// u = x + L·image: with walls a particle between them has image 0, and one that an integrator
// carried through a wall (wrapped to the far side, image ±1) has h < 0 and is reflected back
// (u' = sv − u), which brings its image count back to 0 when the move is applied. (The mirror
// pair's own formula would push such a particle outwards: the wall's normal is used instead.)
// Returns the signed displacement along the axis in push, or kApart (push left alone); the answer
// classifies the depth sv − 2h (> 0; above sv for a particle beyond the wall) against tol·sv.
FF_HD PairOverlap wall_term(double x, std::int32_t image, double L, double sv, double factor, double tol,
                            double& push) {
  const double u = x + L * double(image);
  const double half = 0.5 * sv;
  double h, dir;
  if (u < half) {
    h = u;
    dir = 1;
  } else if (L - u < half) {
    h = L - u;
    dir = -1;
  } else {
    return kApart;
  }
  const double excess = sv - 2 * h;
  push = dir * (factor * excess);
  return excess > tol * sv ? kBeyond : kWithin;
}

// Whether a particle at x (image count `image`) overlaps a wall, a little more loosely than
// wall_term (as Overlaps::overlaps_after_move is looser than a gather): rounding can only add
// particles to the next iteration's candidates.
FF_HD bool near_wall(double x, std::int32_t image, double L, double sv) {
  constexpr double kLoose = 1 + 1e-9;
  const double u = x + L * double(image);
  const double half = 0.5 * sv * kLoose;
  return u < half || L - u < half;
}

// pair_term_d in 2D, at offset (rx, ry), into (tx, ty).
FF_HD PairOverlap pair_term(double rx, double ry, double sv, double su, double factor, double tol, int v, int u,
                            double& tx, double& ty) {
  const double r[2] = {rx, ry};
  double t[2];
  const PairOverlap o = pair_term_d<2>(r, sv, su, factor, tol, v, u, t);
  if (o != kApart) {
    tx = t[0];
    ty = t[1];
  }
  return o;
}

// A push in the sums' fixed point, 2^-50·unit (rint is odd: the push of −t is −(that of t)).
FF_HD std::int64_t fixed_push(double t, double inv_unit) { return std::int64_t(std::rint(t * (inv_unit * kPushOne))); }

// The length of one unit of the pushes' fixed point, 2^-50·unit; computed once with the push rule
// (PushRule::push_length), not in each particle's finish: a division is ~100 cycles on the device.
FF_HD double push_length(double inv_unit) { return 1.0 / (inv_unit * kPushOne); }

// A particle's displacement from its summed pushes q (D components, fixed point; one unit is
// push_length), capped at cap·σ_v in length, into d; returns its length.
template <int D>
FF_HD double finish_d(const std::int64_t* q, double sv, double cap, double push_length, double* d) {
  for (int k = 0; k < D; ++k) d[k] = double(q[k]) * push_length;
  double len2 = d[0] * d[0];
  for (int k = 1; k < D; ++k) len2 += d[k] * d[k];
  // The cap is tested on the squares, so an uncapped d (nearly all) does not wait for the sqrt,
  // which only its length, a counter, needs.
  const double limit = cap * sv;
  if (len2 > limit * limit) {
    const double s = limit / std::sqrt(len2);
    for (int k = 0; k < D; ++k) d[k] *= s;
    return limit;
  }
  return std::sqrt(len2);
}

// |d_v| in the correction counter's fixed point, 2^-32·unit.
FF_HD std::uint64_t fixed_len(double len, double inv_unit) {
  return len > 0 ? std::uint64_t(std::llround(len * inv_unit * kFixedOne)) : 0;
}

// pair_term added to (dx, dy). (A displacement sum starts at +0 and never becomes −0, since
// x − x = +0, so subtracting a zero term, of either sign, leaves it as it is.)
FF_HD PairOverlap pair_push(double rx, double ry, double sv, double su, double factor, double tol, int v, int u,
                            double& dx, double& dy) {
  double tx, ty;
  const PairOverlap o = pair_term(rx, ry, sv, su, factor, tol, v, u, tx, ty);
  if (o != kApart) {
    dx -= tx;
    dy -= ty;
  }
  return o;
}

// Loads. On the device, positions move during the persistent kernel (other blocks write them
// between grid barriers), so they are never read through the read-only path (ld.global.nc),
// which is not kept coherent within a kernel. They are plain loads, cached in L1: each phase
// between two barriers only reads them, and a grid barrier (cg::grid_group::sync, an acquire at
// GPU scope) invalidates the L1 before anything after it reads, so a plain load sees every write
// made before the barrier (the tail's __syncthreads does the same within block 0's SM). L1 hits
// matter: a block's particles are neighbours of each other (Hilbert order), and each position
// is read by ~6 walks; with ld.global.cg (L2 only) every one of those reads went to L2, and at
// N = 2^20 the stage was bound by that traffic (bench/overlap_correct-PERF.md, session 5). The
// half-edges are read-only for the whole stage (__ldg).
template <class R>
FF_HD void load_xy(const R* pos, int v, double& x, double& y) {
#if defined(__CUDA_ARCH__)
  if constexpr (sizeof(R) == 8) {
    const double2 p = reinterpret_cast<const double2*>(pos)[v];
    x = p.x;
    y = p.y;
  } else {
    const float2 p = reinterpret_cast<const float2*>(pos)[v];
    x = double(p.x);
    y = double(p.y);
  }
#else
  x = double(pos[2 * v]);
  y = double(pos[2 * v + 1]);
#endif
}

// Edge e = half-edges 2e and 2e + 1, one 16-byte record {origin(2e), next(2e), origin(2e+1),
// next(2e+1)}: its two ends a, b and the half-edges that follow each side.
FF_HD void load_edge(const std::int32_t* he, std::size_t e, int& a, int& na, int& b, int& nb) {
#if defined(__CUDA_ARCH__)
  const int4 r = __ldg(reinterpret_cast<const int4*>(he) + e);
  a = r.x;
  na = r.y;
  b = r.z;
  nb = r.w;
#else
  a = he[4 * e];
  na = he[4 * e + 1];
  b = he[4 * e + 2];
  nb = he[4 * e + 3];
#endif
}

// Permutation check of the next pointers: Σ_h mix(next(h)) must equal Σ_h mix(h) (mod 2^64).
// A corrupt mesh whose next pointers are not a permutation fails it unless the 64-bit sums
// collide by chance; next is a permutation exactly when every fan walk (next ∘ twin) closes.
FF_HD std::uint64_t mix(std::uint64_t x) {
  x *= 0x9e3779b97f4a7c15ull;
  return x ^ (x >> 29);
}
inline std::uint64_t mix_sum(std::uint64_t count) {
  std::uint64_t s = 0;
  for (std::uint64_t h = 0; h < count; ++h) s += mix(h);
  return s;
}

// The push rule's constants in a step, for both corrections' gathers (Overlaps here, the Verlet
// variant's Gather in verlet/kernel.h): one definition, filled by params.h's push_rule, so that
// the two variants push with the same numbers and give the same bits for the same pairs.
struct PushRule {
  PeriodicBox<double> box;
  double factor;    // 1 = reflect, 0.5 = contact
  double cap;       // fraction of σ_v
  double tol;       // relative overlap that still counts as converged
  double inv_unit;     // 1 / length unit (the largest diameter at configure)
  double push_length;  // push_length(inv_unit): one unit of the pushes' fixed point
  // Every diameter when they are all equal (else 0): the gathers then read no diameters at all.
  // At N = 2^20 a gather's three loads per neighbour (half-edge, position, diameter) do not fit
  // in the GPU's L2, so one load fewer is traffic saved; the value is the same bits.
  double uniform = 0;
  // Walls (wall_term): the axis they cut (0: x, 1: y, 2: z; -1: none). Along that axis a pair's
  // offset is the plain difference of the coordinates, not the minimum image: no pair interacts
  // across a wall.
  int wall_axis = -1;

  // The rule with its derived field (push_length) filled in: build one through this (or
  // params.h's push_rule), not field by field.
  static PushRule make(const PeriodicBox<double>& box, double factor, double cap, double tol, double inv_unit,
                       double uniform = 0, int wall_axis = -1) {
    return {box, factor, cap, tol, inv_unit, overlap::push_length(inv_unit), uniform, wall_axis};
  }
};

// What one particle's gather found.
struct VertexPush {
  double dx = 0, dy = 0;  // capped displacement
  double x = 0, y = 0;    // v's position as the gather read it (where the device's gather moves it from)
  double len = 0;         // its length
  unsigned pairs = 0;     // overlapping pairs with v < u
  unsigned bad = 0;       // of those, beyond the tolerance
  bool touched = false;   // some edge of v overlaps (r² < σ²), counted or not
  bool broken = false;    // the fan did not close within kMaxFan steps
};

// The overlap problem on the triangulation: the particles (positions, diameters), their Delaunay
// edges (half-edges), and the push rule; finds the overlapping pairs along the edges and the
// pushes they give (delaunay::Mesh is the triangulation alone).
// Walls: whether the wall code is compiled in (then wall_axis is 0 or 1). Without it the walks
// are the code they were before walls existed: no wall branch in the gathers and checks, a
// minimum image on both axes (the loops pick the variant once per step from the parameters).
template <class R, bool Walls = false>
struct Overlaps : PushRule {
  const R* pos;                // N x 2
  const R* diameter;           // N
  const std::int32_t* he;      // 2 x 6N: {origin, next}
  const std::int32_t* vedge;   // N
  std::int32_t n;              // particles (the mesh has 3n edges, 6n half-edges)
  double reach2;               // (largest diameter)²: no pair farther apart overlaps
  const std::int32_t* image = nullptr;  // N x 2: image counts, read with walls

  // The same problem with the wall code compiled in (W) or out (the members are the same).
  template <bool W>
  FF_HD Overlaps<R, W> with_walls() const {
    return {static_cast<const PushRule&>(*this), pos, diameter, he, vedge, n, reach2, image};
  }

  FF_HD double diameter_of(int v) const { return uniform > 0 ? uniform : double(diameter[v]); }

  // The wall term of v (at xv, yv with diameter sv) added to its fixed-point sum and counted in
  // out as a pair (v and its mirror image); nothing without walls. The image count is a plain
  // load: on the device, applies change it during the stage (see load_xy).
  FF_HD void gather_wall(int v, double xv, double yv, double sv, std::int64_t& qx, std::int64_t& qy,
                         VertexPush& out) const {
    if constexpr (Walls) {
      double push;
      const PairOverlap o =
          wall_term(wall_axis == 0 ? xv : yv, image[2 * v + wall_axis], box.L[wall_axis], sv, factor, tol, push);
      if (o == kApart) return;
      (wall_axis == 0 ? qx : qy) += fixed_push(push);
      out.touched = true;
      ++out.pairs;
      if (o == kBeyond) ++out.bad;
    }
  }
  // Whether v (at xv, yv with diameter sv) overlaps a wall at its new position (near_wall).
  FF_HD bool wall_after_move(int v, double xv, double yv, double sv) const {
    if constexpr (Walls)
      return near_wall(wall_axis == 0 ? xv : yv, image[2 * v + wall_axis], box.L[wall_axis], sv);
    else
      return false;
  }

  // Calls f(u, h) for each neighbour u of v in fan order (h = the half-edge v -> u); returns
  // false when the fan does not close, an index is out of range (nothing out of range is read)
  // or an edge leads back to v.
  template <class F>
  FF_HD bool for_each_neighbor(int v, F&& f) const {
    const unsigned nh = 6u * unsigned(n);
    const int h0 = vedge[v];
    if (unsigned(h0) >= nh) return false;
    int h = h0, steps = 0;
    do {
      int u, hn;
      load_halfedge(he, h ^ 1, u, hn);  // twin(h) = u -> v; next(twin(h)) leaves v again
      // u == v: a loop edge (a corrupt record); the CPU's edge pass also checks it, the device
      // finds it here, in iteration 0's walk around every particle.
      if (unsigned(u) >= unsigned(n) || u == v || unsigned(hn) >= nh) return false;
      f(u, h);
      h = hn;
      if (++steps > kMaxFan) return false;
    } while (h != h0);
    return true;
  }

  // box.min_image(d, k), bit for bit; on the host without the rounding when |d| ≤ L/4 (then
  // rint(d/L) = ±0 and the minimum image is d + 0: d, or +0 for d = −0).
  FF_HD double min_image(double d, int k) const {
    if (Walls && k == wall_axis) return d + 0.0;  // no pair across a wall
#if !defined(__CUDA_ARCH__)
    if (std::fabs(d) <= 0.25 * box.L[k]) return d + 0.0;
#endif
    return box.min_image(d, k);
  }

  // A push in the sums' fixed point (rint is odd: the push of −t is −(that of t)).
  FF_HD std::int64_t fixed_push(double t) const { return overlap::fixed_push(t, inv_unit); }

  // Edge e of an edge pass: its ends a, b; whether they overlap, and then the push on a in fixed
  // point (qx, qy; the push on b is −q) and pair_term's answer o. With Check (the first pass of
  // a step) its next pointers are checked too: in range, and added to the permutation check.
  // Returns kEdgeApart, kEdgeOverlap, or kEdgeCorrupt when an index it uses is out of range or
  // the edge is a loop (a = b; nothing else is read then). Most edges end at the reach test,
  // before any diameter is read.
  template <bool Check>
  FF_HD int edge(std::size_t e, int& a, int& b, std::int64_t& qx, std::int64_t& qy, PairOverlap& o,
                 std::uint64_t& next_hash) const {
    if (!edge_ends(e, a, b, Check, next_hash)) return kEdgeCorrupt;
    double xa, ya, xb, yb;
    load_xy(pos, a, xa, ya);
    load_xy(pos, b, xb, yb);
    double rx = xb - xa, ry = yb - ya;
#if !defined(__CUDA_ARCH__)
    if (std::fabs(rx) <= 0.25 * box.L[0] && std::fabs(ry) <= 0.25 * box.L[1]) {  // as min_image() does
      if (!(rx * rx + ry * ry < reach2)) return kEdgeApart;
      rx += 0.0;
      ry += 0.0;
    } else
#endif
    {
      rx = Walls && wall_axis == 0 ? rx + 0.0 : box.min_image(rx, 0);
      ry = Walls && wall_axis == 1 ? ry + 0.0 : box.min_image(ry, 1);
    }
    if (!(rx * rx + ry * ry < reach2)) return kEdgeApart;  // σ_ab ≤ largest diameter
    return edge_push(a, b, rx, ry, qx, qy, o);
  }

  // Edge record e's ends a, b, checked as an edge pass checks them: in range and distinct; with
  // `check` (a step's first pass) its next pointers in range too, their mixes added to the
  // permutation check. False for a corrupt record (nothing else is read then). The CPU's edge
  // pass (edge) and the device's dense block (dense_block.cuh) both check records by it.
  FF_HD bool edge_ends(std::size_t e, int& a, int& b, bool check, std::uint64_t& next_hash) const {
    int na, nb;
    load_edge(he, e, a, na, b, nb);
    return edge_ends_checked(a, na, b, nb, check, next_hash);
  }
  // edge_ends of a record already loaded (load_edge): ends a, b and next pointers na, nb.
  FF_HD bool edge_ends_checked(int a, int na, int b, int nb, bool check, std::uint64_t& next_hash) const {
    if (unsigned(a) >= unsigned(n) || unsigned(b) >= unsigned(n) || a == b) return false;
    if (check) {
      if (unsigned(na) >= 6u * unsigned(n) || unsigned(nb) >= 6u * unsigned(n)) return false;
      next_hash += mix(std::uint64_t(unsigned(na))) + mix(std::uint64_t(unsigned(nb)));
    }
    return true;
  }

  // The push along edge (a, b) at the minimum-image offset (rx, ry) = x_b − x_a: pair_term's answer
  // o and, when they overlap (kEdgeOverlap), the push on a in fixed point (qx, qy; the push on b
  // is −q); else kEdgeApart. An edge pass's pair math (edge; the dense block's pushes).
  FF_HD int edge_push(int a, int b, double rx, double ry, std::int64_t& qx, std::int64_t& qy, PairOverlap& o) const {
    double tx, ty;
    o = pair_term(rx, ry, diameter_of(a), diameter_of(b), factor, tol, a, b, tx, ty);
    if (o == kApart) return kEdgeApart;
    qx = -fixed_push(tx);
    qy = -fixed_push(ty);
    return kEdgeOverlap;
  }

  // The check after an apply, for a particle v that moved: calls f(u) for each neighbour u
  // that overlaps v at the new positions and returns whether any did. The test is a little
  // looser than a gather's (r² < σ²·(1 + 1e-9)), so rounding can only add particles to the
  // next iteration's candidates, never leave one out. Both loops build their work lists with it.
  template <class F>
  FF_HD bool overlapping_neighbors(int v, F&& f) const {
    return overlapping_neighbors_by(v, fan_of(v), f);
  }

  // The walk around v's fan as a neighbour source: neighbours(g) calls g(u) for each
  // neighbour u and returns false when the fan does not close (see for_each_neighbor). The
  // device loop also has another source of the same neighbours (a per-step copy, cuda.cu).
  FF_HD auto fan_of(int v) const {
    return [this, v](auto&& g) { return for_each_neighbor(v, [&](int u, int) { g(u); }); };
  }

  template <class N, class F>
  FF_HD bool overlapping_neighbors_by(int v, N&& neighbors, F&& f) const {
    double xv, yv;
    load_xy(pos, v, xv, yv);
    const double sv = diameter_of(v);
    bool any = false;
    neighbors([&](int u) {
      if (overlaps_after_move(xv, yv, sv, u)) {
        f(u);
        any = true;
      }
    });
    return wall_after_move(v, xv, yv, sv) || any;
  }

  // The check's test for one neighbour u of v (at xv, yv with diameter sv); see above.
  FF_HD bool overlaps_after_move(double xv, double yv, double sv, int u) const {
    double xu, yu;
    load_xy(pos, u, xu, yu);
    return overlaps_after_move_at(xv, yv, sv, u, xu, yu);
  }
  FF_HD bool overlaps_after_move_at(double xv, double yv, double sv, int u, double xu, double yu) const {
    constexpr double kLoose = 1 + 1e-9;
    const double rx = min_image(xu - xv, 0), ry = min_image(yu - yv, 1);
    const double s = 0.5 * (sv + diameter_of(u));
    return rx * rx + ry * ry < s * s * kLoose;
  }

  // v's displacement from its summed pushes (qx, qy), capped at cap·σ_v, into out.
  FF_HD void finish(std::int64_t qx, std::int64_t qy, double sv, VertexPush& out) const {
    const std::int64_t q[2] = {qx, qy};
    double d[2];
    out.len = finish_d<2>(q, sv, cap, push_length, d);
    out.dx = d[0];
    out.dy = d[1];
  }

  // Particle v's walk around its fan: every edge, its pushes summed, its pairs counted.
  FF_HD VertexPush gather(int v) const { return gather_by(v, fan_of(v)); }

  // The same from another source of v's neighbours (fan_of's contract; any order: the sums are
  // in fixed point).
  template <class N>
  FF_HD VertexPush gather_by(int v, N&& neighbors) const {
    VertexPush out;
    double xv, yv;
    load_xy(pos, v, xv, yv);
    const double sv = diameter_of(v);
    std::int64_t qx = 0, qy = 0;
    out.broken = !neighbors([&](int u) { gather_pair(v, xv, yv, sv, u, qx, qy, out); });
    gather_wall(v, xv, yv, sv, qx, qy, out);
    finish(qx, qy, sv, out);
    out.x = xv;
    out.y = yv;
    return out;
  }

  // Whether u (at xu, yu) overlaps v (at xv, yv with diameter sv) by pair_term's own test
  // (r² < σ_vu², the same operations): exactly the pairs for which gather_pair_at adds a push.
  FF_HD bool overlaps_at(double xv, double yv, double sv, int u, double xu, double yu) const {
    const double r[2] = {min_image(xu - xv, 0), min_image(yu - yv, 1)};
    const double s = 0.5 * (sv + diameter_of(u));
    double r2 = r[0] * r[0];
    r2 += r[1] * r[1];
    return r2 < s * s;
  }

  // One neighbour u's part of v's gather (v at xv, yv with diameter sv): its push subtracted
  // from the fixed-point sum (qx, qy), and out's touched / pairs / bad. The parts of v's
  // neighbours may be summed in any order, or apart and then added (the device's lane groups).
  FF_HD void gather_pair(int v, double xv, double yv, double sv, int u, std::int64_t& qx, std::int64_t& qy,
                         VertexPush& out) const {
    double xu, yu;
    load_xy(pos, u, xu, yu);
    gather_pair_at(v, xv, yv, sv, u, xu, yu, qx, qy, out);
  }
  // The same with u's position loaded by the caller (the device loads a particle's neighbours
  // all at once).
  FF_HD void gather_pair_at(int v, double xv, double yv, double sv, int u, double xu, double yu, std::int64_t& qx,
                            std::int64_t& qy, VertexPush& out) const {
    double tx, ty;
    const PairOverlap o =
        pair_term(min_image(xu - xv, 0), min_image(yu - yv, 1), sv, diameter_of(u), factor, tol, v, u, tx, ty);
    if (o == kApart) return;
    qx -= fixed_push(tx);
    qy -= fixed_push(ty);
    out.touched = true;
    if (v < u && counted(o)) {
      ++out.pairs;
      if (o == kBeyond) ++out.bad;
    }
  }

  // What a gather of v gives when an edge pass has summed its pushes already (pairs are counted
  // by the edge pass, not here).
  FF_HD VertexPush from_sum(int v, std::int64_t qx, std::int64_t qy) const {
    VertexPush out;
    out.touched = true;
    finish(qx, qy, diameter_of(v), out);
    return out;
  }

  // |d_v| in the correction counter's fixed point.
  FF_HD std::uint64_t fixed_len(double len) const { return overlap::fixed_len(len, inv_unit); }
};

// Where x_v + d_v lands (D components), each coordinate wrapped into the box, and the box
// crossings that adds to its image counts; a zero component leaves its coordinate as it is (and
// crosses nothing), for a particle at x0. The device computes it where it gathered v, from the
// position the gather read (VertexPush::x, y), and its apply only stores the result
// (correct_kernel.cuh).
template <int D, class R>
FF_HD void moved_from(const R* x0, const PeriodicBox<R>& box, const double* d, R* x, int* crossed) {
  for (int k = 0; k < D; ++k) {
    x[k] = x0[k];
    crossed[k] = 0;
    if (d[k] == 0) continue;
    x[k] = R(double(x[k]) + d[k]);
    box.wrap(x[k], crossed[k], k);
  }
}
// moved_from of particle i's position in pos.
template <int D, class R>
FF_HD void moved_d(const R* pos, const PeriodicBox<R>& box, std::size_t i, const double* d, R* x, int* crossed) {
  moved_from<D>(pos + D * i, box, d, x, crossed);
}

// x_v += d_v (D components), each coordinate wrapped into the box; a zero component leaves its
// coordinate alone.
template <int D, class R>
FF_HD void apply_d(R* pos, std::int32_t* image, const PeriodicBox<R>& box, std::size_t i, const double* d) {
  R x[D];
  int crossed[D];
  moved_d<D>(pos, box, i, d, x, crossed);
  for (int k = 0; k < D; ++k) {
    if (d[k] == 0) continue;
    pos[D * i + k] = x[k];
    image[D * i + k] += crossed[k];
  }
}

// apply_d in 2D.
template <class R>
FF_HD void apply_one(R* pos, std::int32_t* image, const PeriodicBox<R>& box, std::size_t i, double dx, double dy) {
  const double d[2] = {dx, dy};
  apply_d<2>(pos, image, box, i, d);
}

}  // namespace ff::overlap
