// delaunay.check's comparison (host, check.cpp): the maintained half-edge triangulation against
// CGAL's Delaunay triangulation of the same positions (build/cgal.cpp), edge set against edge
// set, with co-circular ties tolerated. Plain std types; no CGAL here.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace ff::delaunay {

// One edge present in one triangulation and not in the other, with the quad around it in the
// triangulation that has it: (a, b) the edge, c and d the opposite vertices.
struct EdgeDifference {
  int a = -1, b = -1, c = -1, d = -1;
  bool maintained = true;      // true: only the maintained triangulation has it; false: only CGAL's
  double cocircularity = 0;    // |in-circle| / permanent of (a, b, c, d); 0 = exactly co-circular
};

struct CheckReport {
  std::string structure;       // non-empty: the half-edges are not a torus triangulation (why)
  std::size_t inverted = 0;    // triangles not positively oriented (or not closing) under minimum image
  std::size_t edges_only_maintained = 0;
  std::size_t edges_only_cgal = 0;
  std::size_t ties = 0;        // differing edges whose quad is co-circular within the tolerance
  std::size_t mismatches = 0;  // differing edges that are not ties
  std::vector<EdgeDifference> first;  // the first mismatches (lowest vertex pairs), at most kShown
  std::string method;          // how CGAL triangulated the positions

  static constexpr std::size_t kShown = 6;
  bool ok() const { return structure.empty() && inverted == 0 && mismatches == 0; }
};

// Compares the half-edges `he` (2 x 6n) / `vedge` (n) with CGAL's Delaunay triangulation of the
// positions xy (x0 y0 x1 y1 ..., n points) in the periodic box Lx x Ly. An edge in only one of
// the two triangulations is a tie (not a mismatch) when the four points of its quad are
// co-circular within `tolerance` (|in-circle determinant| <= tolerance x its permanent, the
// determinant's own rounding scale): there either diagonal is Delaunay. InputError from the CGAL
// side (coincident positions, an edge longer than half the box) is passed on.
CheckReport compare_with_cgal(const std::int32_t* he, const std::int32_t* vedge, std::size_t n,
                              const std::vector<double>& xy, double Lx, double Ly, double tolerance);

// "maintained edge 12-57 (opposite 60, 61; in-circle/permanent 3.2e-03)", one per difference.
std::string describe(const EdgeDifference& d);

}  // namespace ff::delaunay
