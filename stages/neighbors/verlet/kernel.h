// Cell list + Verlet list, per-element math for both backends (Tran et al. 2015, section 3).
//
// The box is cut into nc[k] ≥ 1 cells per axis of edge ≥ r_list = cutoff + skin, so every
// neighbour of a particle lies in its own or an adjacent cell. Particles are binned
// (AssignCell), ordered by cell (the backend's sort, giving `order` and per-cell ranges), and
// each particle's row is filled by scanning the 3^D cells around it (BuildList, launched over
// the cell order so neighbouring threads read neighbouring particles). Axes with fewer than
// three cells are scanned whole, so no cell is visited twice. A row is then sorted by particle
// index: the list content is a set, and its order never depends on the binning or the backend.
//
// Rebuild test (Tran's dynamic test): MovedTooFar is 1 for a particle whose minimum-image
// displacement since the last build exceeds skin/2; any such particle triggers a rebuild.
#pragma once
#include <cmath>
#include <cstdint>

#include "core/physics/box.h"
#include "core/base/hd.h"

namespace ff::neighbors {

template <class R, int D>
struct Grid {
  PeriodicBox<R> box;
  int nc[3];  // cells per axis (1 for unused axes)

  FF_HD int coord(R x, int k) const {
    R u = x * box.inv_L[k];
    u -= std::floor(u);  // tolerate positions a step outside [0, L)
    int c = int(u * R(nc[k]));
    return c < 0 ? 0 : (c >= nc[k] ? nc[k] - 1 : c);
  }
  FF_HD std::uint32_t index(const int c[3]) const {
    return std::uint32_t(c[0] + nc[0] * (c[1] + (D == 3 ? nc[1] * c[2] : 0)));
  }
  FF_HD std::uint32_t cell_of(const R* x) const {
    int c[3] = {0, 0, 0};
    for (int k = 0; k < D; ++k) c[k] = coord(x[k], k);
    return index(c);
  }
};

template <class R, int D>
struct AssignCell {
  const R* position;
  std::uint32_t* cell;
  Grid<R, D> grid;

  FF_HD void operator()(std::size_t i) const { cell[i] = grid.cell_of(&position[i * D]); }
};

template <class R, int D>
struct MovedTooFar {
  const R* position;
  const R* at_build;
  PeriodicBox<R> box;
  R limit2;  // (skin/2)^2

  FF_HD std::uint32_t operator()(std::size_t i) const {
    R d2 = 0;
    for (int k = 0; k < D; ++k) {
      const R d = box.min_image(position[i * D + k] - at_build[i * D + k], k);
      d2 += d * d;
    }
    return d2 > limit2 ? 1u : 0u;
  }
};

struct CountOf {
  const std::uint32_t* count;
  FF_HD std::uint32_t operator()(std::size_t i) const { return count[i]; }
};

template <class R, int D>
struct BuildList {
  const R* position;
  const std::uint32_t* order;       // particles by cell
  const std::uint32_t* cell_start;  // per cell: [start, end) in `order`
  const std::uint32_t* cell_end;
  Grid<R, D> grid;
  R radius2;                        // (cutoff + skin)^2
  std::uint32_t capacity;
  std::uint32_t* list;              // N x capacity
  std::uint32_t* count;             // true number of neighbours (may exceed capacity: then grow)
  R* at_build;                      // positions the list was built from (null: `position` is them already)
  // The particles' global ids in a decomposed team (core/run/domain.h), whose ranks hold their
  // particles in an order of their own: rows are then sorted by id, the order one rank alone
  // sorts them in. Null: by index (= id).
  const std::uint32_t* id = nullptr;

  FF_HD void operator()(std::size_t p) const {
    const std::uint32_t i = order[p];
    const R* xi = &position[std::size_t(i) * D];
    int c[3] = {0, 0, 0}, first[3] = {0, 0, 0}, span[3] = {1, 1, 1};
    for (int k = 0; k < D; ++k) {
      c[k] = grid.coord(xi[k], k);
      if (grid.nc[k] >= 3) {
        first[k] = c[k] - 1;
        span[k] = 3;
      } else {
        span[k] = grid.nc[k];
      }
    }
    std::uint32_t* row = &list[std::size_t(i) * capacity];
    std::uint32_t n = 0;
    for (int a = 0; a < span[2]; ++a)
      for (int b = 0; b < span[1]; ++b)
        for (int e = 0; e < span[0]; ++e) {
          const int off[3] = {e, b, a};
          int cc[3] = {0, 0, 0};
          for (int k = 0; k < D; ++k) cc[k] = (first[k] + off[k] + grid.nc[k]) % grid.nc[k];
          const std::uint32_t cell = grid.index(cc);
          for (std::uint32_t q = cell_start[cell]; q < cell_end[cell]; ++q) {
            const std::uint32_t j = order[q];
            if (j == i) continue;
            R d2 = 0;
            for (int k = 0; k < D; ++k) {
              const R d = grid.box.min_image(position[std::size_t(j) * D + k] - xi[k], k);
              d2 += d * d;
            }
            if (d2 <= radius2) {
              if (n < capacity) row[n] = j;
              ++n;
            }
          }
        }
    count[i] = n;
    if (at_build)
      for (int k = 0; k < D; ++k) at_build[std::size_t(i) * D + k] = xi[k];
    if (n <= capacity) {  // ascending index (or id) order (insertion sort: rows are short)
      for (std::uint32_t a = 1; a < n; ++a) {
        const std::uint32_t v = row[a];
        std::uint32_t b = a;
        if (id) {
          for (; b > 0 && id[row[b - 1]] > id[v]; --b) row[b] = row[b - 1];
        } else {
          for (; b > 0 && row[b - 1] > v; --b) row[b] = row[b - 1];
        }
        row[b] = v;
      }
    }
  }
};

}  // namespace ff::neighbors
