// neighbors.delaunay, traversal `parent` (kernel.h says why a search over Delaunay edges is exact
// and holds what both traversals share):
// depth-first without a visited set: q's parent is its ring member closest to p
// (ties: lower index), which the lemma makes closer to p than q, so the parent links
// form a tree rooted at p; the search descends from u to w iff parent(w) = u. The
// row holds the tree's vertices from its front and the depth-first stack (pairs of a
// vertex and the table slot to resume its scan at) from its back.
// nvcc-clean.

#pragma once

#include <cstdint>

#include "core/base/hd.h"
#include "stages/neighbors/delaunay/kernel.h"

namespace ff::neighbors {

// Traversal `parent`: depth-first over the tree of parent links, no visited set.
template <class R>
struct SearchParent : SearchBase<R> {
  // The ring member of w closest to p in the old positions (ties: the lower index).
  FF_HD std::uint32_t parent(double px, double py, std::uint32_t w) const {
    const RingRecord rw = load_record(this->record, w);
    const std::uint32_t* ring = this->table + rw.start;
    std::uint32_t best = ring[0];
    double best_d2 = this->old_d2(px, py, best);
    for (std::uint32_t k = 1; k < rw.degree; ++k) {
      const std::uint32_t v = ring[k];
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
    if (*this->move2 & kRingOverflow) return kRingOverflow;
    const double e2 = this->expand2();
    if (e2 < 0) return kTooFar;
    const std::uint32_t cap = this->capacity;
    std::uint32_t* row = this->list + std::size_t(p) * cap;
    R ox, oy;
    load_xy(this->old.p, p, ox, oy);
    const double px = double(ox), py = double(oy);
    // The vertex being scanned, its next table slot and its end.
    std::uint32_t u = p;
    RingRecord ru = load_record(this->record, p);
    std::uint32_t slot = ru.start, end = ru.start + ru.degree;
    // Tree vertices in row[0, n); from the back, the stack of (vertex, slot to resume at) pairs.
    std::uint32_t n = 0, top = cap;
    std::uint32_t used = 0;  // the most slots held at once
    for (;;) {
      if (slot == end) {
        if (top == cap) break;
        u = row[top++];  // resume the parent's scan after the child it descended into
        slot = row[top++];
        ru = load_record(this->record, u);
        end = ru.start + ru.degree;
        continue;
      }
      const std::uint32_t w = this->table[slot++];
      if (w == p || this->old_d2(px, py, w) > e2) continue;
      if (parent(px, py, w) != u) continue;
      if (n + 3 > top) return this->overflow(p);  // w and the resume pair must fit
      row[n++] = w;
      row[--top] = slot;
      row[--top] = u;
      used = used > n + (cap - top) ? used : n + (cap - top);
      u = w;
      ru = load_record(this->record, w);
      slot = ru.start;
      end = ru.start + ru.degree;
    }
    R x0, y0;
    load_xy(this->x, p, x0, y0);
    std::uint32_t m = 0;
    for (std::uint32_t a = 0; a < n; ++a)
      if (this->accepted(x0, y0, row[a])) row[m++] = row[a];
    for (std::uint32_t a = 1; a < m; ++a) {  // insertion sort: rows are short
      const std::uint32_t v = row[a];
      std::uint32_t b = a;
      for (; b > 0 && row[b - 1] > v; --b) row[b] = row[b - 1];
      row[b] = v;
    }
    this->write_row(p, x0, y0, m, [&](std::uint32_t a) { return row[a]; });
    return used;
  }
};

}  // namespace ff::neighbors
