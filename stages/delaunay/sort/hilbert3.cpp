// The 3D order of delaunay.sort: CGAL's Hilbert sort of the positions (the one file of the sort
// stage that includes CGAL; nvcc never sees it).
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Spatial_sort_traits_adapter_3.h>
#include <CGAL/hilbert_sort.h>
#include <CGAL/property_map.h>

#include <cstdint>
#include <numeric>
#include <vector>

#include "stages/delaunay/sort/hilbert3.h"

namespace ff::delaunay {

std::vector<std::int32_t> hilbert_ranks_3(const std::vector<double>& xyz) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  const std::size_t n = xyz.size() / 3;
  std::vector<K::Point_3> points(n);
  for (std::size_t i = 0; i < n; ++i) points[i] = K::Point_3(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t(0));
  // The middle policy splits cells at their geometric centre: the curve of a box, not of the
  // sample (the median policy would adapt it to clusters, and tie the order to their shape).
  using Traits = CGAL::Spatial_sort_traits_adapter_3<K, CGAL::Pointer_property_map<K::Point_3>::type>;
  CGAL::hilbert_sort(order.begin(), order.end(), Traits(CGAL::make_property_map(points)), CGAL::Hilbert_sort_middle_policy());
  std::vector<std::int32_t> rank(n);
  for (std::size_t r = 0; r < n; ++r) rank[order[r]] = std::int32_t(r);
  return rank;
}

}  // namespace ff::delaunay
