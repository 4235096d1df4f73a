// delaunay.sort's 3D order (hilbert3.cpp: CGAL's Hilbert sort; host only).
#pragma once
#include <cstdint>
#include <vector>

namespace ff::delaunay {

// Each point's rank along CGAL's Hilbert curve through the points xyz (x0 y0 z0 x1 ...), wrapped
// into the box: a permutation of 0..n-1.
std::vector<std::int32_t> hilbert_ranks_3(const std::vector<double>& xyz);

}  // namespace ff::delaunay
