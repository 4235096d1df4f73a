// The only file of the delaunay stages that includes CGAL (slow to compile; nvcc never sees it).
#include "stages/delaunay/build/cgal.h"

#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Periodic_2_Delaunay_triangulation_2.h>
#include <CGAL/Periodic_2_Delaunay_triangulation_traits_2.h>
#include <CGAL/Spatial_sort_traits_adapter_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>
#include <CGAL/property_map.h>
#include <CGAL/spatial_sort.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <utility>

#include "core/base/error.h"

namespace ff::delaunay {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;

// Periodic (square domain, CGAL P2T2), vertex info = particle index.
using PGt = CGAL::Periodic_2_Delaunay_triangulation_traits_2<K>;
using PVb = CGAL::Triangulation_vertex_base_with_info_2<unsigned, PGt, CGAL::Periodic_2_triangulation_vertex_base_2<PGt>>;
using PFb = CGAL::Periodic_2_triangulation_face_base_2<PGt>;
using PTds = CGAL::Triangulation_data_structure_2<PVb, PFb>;
using PDT = CGAL::Periodic_2_Delaunay_triangulation_2<PGt, PTds>;

// Plain Delaunay of the 3 x 3 copies, vertex info = 9 * index + copy.
using Vb = CGAL::Triangulation_vertex_base_with_info_2<unsigned, K>;
using Tds = CGAL::Triangulation_data_structure_2<Vb>;
using DT = CGAL::Delaunay_triangulation_2<K, Tds>;

std::string fmt(double v) {
  std::ostringstream os;
  os.precision(4);
  os << v;
  return os.str();
}

[[noreturn]] void coincident(const std::vector<double>& xy) {
  const std::size_t n = xy.size() / 2;
  std::vector<std::size_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t i, std::size_t j) {
    return std::make_pair(xy[2 * i], xy[2 * i + 1]) < std::make_pair(xy[2 * j], xy[2 * j + 1]);
  });
  for (std::size_t k = 1; k < n; ++k) {
    const std::size_t i = order[k - 1], j = order[k];
    if (xy[2 * i] == xy[2 * j] && xy[2 * i + 1] == xy[2 * j + 1])
      throw InputError("delaunay.build: particles " + std::to_string(std::min(i, j)) + " and " +
                       std::to_string(std::max(i, j)) + " are at the same position (" + fmt(xy[2 * i]) + ", " +
                       fmt(xy[2 * i + 1]) + "); a triangulation needs distinct positions");
  }
  throw InputError("delaunay.build: CGAL merged coincident particles; a triangulation needs distinct positions");
}

[[noreturn]] void too_sparse(std::size_t n, double Lx, double Ly, double longest, const std::string& what) {
  const double density = double(n) / (Lx * Ly);
  const double aspect = std::max(Lx, Ly) / std::min(Lx, Ly);
  // Keep the longest edge below 0.4 of the shorter side (CGAL's 1-sheet criterion is 0.407).
  const double need = std::ceil(density * aspect * (2.5 * longest) * (2.5 * longest));
  const long long use = std::max<long long>(static_cast<long long>(need), static_cast<long long>(n) + 1);
  throw TooSparse("delaunay.build: " + what + ": with N = " + std::to_string(n) + " in a " + fmt(Lx) + " x " +
                      fmt(Ly) + " box (number density " + fmt(density) + ") the longest Delaunay edge is " +
                      fmt(longest) + ", but the periodic triangulation is stored by minimum image and needs every "
                      "edge shorter than half the box. At this density use N >= " + std::to_string(use) +
                      " (or a denser system)",
                  longest, use);
}

// The periodic triangulation with the dummy points CGAL's own insert of a large point set starts
// from (protected there).
struct PeriodicDelaunay : PDT {
  using PDT::PDT;
  using PDT::insert_dummy_points;
};

