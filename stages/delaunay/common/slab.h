// One rank's part of a decomposed Delaunay pipeline (issue 21 item 2, ../shared/specs/seed-gaps.md
// D4, docs/multi-gpu.md "Delaunay pipelines"): the particles a slab holds, their coordinates on the
// slab's *local torus*, and the band condition that makes the owned vertices' stars exact.
//
// Rank r of P owns the particles with x in the slab [r L/P, (r+1) L/P) and holds as ghosts the
// others within `band` g of it along x (periodic) — the rule of core/run/domain.h. Its local
// triangulation is the periodic Delaunay triangulation of the held particles in a box of width
// W = L/P + 2g (and the global height): x is shifted so that the slab lies in [g, W - g). Every
// Delaunay kernel then runs unchanged on the local state (it is just a smaller periodic box).
// Or (SlabCoordinates::global_with_gap) the held particles keep their global coordinates in the
// global box and fixed dummy vertices fill the gap beyond the band: kernels unchanged too, and
// every difference of held positions is the bits of one rank alone.
//
// Why owned stars are exact when every local triangle with an owned vertex v has circumdiameter
// 2R < g: the triangle's circumdisk contains v and has diameter < g, so every point of it lies
// within x-distance < g of the slab: inside (0, W) on the local torus (no seam, no periodic image
// of a held particle can fall in it) and, in the global box, within the band, so every particle
// in it is held. Locally Delaunay, the disk holds no held particle, so it holds no particle at
// all: the triangle is a Delaunay triangle of the global set. The closed fan of such triangles
// around v is then v's global star (for points in general position, where the Delaunay
// triangulation is unique). 2R ≥ g for some such triangle means the band may be too narrow
// (the star may still be right: the condition is sufficient, not necessary); the remedy is a
// wider band, g > 2R_max. De Fabritiis & Coveney's ghost set (circumcircle crossing the slab
// face) is the exact minimal one; the band is a superset that a rank can choose before it has a
// triangulation. Tested: stages/delaunay/build/test_slab.cpp.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/base/error.h"

namespace ff::delaunay {

struct Slab {
  int rank = 0, ranks = 1;
  double Lx = 0, Ly = 0;  // the global box
  double band = 0;        // g

  double lo() const { return Lx * double(rank) / double(ranks); }
  double hi() const { return Lx * double(rank + 1) / double(ranks); }
  double width() const { return hi() - lo() + 2 * band; }  // W, the local torus' width

  // The slab that owns a particle at x (as Domain::owner_of).
  int owner_of(double x) const {
    const int r = int(std::floor(x / Lx * double(ranks)));
    return std::min(std::max(r, 0), ranks - 1);
  }
  // Whether a particle at x lies within the band of this slab, along x, periodic (as
  // Domain::ghost_of, with its margin for the rounding of positions on a slab's edge).
  bool in_band(double x) const {
    double best = Lx;
    for (int k = -1; k <= 1; ++k) {
      const double y = x + double(k) * Lx;
      best = std::min(best, std::max({lo() - y, y - hi(), 0.0}));
    }
    return best <= band + 1e-9 * Lx;
  }
  // x on the local torus: the image of x nearest the slab's centre, shifted so the slab starts
  // at g, wrapped into [0, W).
  double local_x(double x) const {
    const double centre = 0.5 * (lo() + hi());
    double d = x - centre;
    d -= Lx * std::rint(d / Lx);
    const double W = width();
    double u = d + 0.5 * W;
    u -= W * std::floor(u / W);
    if (u >= W) u -= W;
    return u;
  }
};

// How a slab's held particles are placed in a periodic box the Delaunay kernels run on.
//  - local_torus: D4's design, x shifted onto the torus of width W. x - shift is not exact in
//    floating point, so stages that move particles in these coordinates do not give the bits of
//    one rank.
//  - global_with_gap: the coordinates stay the global ones, in the global box, and the gap beyond
//    the band (x-distance > g from the slab) is filled with fixed dummy vertices on a staggered
//    lattice, so that no Delaunay edge spans it (edges stay shorter than half the box). The same
//    proof holds (a disk within the band holds no dummy); every difference of held positions,
//    and its minimum image, is then the one alone, and no band is too wide (W ≥ L: no gap).
enum class SlabCoordinates { local_torus, global_with_gap };

// The particles a slab holds: owned first, then ghosts, each in ascending global index, then (in
// global_with_gap) the dummies, whose id is kDummy; their coordinates in the box box_x x Ly.
struct SlabPoints {
  static constexpr std::uint32_t kDummy = 0xffffffffu;
  std::vector<std::uint32_t> id;  // global index of each held particle
  std::size_t n_owned = 0, n_held = 0;
  std::vector<double> xy;         // x0 y0 x1 y1 ...
  double box_x = 0;
};

// Dummy vertices in the gap beyond the band: columns at most `spacing` apart strictly inside
// (hi + g, lo - g + Lx) (periodic), rows at most `spacing` apart, odd columns shifted half a row.
inline void fill_gap(const Slab& slab, double spacing, SlabPoints& out) {
  const double gap = slab.Lx - slab.width();
  if (!(gap > 0)) return;
  const int nx = std::max(1, int(std::ceil(gap / spacing))), ny = std::max(3, int(std::ceil(slab.Ly / spacing)));
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j) {
      double x = slab.hi() + slab.band + (i + 0.5) * gap / nx;
      x -= slab.Lx * std::floor(x / slab.Lx);
      out.id.push_back(SlabPoints::kDummy);
      out.xy.push_back(x);
      out.xy.push_back((j + 0.25 + 0.5 * (i % 2)) * slab.Ly / ny);
    }
}

