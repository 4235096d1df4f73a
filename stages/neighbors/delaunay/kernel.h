// neighbors.delaunay: fixed-radius neighbours by graph search on the maintained Delaunay
// triangulation (Porro et al.; spec seed-gaps P1), per-element math for both backends.
//
// Why a search over Delaunay edges finds every neighbour: in a Delaunay triangulation, every
// q ≠ p has a Delaunay neighbour s with |ps| < |pq| (walk the segment q → p; where it leaves
// q's Voronoi cell, the cell beyond belongs to such an s). So each q within r of p is joined to
// p by a path of edges along which the distance to p strictly decreases: a search from p that
// expands only vertices within r of p reaches all of them.
//
// The triangulation is Delaunay for delaunay.position_prev (the positions delaunay.lawson
// worked on), and overlap correction may have moved particles since. With m the largest move
// since (MaxMove), a pair within r now was within r + 2m then, so the search walks the old
// positions expanding vertices within r_expand = r + 2m (plus a relative margin for Lawson's
// co-circular tolerance and rounding), and a vertex it reaches is accepted when its current
// distance is within r, by the same formula as neighbors.verlet's BuildList (so both sources
// list the same pairs at the same cutoff, bit for bit).
//
// Layout: GatherRing copies each vertex's one-ring (its neighbours, turning CCW from
// vertex_edge) into a padded array of `width` slots per vertex, so the search reads each ring
// contiguously. The search of p writes into p's row of neighbors.list, used as working memory
// of `capacity` slots until the accepted neighbours are compacted to its front and sorted:
//   visited  breadth-first; the row is the queue and the visited set. A 128-bit filter in
//            registers answers "not seen" for most new vertices without a scan of the row, and a
//            vertex seen before is skipped before its distance is computed again.
//   parent   depth-first without a visited set: q's parent is its ring member closest to p
//            (ties: lower index), which the lemma makes closer to p than q, so the parent links
//            form a tree rooted at p; the search descends from u to w iff parent(w) = u. The
//            row holds the tree's vertices from its front and the depth-first stack (ring slots
//            to resume at) from its back.
// Either returns (through the backend's max-reduction) the most row slots it held at once, or
// capacity + 1 when the row overflowed, with kRingOverflow set when p's degree exceeds `width`:
// the stage then grows the row or the ring and searches again, so an overflow is never silent.
// nvcc-clean.
#pragma once
#include <cmath>
#include <cstdint>
#include <cstring>

#include "core/base/hd.h"
#include "core/physics/box.h"
#include "stages/delaunay/common/mesh.h"

namespace ff::neighbors {

// Set in a search's result when the vertex has more ring members than the ring array's width.
inline constexpr std::uint32_t kRingOverflow = 0x80000000u;

// The bits of a non-negative float as an unsigned integer, which order as the floats do.
FF_HD std::uint32_t float_bits(float f) {
#if defined(__CUDA_ARCH__)
  return __float_as_uint(f);
#else
  std::uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
#endif
}
FF_HD float bits_float(std::uint32_t u) {
#if defined(__CUDA_ARCH__)
  return __uint_as_float(u);
#else
  float f;
  std::memcpy(&f, &u, sizeof f);
  return f;
#endif
}

// Squared minimum-image move of each particle since the triangulation's positions, rounded up to
// a float and returned as its bits, so the backend's integer max-reduction gives an upper bound
// of m² (an upper bound is all the expansion radius needs).
template <class R>
struct MaxMove {
  delaunay::Points<R> now;
  const R* prev;

