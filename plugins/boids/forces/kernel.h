// The boids' steering (Reynolds' rules as in Porro et al.'s code, ../shared/specs/seed-gaps.md P2):
// boid i sees the boids j ≠ i closer than the view radius r_v whose direction d = x_j − x_i
// (minimum image) lies within the view angle θ_v of its heading u_i (d·u_i ≥ |d| cos θ_v), and
// steers by
//
//   F_i = A s_i + [n_i > 0] (C ā_i + B (c̄_i − x_i)),     s_i = −Σ_j d/|d|      (separation)
//                                                          ā_i = (1/n_i) Σ_j u_j (alignment)
//                                                          c̄_i − x_i = (1/n_i) Σ_j d (cohesion)
//
// n_i the number of boids seen. Separation adds unit vectors (not 1/r-weighted), as the code does.
// Cohesion sums the minimum-image differences d, never positions, so it is right across the
// periodic boundary. Boid i sums its own row of the neighbour list in list order (ascending j,
// stages/neighbors/list.h): the same terms in the same order on every backend, after every
// rebuild and from either list source (neighbors.verlet, neighbors.delaunay). math::mul_rn keeps
// the products out of fused multiply-adds.
//
// Every operation on the two components is the same with x and y swapped (sums of two products
// commute exactly), so a state symmetric under the mirror x ↔ y stays symmetric bit for bit.
#pragma once
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/base/hd.h"
#include "core/physics/box.h"
#include "core/physics/math.h"
#include "stages/neighbors/list.h"

namespace ff::boids {

template <class R>
struct Steering {
  const R* position;  // N x 2
  const R* heading;   // N x 2, unit vectors
  R* steering;        // N x 2: F_i (written for every boid)
  neighbors::ListView list;
  PeriodicBox<R> box;
  R view_radius2;     // r_v²
  R cos_view;         // cos θ_v
  bool full_view;     // θ_v ≥ π: every boid in range is seen (no angle test)
  R separation;       // A
  R alignment;        // C
  R cohesion;         // B

  FF_HD void operator()(std::size_t i) const {
    const R xi = position[2 * i], yi = position[2 * i + 1];
    const R ux = heading[2 * i], uy = heading[2 * i + 1];
    R sx = 0, sy = 0, ax = 0, ay = 0, cx = 0, cy = 0;
    std::uint32_t n = 0;
    const std::uint32_t* row = list.list + i * list.capacity;
    for (std::uint32_t k = 0; k < list.count[i]; ++k) {
      const std::uint32_t j = row[k];
      const R dx = box.min_image(position[2 * j] - xi, 0);
      const R dy = box.min_image(position[2 * j + 1] - yi, 1);
      const R r2 = math::mul_rn(dx, dx) + math::mul_rn(dy, dy);
      if (r2 >= view_radius2 || r2 == R(0)) continue;  // out of range (or coincident: no direction)
      const R r = std::sqrt(r2);
      if (!full_view && math::mul_rn(dx, ux) + math::mul_rn(dy, uy) < math::mul_rn(r, cos_view)) continue;  // behind
      ++n;
      sx -= dx / r;
      sy -= dy / r;
      ax += heading[2 * j];
      ay += heading[2 * j + 1];
      cx += dx;
      cy += dy;
    }
    R fx = math::mul_rn(separation, sx), fy = math::mul_rn(separation, sy);
    if (n > 0) {
      const R count = R(n);
      fx += math::mul_rn(alignment, ax / count) + math::mul_rn(cohesion, cx / count);
      fy += math::mul_rn(alignment, ay / count) + math::mul_rn(cohesion, cy / count);
    }
    steering[2 * i] = fx;
    steering[2 * i + 1] = fy;
  }
};

}  // namespace ff::boids
