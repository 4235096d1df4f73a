#include "stages/observe/clusters/analysis.h"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "stages/delaunay/common/fields.h"
#include "stages/observe/cell_grid.h"

namespace ff::observe {

namespace {

// Rows from per-particle counts (start[i + 1] = count of row i) filled by `fill(i, row)`.
template <class Count, class Fill>
PairRows make_rows(std::size_t n, Count count, Fill fill) {
  PairRows rows;
  rows.start.assign(n + 1, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 256), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) rows.start[i + 1] = count(i);
  });
  for (std::size_t i = 0; i < n; ++i) rows.start[i + 1] += rows.start[i];
  rows.index.resize(rows.start[n]);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 256), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) fill(i, &rows.index[rows.start[i]]);
  });
  return rows;
}

int find(std::vector<std::int32_t>& parent, std::int32_t a) {
  while (parent[a] != a) {
    parent[a] = parent[parent[a]];
    a = parent[a];
  }
  return a;
}

}  // namespace

PairRows cell_pairs(const ClusterFrame& f, double r) {
  const std::size_t n = f.n();
  const int dim = f.dim;
  int nc[3] = {1, 1, 1};
  for (int k = 0; k < dim; ++k) nc[k] = std::max(1, int(std::floor(f.L[k] / r)));
  // Not more cells than ~4 per particle: empty cells cost a visit each.
  const double limit = 4.0 * double(n) + 64;
  double total = double(nc[0]) * nc[1] * nc[2];
  if (total > limit) {
    const double shrink = std::pow(total / limit, 1.0 / dim);
    for (int k = 0; k < dim; ++k) nc[k] = std::max(1, int(std::floor(nc[k] / shrink)));
  }
  const CellGrid grid(f.x.data(), n, dim, f.L, nc);
  const double r2 = r * r;
  // Visits the particles of the 3^dim cells around i closer than r (minimum image), i excluded.
  auto each = [&](std::size_t i, auto&& emit) {
    if (!f.takes_part[i]) return;
    grid.for_each_candidate(i, [&](std::size_t j) {
      if (j != i && f.takes_part[j] && distance2(f, i, j) < r2) emit(std::uint32_t(j));
    });
  };
  return make_rows(
      n,
      [&](std::size_t i) {
        std::uint32_t k = 0;
        each(i, [&](std::uint32_t) { ++k; });
        return k;
      },
      [&](std::size_t i, std::uint32_t* row) {
        std::uint32_t k = 0;
        each(i, [&](std::uint32_t j) { row[k++] = j; });
      });
}

PairRows list_pairs(std::size_t n, const std::uint32_t* list, const std::uint32_t* count, std::uint32_t capacity) {
  return make_rows(
      n, [&](std::size_t i) { return std::min(count[i], capacity); },
      [&](std::size_t i, std::uint32_t* row) {
        const std::uint32_t* src = list + i * std::size_t(capacity);
        std::copy(src, src + std::min(count[i], capacity), row);
      });
}

PairRows edge_pairs(std::size_t n, const std::int32_t* he) {
  // Edge e joins the origins of half-edges 2e and 2e + 1 (he[4e] and he[4e + 2]).
  PairRows rows;
  rows.start.assign(n + 1, 0);
  const std::size_t edges = delaunay::edge_count(n);
  for (std::size_t e = 0; e < edges; ++e) {
    ++rows.start[std::size_t(he[4 * e]) + 1];
    ++rows.start[std::size_t(he[4 * e + 2]) + 1];
  }
  for (std::size_t i = 0; i < n; ++i) rows.start[i + 1] += rows.start[i];
  rows.index.resize(rows.start[n]);
  std::vector<std::uint32_t> fill(rows.start.begin(), rows.start.end() - 1);
  for (std::size_t e = 0; e < edges; ++e) {
    const std::uint32_t a = std::uint32_t(he[4 * e]), b = std::uint32_t(he[4 * e + 2]);
    rows.index[fill[a]++] = b;
    rows.index[fill[b]++] = a;
  }
  return rows;
}