  FF_HD std::uint32_t operator()(std::size_t i) const {
    const double dx = now.image(double(now.p[2 * i]) - double(prev[2 * i]), 0);
    const double dy = now.image(double(now.p[2 * i + 1]) - double(prev[2 * i + 1]), 1);
    const double d2 = dx * dx + dy * dy;
    const float f = float(d2);
    const std::uint32_t b = float_bits(f);
    return double(f) < d2 ? b + 1 : b;  // the next float up
  }
};

// Vertex u's one-ring into ring[u·width ...] in CCW order from vertex_edge[u]; degree[u] = its
// true degree (more than width: the search reports kRingOverflow and the stage widens the ring).
struct GatherRing {
  const std::int32_t* he;     // delaunay.halfedge: {origin, next} per half-edge
  const std::int32_t* vedge;  // delaunay.vertex_edge
  std::uint32_t width;
  std::uint32_t n;            // vertices: no valid ring is longer (guards a corrupt mesh)
  std::uint32_t* ring;        // n x width
  std::uint32_t* degree;      // n

  FF_HD void operator()(std::size_t u) const {
    const int h0 = vedge[u];
    int h = h0;
    std::uint32_t k = 0;
    std::uint32_t* row = ring + u * width;
    do {
      if (k < width) row[k] = std::uint32_t(he[2 * (h ^ 1)]);  // the other end of h
      ++k;
      h = he[2 * he[2 * h + 1] + 1] ^ 1;  // twin(next(next(h))): the next half-edge CCW around u
    } while (h != h0 && k < n);
    degree[u] = k;
  }
};

// What both traversals share: the radii, the two position sets, the rings and the output.
template <class R>
struct SearchBase {
  delaunay::Points<R> old;      // delaunay.position_prev: the positions the mesh is Delaunay for
  const R* x;                   // position now
  PeriodicBox<R> box;           // the acceptance test's minimum image (BuildList's)
  R accept2;                    // r², in the run's precision
  double expand2;               // r_expand²
  const std::uint32_t* ring;    // GatherRing's
  const std::uint32_t* degree;
  std::uint32_t width;
  std::uint32_t capacity;       // row length of the list
  std::uint32_t* list;          // n x capacity
  std::uint32_t* count;         // accepted neighbours per row
  R* at_build;                  // neighbors.position_at_build: the positions the rows are exact for

  FF_HD std::uint32_t ring_size(std::uint32_t u) const { return degree[u] < width ? degree[u] : width; }

  // Squared distance from p (its old position (px, py)) to vertex w, in the old positions.
  FF_HD double old_d2(double px, double py, std::uint32_t w) const {
    const double dx = old.image(double(old.p[2 * w]) - px, 0);
    const double dy = old.image(double(old.p[2 * w + 1]) - py, 1);
    return dx * dx + dy * dy;
  }

  // Within r now: neighbors.verlet's test (verlet/kernel.h BuildList), term for term.
  FF_HD bool accepted(std::uint32_t p, std::uint32_t j) const {
    R d2 = 0;
    for (int k = 0; k < 2; ++k) {
      const R d = box.min_image(x[std::size_t(j) * 2 + k] - x[std::size_t(p) * 2 + k], k);
      d2 += d * d;
    }
    return d2 <= accept2;
  }

  // Keeps the accepted entries of row[0, n) in ascending order at the row's front; count[p].
  FF_HD void finish_row(std::uint32_t p, std::uint32_t* row, std::uint32_t n) const {
    std::uint32_t m = 0;
    for (std::uint32_t a = 0; a < n; ++a)
      if (accepted(p, row[a])) row[m++] = row[a];
    for (std::uint32_t a = 1; a < m; ++a) {  // insertion sort: rows are short
      const std::uint32_t v = row[a];
      std::uint32_t b = a;
      for (; b > 0 && row[b - 1] > v; --b) row[b] = row[b - 1];
      row[b] = v;
    }
    count[p] = m;
    at_build[2 * std::size_t(p)] = x[2 * std::size_t(p)];
    at_build[2 * std::size_t(p) + 1] = x[2 * std::size_t(p) + 1];
  }

