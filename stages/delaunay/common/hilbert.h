// A Hilbert-curve order of points in the periodic box (host only, header-only): delaunay.build
// numbers edges in this order and delaunay.sort renumbers particles in it, so that neighbours in
// space are neighbours in memory.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

namespace ff::delaunay {

// Index of cell (x, y) along the Hilbert curve filling a 2^bits x 2^bits grid.
inline std::uint64_t hilbert_index(std::uint32_t x, std::uint32_t y, int bits) {
  std::uint64_t d = 0;
  for (std::uint32_t s = std::uint32_t(1) << (bits - 1); s > 0; s >>= 1) {
    const std::uint32_t rx = (x & s) ? 1 : 0, ry = (y & s) ? 1 : 0;
    d += std::uint64_t(s) * s * ((3 * rx) ^ ry);
    if (ry == 0) {  // rotate the quadrant (only the bits below s matter from here on)
      if (rx == 1) {
        x = (s - 1) - (x & (s - 1));
        y = (s - 1) - (y & (s - 1));
      }
      std::swap(x, y);
    }
  }
  return d;
}

// Each point's rank along a Hilbert curve over the periodic box Lx x Ly (2^16 cells a side;
// points in one cell by index): a permutation of 0..n-1. xy: x0 y0 x1 y1 ...
inline std::vector<std::int32_t> hilbert_ranks(const std::vector<double>& xy, double Lx, double Ly) {
  const std::size_t n = xy.size() / 2;
  constexpr int bits = 16;
  const double cells = double(1u << bits);
  auto cell = [&](double x, double L) {
    const double c = std::floor((x - L * std::floor(x / L)) / L * cells);
    return std::uint32_t(std::min(std::max(c, 0.0), cells - 1));
  };
  std::vector<std::pair<std::uint64_t, std::int32_t>> key(n);
  for (std::size_t i = 0; i < n; ++i)
    key[i] = {hilbert_index(cell(xy[2 * i], Lx), cell(xy[2 * i + 1], Ly), bits), std::int32_t(i)};
  std::sort(key.begin(), key.end());
  std::vector<std::int32_t> rank(n);
  for (std::size_t r = 0; r < n; ++r) rank[std::size_t(key[r].second)] = std::int32_t(r);
  return rank;
}

}  // namespace ff::delaunay
