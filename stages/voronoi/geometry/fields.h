// The per-particle and per-edge fields of voronoi.geometry, which voronoi.mirror writes too
// (the real particles' cells clipped by walls): one list of names for both stages.
#pragma once

namespace ff::voronoi {

namespace fields {
inline constexpr const char* area = "voronoi.area";                    // real, N
inline constexpr const char* perimeter = "voronoi.perimeter";          // real, N
inline constexpr const char* centroid = "voronoi.centroid";            // real x 2, N
inline constexpr const char* sides = "voronoi.sides";                  // i32, N
inline constexpr const char* face_length = "voronoi.face_length";      // real, 3N (per Delaunay edge)
inline constexpr const char* face_midpoint = "voronoi.face_midpoint";  // real x 2, 3N
inline constexpr const char* circumcenter = "voronoi.circumcenter";    // real x 2, 6N (per half-edge)
}  // namespace fields

}  // namespace ff::voronoi