ClusterResult analyse_clusters(const ClusterFrame& f, const PairRows& rows, double bond, double neighbor,
                               std::int64_t min_size, int types) {
  const std::size_t n = f.n();
  const int dim = f.dim;
  auto sigma = [&](std::size_t i, std::size_t j) { return 0.5 * (f.diameter[i] + f.diameter[j]); };
  // Per particle: its bonded partners (ascending) and how many particles lie within the
  // coordination radius.
  std::vector<std::uint32_t> coordination(n, 0);
  const PairRows bonds = make_rows(
      n,
      [&](std::size_t i) {
        std::uint32_t k = 0, c = 0;
        if (!f.takes_part[i]) return k;
        for (std::uint32_t p = rows.start[i]; p < rows.start[i + 1]; ++p) {
          const std::size_t j = rows.index[p];
          if (j == i || !f.takes_part[j]) continue;
          const double r2 = distance2(f, i, j), s = sigma(i, j);
          if (r2 < bond * bond * s * s) ++k;
          if (r2 < neighbor * neighbor * s * s) ++c;
        }
        coordination[i] = c;
        return k;
      },
      [&](std::size_t i, std::uint32_t* row) {
        if (!f.takes_part[i]) return;
        std::uint32_t k = 0;
        for (std::uint32_t p = rows.start[i]; p < rows.start[i + 1]; ++p) {
          const std::size_t j = rows.index[p];
          if (j == i || !f.takes_part[j]) continue;
          const double s = sigma(i, j);
          if (distance2(f, i, j) < bond * bond * s * s) row[k++] = std::uint32_t(j);
        }
        std::sort(row, row + k);
      });

  ClusterResult res;
  res.bonds_by_pair.assign(std::size_t(types) * types, 0);
  // Union–find hooking the larger root under the smaller: every root is its component's
  // smallest index, whatever the order of the unions.
  std::vector<std::int32_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  for (std::size_t i = 0; i < n; ++i) {
    if (f.takes_part[i]) ++res.taking_part;
    for (std::uint32_t p = bonds.start[i]; p < bonds.start[i + 1]; ++p) {
      const std::size_t j = bonds.index[p];
      if (j < i) continue;  // each bond once, from its lower end
      ++res.bonds;
      int a = f.type[i], b = f.type[j];
      if (a != b) ++res.unlike_bonds;
      if (a > b) std::swap(a, b);
      ++res.bonds_by_pair[std::size_t(a) * types + b];
      const int ra = find(parent, std::int32_t(i)), rb = find(parent, std::int32_t(j));
      if (ra < rb)
        parent[rb] = ra;
      else if (rb < ra)
        parent[ra] = rb;
    }
  }
  res.label.assign(n, -1);
  std::vector<std::uint32_t> size(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    if (!f.takes_part[i]) continue;
    res.label[i] = find(parent, std::int32_t(i));
    ++size[res.label[i]];
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!f.takes_part[i] || res.label[i] != std::int32_t(i)) continue;
    const std::uint32_t sz = size[i];
    res.sizes.push_back(sz);
    res.largest = std::max<std::uint64_t>(res.largest, sz);
    if (sz == 1) ++res.monomers;
    if (std::int64_t(sz) >= min_size) {
      ++res.aggregates;
      res.in_aggregates += sz;
    }
  }
  for (std::size_t i = 0; i < n; ++i)
    if (f.takes_part[i] && std::int64_t(size[res.label[i]]) >= min_size) res.coordination_sum += coordination[i];

  // Percolation: walk each cluster from its label over the bonds, giving every member the
  // integer box offset of its image reached along the walk; a bond to a member already reached
  // with another offset closes a path that wraps the box.
  std::vector<std::array<int, 3>> offset(n);
  std::vector<std::uint8_t> seen(n, 0);
  std::vector<std::uint32_t> queue;
  for (std::size_t root = 0; root < n; ++root) {
    if (!f.takes_part[root] || res.label[root] != std::int32_t(root) || size[root] < 2) continue;
    queue.assign(1, std::uint32_t(root));
    seen[root] = 1;
    offset[root] = {0, 0, 0};
    for (std::size_t q = 0; q < queue.size(); ++q) {
      const std::size_t i = queue[q];
      for (std::uint32_t p = bonds.start[i]; p < bonds.start[i + 1]; ++p) {
        const std::size_t j = bonds.index[p];
        int shift[3] = {0, 0, 0};
        distance2(f, i, j, shift);
        std::array<int, 3> o = offset[i];
        for (int k = 0; k < dim; ++k) o[k] += shift[k];
        if (!seen[j]) {
          seen[j] = 1;
          offset[j] = o;
          queue.push_back(std::uint32_t(j));
        } else {
          for (int k = 0; k < dim; ++k)
            if (offset[j][k] != o[k]) res.percolates[k] = 1;
        }
      }
    }
  }
  return res;
}

double gabriel_ratio2(double b, const std::vector<double>& pair_diameters, const std::vector<double>& all_diameters) {
  double worst = 0;
  for (double si : pair_diameters)
    for (double sj : pair_diameters)
      for (double sk : all_diameters) {
        const double sij = 0.5 * (si + sj), sik = 0.5 * (si + sk), sjk = 0.5 * (sj + sk);
        worst = std::max(worst, b * b * sij * sij / (sik * sik + sjk * sjk));
      }
  return worst;
}

}  // namespace ff::observe
