// Particles binned into a periodic grid of cells, for the host observers that look for pairs
// within a distance (observe.gr, observe.clusters): a counting sort, so the particles of cell c
// are order[start[c] .. start[c + 1]) in index order, and a walk over the 3^dim cells around a
// particle (each distinct cell once, also when an axis has fewer than 3 cells). Host-only.
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace ff::observe {

class CellGrid {
 public:
  // x: n x dim positions in [0, L); cells[k] cells along axis k (cells[2] ignored in 2D).
  CellGrid(const double* x, std::size_t n, int dim, const double* L, const int* cells)
      : dim_(dim), nc_{cells[0], cells[1], dim == 3 ? cells[2] : 1}, cell_of_(n * 3, 0), order_(n) {
    const std::size_t ncells = std::size_t(nc_[0]) * nc_[1] * nc_[2];
    start_.assign(ncells + 1, 0);
    std::vector<std::size_t> lin(n);
    for (std::size_t i = 0; i < n; ++i) {
      std::size_t l = 0;
      for (int k = dim - 1; k >= 0; --k) {
        int c = int(x[i * dim + k] / L[k] * nc_[k]);
        c = std::min(std::max(c, 0), nc_[k] - 1);
        cell_of_[i * 3 + k] = c;
        l = l * std::size_t(nc_[k]) + std::size_t(c);
      }
      lin[i] = l;
      ++start_[l + 1];
    }
    for (std::size_t c = 0; c < ncells; ++c) start_[c + 1] += start_[c];
    std::vector<std::uint32_t> fill(start_.begin(), start_.end() - 1);
    for (std::size_t i = 0; i < n; ++i) order_[fill[lin[i]]++] = std::uint32_t(i);
  }

  // f(j) for every particle j (i included) of the cells around i's, cell by cell (z, y, x
  // outermost to innermost), in index order within a cell.
  template <class F>
  void for_each_candidate(std::size_t i, F&& f) const {
    int cx[3], cy[3], cz[3] = {0, 0, 0};
    const int nx = around(cell_of_[i * 3], nc_[0], cx);
    const int ny = around(cell_of_[i * 3 + 1], nc_[1], cy);
    const int nz = dim_ == 3 ? around(cell_of_[i * 3 + 2], nc_[2], cz) : 1;
    for (int a = 0; a < nz; ++a)
      for (int b = 0; b < ny; ++b)
        for (int c = 0; c < nx; ++c) {
          const std::size_t cell = (std::size_t(cz[a]) * nc_[1] + std::size_t(cy[b])) * nc_[0] + std::size_t(cx[c]);
          for (std::uint32_t p = start_[cell]; p < start_[cell + 1]; ++p) f(std::size_t(order_[p]));
        }
  }

 private:
  // The distinct cells c−1, c, c+1 along an axis of `nc` cells (all of them when nc < 3).
  static int around(int c, int nc, int out[3]) {
    if (nc < 3) {
      for (int k = 0; k < nc; ++k) out[k] = k;
      return nc;
    }
    out[0] = (c + nc - 1) % nc;
    out[1] = c;
    out[2] = (c + 1) % nc;
    return 3;
  }

  int dim_;
  int nc_[3];
  std::vector<int> cell_of_;
  std::vector<std::uint32_t> start_, order_;
};

}  // namespace ff::observe
