// voronoi.mirror's host side: the Delaunay triangulation of the doubled point set from scratch
// (delaunay.build's CGAL code, stages/delaunay/build), for the first call and whenever the
// stage's own triangulation is no longer valid at the new points. nvcc-clean (declarations).
#pragma once
#include <string>

#include "core/stage/state.h"

namespace ff::voronoi {

// Names of the stage's own fields: the doubled points and their triangulation.
namespace mirror_fields {
inline constexpr const char* position = "voronoi.mirror.position";        // real x 2, 2N: particles, then images
inline constexpr const char* halfedge = "voronoi.mirror.halfedge";        // i32 x 2, 12N (as delaunay.halfedge)
inline constexpr const char* opposite = "voronoi.mirror.opposite";        // i32, 12N (as delaunay.opposite)
inline constexpr const char* vertex_edge = "voronoi.mirror.vertex_edge";  // i32, 2N (as delaunay.vertex_edge)
inline constexpr const char* status = "voronoi.mirror.status";            // i32, 1 (host): 1 once built
}  // namespace mirror_fields

// Triangulates the 2N points of mirror_fields::position (on the host: `stream` only brings them
// there) in the periodic box L2 (the doubled box) and writes halfedge, opposite, vertex_edge and
// status on the host. RunError when a particle lies on a wall (it coincides with its image);
// InputError, in the user's N and box, when there are too few particles for the periodic
// triangulation of the doubled box.
void build_mirror_mesh(State& s, const double L2[2], CUstream_st* stream);

}  // namespace ff::voronoi