// The points xy (info: their index) into an empty periodic triangulation, as CGAL's
// insert(first, last, is_large_point_set = true) of (point, index) pairs does it
// (Periodic_2_Delaunay_triangulation_2::insert_with_info), step for step: dummy points, a spatial
// sort, each point located from the last one's face and inserted, the dummies left removed. One
// difference: the sort compares points through K's Less_x_2 / Less_y_2, not through the periodic
// traits. Those compare the same doubles the same way (the same order, so the same
// triangulation), but they hold the domain as GMP rationals, and the sort copies its comparator,
// traits and all, at every step of its median selections: those copies were half of the
// instructions of a first step at 2^14 (callgrind; bench/README.md, "Session 42").
void insert_all(PeriodicDelaunay& t, const std::vector<double>& xy) {
  const std::size_t n = xy.size() / 2;
  std::vector<PDT::Point> points;
  std::vector<std::size_t> indices(n);
  points.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    points.emplace_back(xy[2 * i], xy[2 * i + 1]);
    indices[i] = i;
  }
  const std::vector<PDT::Vertex_handle> dummies = t.insert_dummy_points();
  std::set<PDT::Vertex_handle> dummy(dummies.begin(), dummies.end());
  using Pmap = CGAL::Pointer_property_map<PDT::Point>::type;
  CGAL::spatial_sort(indices.begin(), indices.end(), CGAL::Spatial_sort_traits_adapter_2<K, Pmap>(CGAL::make_property_map(points)));
  PDT::Face_handle f;
  PDT::Locate_type lt;
  int li = 0;
  for (const std::size_t i : indices) {
    f = t.locate(points[i], lt, li, f);
    if (lt == PDT::VERTEX) {  // a dummy's place (or a coincident point: caught by the caller's count)
      f->vertex(li)->info() = unsigned(i);
      dummy.erase(f->vertex(li));
    } else {
      t.insert(points[i], lt, f, li)->info() = unsigned(i);
    }
  }
  for (const PDT::Vertex_handle v : dummy) t.remove(v);
}

// Square box: CGAL's periodic triangulation, if it reaches the 1-sheeted covering.
bool try_periodic(const std::vector<double>& xy, double L, PeriodicTriangles& out) {
  const std::size_t n = xy.size() / 2;
  PeriodicDelaunay t(PDT::Iso_rectangle(0, 0, L, L));
  insert_all(t, xy);
  if (t.number_of_vertices() != n) coincident(xy);
  if (!t.is_1_cover()) return false;
  out.triangles.clear();
  out.triangles.reserve(2 * n);
  for (auto f = t.faces_begin(); f != t.faces_end(); ++f) {
    std::array<int, 3> tri;
    double x[3], y[3];
    for (int k = 0; k < 3; ++k) {
      const auto pp = t.periodic_point(f, k);
      tri[k] = int(f->vertex(k)->info());
      x[k] = pp.first.x() + pp.second.x() * L;
      y[k] = pp.first.y() + pp.second.y() * L;
    }
    for (int k = 0; k < 3; ++k) {
      const double dx = x[(k + 1) % 3] - x[k], dy = y[(k + 1) % 3] - y[k];
      if (!(std::fabs(dx) < 0.5 * L && std::fabs(dy) < 0.5 * L)) return false;  // leave it to the checked path
    }
    out.triangles.push_back(tri);
  }
  out.method = "CGAL Periodic_2_Delaunay_triangulation_2 (1-sheeted covering)";
  return out.triangles.size() == 2 * n;
}