// xy: the global positions (wrapped into the box). local_torus: InputError when the torus would
// not be smaller than the box (W ≥ Lx: a particle would be held twice; use fewer ranks).
// gap_spacing: the dummies' spacing (global_with_gap; the band g when 0).
inline SlabPoints slab_points(const Slab& slab, const std::vector<double>& xy,
                              SlabCoordinates c = SlabCoordinates::local_torus, double gap_spacing = 0) {
  const bool local = c == SlabCoordinates::local_torus;
  if (local && !(slab.width() < slab.Lx))
    throw InputError("decomposed Delaunay: the band " + std::to_string(slab.band) + " on both sides of a slab of " +
                     std::to_string(slab.hi() - slab.lo()) + " is as wide as the box (" + std::to_string(slab.Lx) +
                     "): use fewer ranks");
  const std::size_t n = xy.size() / 2;
  SlabPoints out;
  out.box_x = local ? slab.width() : slab.Lx;
  for (int pass = 0; pass < 2; ++pass)
    for (std::size_t i = 0; i < n; ++i) {
      const double x = xy[2 * i];
      const bool owned = slab.owner_of(x) == slab.rank;
      if (pass == 0 ? !owned : (owned || !slab.in_band(x))) continue;
      out.id.push_back(std::uint32_t(i));
      out.xy.push_back(local ? slab.local_x(x) : x);
      out.xy.push_back(xy[2 * i + 1]);
      if (pass == 0) ++out.n_owned;
    }
  out.n_held = out.id.size();
  if (!local) fill_gap(slab, gap_spacing > 0 ? gap_spacing : slab.band, out);
  return out;
}

// The largest circumdiameter of the triangles of a local triangulation (half-edges as
// fields::halfedge: origin, next) that have a vertex below n_owned; coordinates as
// SlabPoints::xy, box W x Ly, edges minimum images. The owned stars are exact when it is < g.
inline double max_owned_circumdiameter(const std::int32_t* he, std::size_t n, std::size_t n_owned, const double* xy,
                                       double W, double Ly) {
  auto image = [](double d, double L) { return d - L * std::rint(d / L); };
  double worst = 0;
  for (int h = 0; h < int(6 * n); ++h) {
    const int h1 = he[2 * h + 1], h2 = he[2 * h1 + 1];
    if (!(h < h1 && h < h2)) continue;  // each triangle once
    const int a = he[2 * h], b = he[2 * h1], c = he[2 * h2];
    if (std::size_t(a) >= n_owned && std::size_t(b) >= n_owned && std::size_t(c) >= n_owned) continue;
    const double bx = image(xy[2 * b] - xy[2 * a], W), by = image(xy[2 * b + 1] - xy[2 * a + 1], Ly);
    const double cx = image(xy[2 * c] - xy[2 * a], W), cy = image(xy[2 * c + 1] - xy[2 * a + 1], Ly);
    const double cross = bx * cy - by * cx;
    const double ab = std::hypot(bx, by), ac = std::hypot(cx, cy), bc = std::hypot(cx - bx, cy - by);
    // 2R = |ab| |ac| |bc| / (2 area) = |ab| |ac| |bc| / |cross|
    worst = std::max(worst, ab * ac * bc / std::fabs(cross));
  }
  return worst;
}

// The star of vertex v, its neighbours in counter-clockwise order starting from the lowest
// (mapped through `id`; identity when null): what two triangulations must agree on at v.
inline std::vector<std::uint32_t> star(const std::int32_t* he, const std::int32_t* vedge, int v,
                                       const std::uint32_t* id = nullptr) {
  std::vector<std::uint32_t> ring;
  const int first = vedge[v];
  int h = first;
  do {
    const int to = he[2 * he[2 * h + 1]];  // the next half-edge's origin: h's end
    ring.push_back(id ? id[to] : std::uint32_t(to));
    const int prev = he[2 * he[2 * h + 1] + 1];  // next(next(h)) ends at v
    h = prev ^ 1;                                 // its twin leaves v, one neighbour on (CCW)
    if (ring.size() > 1000) throw RunError("delaunay star: the fan around a vertex does not close");
  } while (h != first);
  std::rotate(ring.begin(), std::min_element(ring.begin(), ring.end()), ring.end());
  return ring;
}

}  // namespace ff::delaunay