  // Row overflow: nothing valid in the row; the stage grows it and searches again.
  FF_HD std::uint32_t overflow(std::uint32_t p) const {
    count[p] = 0;
    return capacity + 1;
  }
};

// Traversal `visited`: breadth-first, the row as queue and visited set.
template <class R>
struct SearchVisited : SearchBase<R> {
  FF_HD std::uint32_t operator()(std::size_t pi) const {
    const std::uint32_t p = std::uint32_t(pi);
    if (this->degree[p] > this->width) return this->overflow(p) | kRingOverflow;
    std::uint32_t* row = this->list + std::size_t(p) * this->capacity;
    const double px = double(this->old.p[2 * pi]), py = double(this->old.p[2 * pi + 1]);
    std::uint64_t filter[2] = {0, 0};  // bit (hash of w) set for every w in the row
    std::uint32_t n = 0, head = 0, u = p;
    for (;;) {
      const std::uint32_t* ru = this->ring + std::size_t(u) * this->width;
      const std::uint32_t du = this->ring_size(u);
      for (std::uint32_t k = 0; k < du; ++k) {
        const std::uint32_t w = ru[k];
        const std::uint32_t hash = (w * 0x9E3779B1u) >> 25;  // 7 bits
        const std::uint64_t bit = std::uint64_t(1) << (hash & 63);
        if (filter[hash >> 6] & bit) {
          bool seen = false;
          for (std::uint32_t a = 0; a < n && !seen; ++a) seen = row[a] == w;
          if (seen) continue;
        }
        if (w == p || this->old_d2(px, py, w) > this->expand2) continue;
        if (n == this->capacity) return this->overflow(p);
        filter[hash >> 6] |= bit;
        row[n++] = w;
      }
      if (head == n) break;
      u = row[head++];
    }
    this->finish_row(p, row, n);
    return n;
  }
};

// Traversal `parent`: depth-first over the tree of parent links, no visited set.
template <class R>
struct SearchParent : SearchBase<R> {
  // The ring member of w closest to p in the old positions (ties: the lower index).
  FF_HD std::uint32_t parent(double px, double py, std::uint32_t w) const {
    const std::uint32_t* rw = this->ring + std::size_t(w) * this->width;
    const std::uint32_t dw = this->ring_size(w);
    std::uint32_t best = rw[0];
    double best_d2 = this->old_d2(px, py, best);
    for (std::uint32_t k = 1; k < dw; ++k) {
      const std::uint32_t v = rw[k];
      const double d2 = this->old_d2(px, py, v);
      if (d2 < best_d2 || (d2 == best_d2 && v < best)) {
        best = v;
        best_d2 = d2;
      }
    }
    return best;
  }

  FF_HD std::uint32_t operator()(std::size_t pi) const {
    const std::uint32_t p = std::uint32_t(pi);
    if (this->degree[p] > this->width) return this->overflow(p) | kRingOverflow;
    const std::uint32_t W = this->width, cap = this->capacity;
    std::uint32_t* row = this->list + std::size_t(p) * cap;
    const double px = double(this->old.p[2 * pi]), py = double(this->old.p[2 * pi + 1]);
    // Ring slots (u·W + k) of the vertex being scanned: the next one and the end.
    std::uint32_t slot = p * W, end = p * W + this->ring_size(p);
    std::uint32_t n = 0, top = cap;  // tree vertices in row[0, n), the stack in row[top, cap)
    std::uint32_t used = 0;          // the most slots held at once
    for (;;) {
      if (slot == end) {
        if (top == cap) break;
        slot = row[top++];  // resume the parent's scan after the child it descended into
        const std::uint32_t u = (slot - 1) / W;
        end = u * W + this->ring_size(u);
        continue;
      }
      const std::uint32_t u = slot / W;
      const std::uint32_t w = this->ring[slot++];
      if (w == p || this->old_d2(px, py, w) > this->expand2) continue;
      if (parent(px, py, w) != u) continue;
      if (n + 2 > top) return this->overflow(p);  // w and the resume slot must both fit
      row[n++] = w;
      row[--top] = slot;
      used = used > n + (cap - top) ? used : n + (cap - top);
      slot = w * W;
      end = w * W + this->ring_size(w);
    }
    this->finish_row(p, row, n);
    return used;
  }
};

}  // namespace ff::neighbors