// Any box: Delaunay of the points and their 8 images; keep each torus triangle once (the copy
// whose lowest-index vertex lies in the original box) and check it is a valid minimum-image
// triangulation of the torus.
PeriodicTriangles from_copies(const std::vector<double>& xy, double Lx, double Ly) {
  const std::size_t n = xy.size() / 2;
  std::vector<std::pair<DT::Point, unsigned>> pts;
  pts.reserve(9 * n);
  for (unsigned copy = 0; copy < 9; ++copy) {
    const double ox = double(int(copy % 3) - 1) * Lx, oy = double(int(copy / 3) - 1) * Ly;
    for (std::size_t i = 0; i < n; ++i)
      pts.emplace_back(DT::Point(xy[2 * i] + ox, xy[2 * i + 1] + oy), unsigned(9 * i + copy));
  }
  DT t;
  t.insert(pts.begin(), pts.end());
  if (t.number_of_vertices() != 9 * n) coincident(xy);

  constexpr unsigned kCentre = 4;  // copy index of offset (0, 0)
  PeriodicTriangles out;
  out.method = "CGAL Delaunay_triangulation_2 of the 3x3 periodic copies";
  double longest = 0;
  bool bad = false;
  std::string why;
  for (auto f = t.finite_faces_begin(); f != t.finite_faces_end(); ++f) {
    unsigned info[3];
    for (int k = 0; k < 3; ++k) info[k] = f->vertex(k)->info();
    int low = 0;
    for (int k = 1; k < 3; ++k)
      if (info[k] / 9 < info[low] / 9) low = k;
    const bool touches_centre = info[0] % 9 == kCentre || info[1] % 9 == kCentre || info[2] % 9 == kCentre;
    if (info[0] / 9 == info[1] / 9 || info[1] / 9 == info[2] / 9 || info[0] / 9 == info[2] / 9) {
      if (touches_centre) {
        bad = true;
        why = "a particle is joined to its own periodic image";
      }
      continue;
    }
    if (touches_centre)
      for (int k = 0; k < 3; ++k) {
        const auto p = f->vertex(k)->point(), q = f->vertex((k + 1) % 3)->point();
        longest = std::max(longest, std::hypot(q.x() - p.x(), q.y() - p.y()));
      }
    if (info[low] % 9 != kCentre) continue;
    std::array<int, 3> tri;
    for (int k = 0; k < 3; ++k) tri[k] = int(info[k] / 9);
    for (int k = 0; k < 3 && !bad; ++k) {
      const auto p = f->vertex(k)->point(), q = f->vertex((k + 1) % 3)->point();
      if (!(std::fabs(q.x() - p.x()) < 0.5 * Lx && std::fabs(q.y() - p.y()) < 0.5 * Ly)) {
        bad = true;
        why = "an edge is longer than half the box";
      }
    }
    // The circumdisk must lie inside the 3 x 3 copies, or points beyond them could fall in it.
    const auto cc = CGAL::circumcenter(f->vertex(0)->point(), f->vertex(1)->point(), f->vertex(2)->point());
    const double r = std::sqrt(CGAL::squared_distance(cc, f->vertex(0)->point()));
    if (!bad && (cc.x() - r < -Lx || cc.x() + r > 2 * Lx || cc.y() - r < -Ly || cc.y() + r > 2 * Ly)) {
      bad = true;
      why = "a Delaunay circle is larger than the box";
    }
    out.triangles.push_back(tri);
  }
  if (!bad && out.triangles.size() != 2 * n) {
    bad = true;
    why = "the triangles do not tile the periodic box once (" + std::to_string(out.triangles.size()) +
          " triangles for " + std::to_string(n) + " particles, expected " + std::to_string(2 * n) + ")";
  }
  if (bad) too_sparse(n, Lx, Ly, longest, "cannot triangulate the periodic box (" + why + ")");
  return out;
}

}  // namespace

PeriodicTriangles periodic_delaunay(const std::vector<double>& xy, double Lx, double Ly) {
  const std::size_t n = xy.size() / 2;
  if (n < 3) throw InputError("delaunay.build: a triangulation needs at least 3 particles");
  if (!(Lx > 0 && Ly > 0)) throw InputError("delaunay.build: the box has no area");
  // Wrap into [0, L) (positions are wrapped, but a float coordinate can round onto L).
  std::vector<double> w(xy);
  for (std::size_t i = 0; i < n; ++i)
    for (int k = 0; k < 2; ++k) {
      const double L = k ? Ly : Lx;
      double& x = w[2 * i + k];
      x -= L * std::floor(x / L);
      if (x >= L) x -= L;
      if (x < 0) x = 0;
    }
  PeriodicTriangles out;
  if (Lx == Ly && try_periodic(w, Lx, out)) return out;
  return from_copies(w, Lx, Ly);
}

}  // namespace ff::delaunay
