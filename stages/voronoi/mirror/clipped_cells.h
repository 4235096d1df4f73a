// Test helper (CGAL, tests only): the reference cells of points in a slab, x-periodic with
// walls at y = 0 and y = L_y. Each real point's cell is the strip clipped by the bisectors with
// its neighbours in CGAL's non-periodic Delaunay triangulation of the points and their copies at
// x ± L_x (Sutherland–Hodgman): the Voronoi cell among the particles, cut by the walls.
#pragma once
#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <cmath>
#include <vector>

namespace ff::test::slab {

struct Pt {
  double x, y;
};

// The convex polygon `poly` cut by the half-plane {p : (p − m)·n ≤ 0}.
inline std::vector<Pt> clip(const std::vector<Pt>& poly, Pt m, Pt n) {
  std::vector<Pt> out;
  auto side = [&](Pt p) { return (p.x - m.x) * n.x + (p.y - m.y) * n.y; };
  for (std::size_t k = 0; k < poly.size(); ++k) {
    const Pt a = poly[k], b = poly[(k + 1) % poly.size()];
    const double sa = side(a), sb = side(b);
    if (sa <= 0) out.push_back(a);
    if ((sa < 0 && sb > 0) || (sa > 0 && sb < 0)) {
      const double t = sa / (sa - sb);
      out.push_back({a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)});
    }
  }
  return out;
}

struct Cell {
  double area = 0, perimeter = 0, cx = 0, cy = 0;  // centroid relative to the site
};

// The cells of the real points (x-periodic, walls at 0 and Ly) from CGAL's non-periodic
// Delaunay triangulation of the points and their copies at x ± Lx. With torus = true the
// copies at y ± Ly are in too: the cells of the periodic (torus) Voronoi diagram clipped at the
// walls, which are not the walled cells (what voronoi.mirror's test shows).
inline std::vector<Cell> clipped_cells(const std::vector<double>& xy, double Lx, double Ly, bool torus = false) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  using Vb = CGAL::Triangulation_vertex_base_with_info_2<int, K>;
  using Tds = CGAL::Triangulation_data_structure_2<Vb>;
  using DT = CGAL::Delaunay_triangulation_2<K, Tds>;
  const std::size_t n = xy.size() / 2;
  DT T;
  std::vector<DT::Vertex_handle> real(n);
  for (int copy_y = torus ? -1 : 0; copy_y <= (torus ? 1 : 0); ++copy_y)
    for (int copy = -1; copy <= 1; ++copy)
      for (std::size_t i = 0; i < n; ++i) {
        auto v = T.insert(K::Point_2(xy[2 * i] + copy * Lx, xy[2 * i + 1] + copy_y * Ly));
        v->info() = int(i);
        if (copy == 0 && copy_y == 0) real[i] = v;
      }
  std::vector<Cell> cells(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Pt s{xy[2 * i], xy[2 * i + 1]};
    std::vector<Pt> poly{{s.x - Lx, 0}, {s.x + Lx, 0}, {s.x + Lx, Ly}, {s.x - Lx, Ly}};
    auto circ = T.incident_vertices(real[i]), end = circ;
    do {
      if (T.is_infinite(circ)) continue;
      const Pt q{circ->point().x(), circ->point().y()};
      poly = clip(poly, {0.5 * (s.x + q.x), 0.5 * (s.y + q.y)}, {q.x - s.x, q.y - s.y});
    } while (++circ != end);
    Cell& c = cells[i];
    for (std::size_t k = 0; k < poly.size(); ++k) {
      const Pt a{poly[k].x - s.x, poly[k].y - s.y};
      const Pt b{poly[(k + 1) % poly.size()].x - s.x, poly[(k + 1) % poly.size()].y - s.y};
      const double t = 0.5 * (a.x * b.y - a.y * b.x);
      c.area += t;
      c.cx += t * (a.x + b.x) / 3;
      c.cy += t * (a.y + b.y) / 3;
      c.perimeter += std::hypot(b.x - a.x, b.y - a.y);
    }
    c.cx /= c.area;
    c.cy /= c.area;
  }
  return cells;
}

}  // namespace ff::test::slab
