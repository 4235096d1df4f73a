// The one CGAL translation unit's interface (cgal.cpp); plain std types only.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "core/base/error.h"

namespace ff::delaunay {

// periodic_delaunay's InputError for too few points at their density (an edge longer than half the
// box): what it found, for a caller that triangulates points other than the user's (voronoi.mirror's
// doubled box) to say it in the user's terms.
struct TooSparse : InputError {
  TooSparse(const std::string& what, double longest_edge, long long need_n)
      : InputError(what), longest(longest_edge), need(need_n) {}
  double longest;  // the longest Delaunay edge
  long long need;  // the N that would do at this density, in this box
};

struct PeriodicTriangles {
  std::vector<std::array<int, 3>> triangles;  // CCW, 2N of them
  std::string method;                         // how they were obtained (for messages and tests)
};

// The Delaunay triangulation of n points (xy: x0 y0 x1 y1 ...) in the periodic box
// [0, Lx) x [0, Ly), as triangles whose edge vectors are all minimum images (shorter than half
// the box in each coordinate). Square boxes use CGAL's Periodic_2_Delaunay_triangulation_2
// when it reaches its 1-sheeted covering; otherwise (rectangular box, or few points at this
// density) the Delaunay triangulation of the points and their 8 periodic images
// (CGAL::Delaunay_triangulation_2) is cut back to one copy of each triangle and checked.
// InputError when the points cannot be triangulated that way (coincident particles, or an edge
// longer than half the box: the message names the minimum N for the density).
PeriodicTriangles periodic_delaunay(const std::vector<double>& xy, double Lx, double Ly);

}  // namespace ff::delaunay
