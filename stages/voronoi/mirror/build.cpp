#include "stages/voronoi/mirror/build.h"

#include <cstring>
#include <sstream>
#include <vector>

#include "core/base/error.h"
#include "stages/delaunay/build/build.h"
#include "stages/delaunay/build/cgal.h"
#include "stages/delaunay/common/fields.h"
#include "stages/delaunay/common/hilbert.h"
#include "stages/delaunay/common/mesh.h"

namespace ff::voronoi {

void build_mirror_mesh(State& s, const double L2[2], CUstream_st* stream) {
  Field& pos = s.field(mirror_fields::position);
  const std::size_t m = pos.size() / 2;  // 2N vertices
  pos.acquire(Where::host, Mode::read, stream);
  std::vector<double> xy(2 * m);
  if (pos.dtype() == DType::f32)
    std::copy(pos.host<float>(), pos.host<float>() + 2 * m, xy.begin());
  else
    std::copy(pos.host<double>(), pos.host<double>() + 2 * m, xy.begin());
  delaunay::PeriodicTriangles tri;
  try {
    tri = delaunay::periodic_delaunay(xy, L2[0], L2[1]);
  } catch (const delaunay::TooSparse& e) {
    // Too few particles: said in the user's terms (their N and box; the doubled box has the same
    // density), an input error as delaunay.build's for the pipeline's own triangulation.
    const int axis = L2[0] != s.box.L[0] ? 0 : 1;
    std::ostringstream os;
    os.precision(4);
    os << "voronoi.mirror: with N = " << m / 2 << " in a " << s.box.L[0] << " x " << s.box.L[1]
       << " box between walls at " << "xy"[axis] << " = 0 and " << s.box.L[axis] << " (number density "
       << double(m / 2) / (s.box.L[0] * s.box.L[1])
       << ") the cells clipped by the walls cannot be computed: the triangulation of the particles and their mirror "
          "images (the doubled box) has an edge of length "
       << e.longest << ", longer than half the doubled box. At this density use N >= " << (e.need + 1) / 2
       << " (or a denser system)";
    throw InputError(os.str());
  } catch (const std::exception& e) {
    throw RunError(std::string("voronoi.mirror: step ") + std::to_string(s.step) +
                   ": cannot triangulate the particles with their mirror images (images are numbered N + i; a particle "
                   "exactly on a wall coincides with its image): " + e.what());
  }
  const std::vector<std::int32_t> rank = delaunay::hilbert_ranks(xy, L2[0], L2[1]);
  const delaunay::HalfEdges h = delaunay::assemble(tri.triangles, m, &rank);
  Field& he = s.field(mirror_fields::halfedge);
  he.acquire(Where::host, Mode::write, stream);
  std::memcpy(he.host<std::int32_t>(), h.he.data(), h.he.size() * sizeof(std::int32_t));
  Field& op = s.field(mirror_fields::opposite);
  op.acquire(Where::host, Mode::write, stream);
  for (std::size_t k = 0; k < delaunay::halfedge_count(m); ++k)
    op.host<std::int32_t>()[k] = delaunay::opposite_of(h.he.data(), int(k));
  Field& ve = s.field(mirror_fields::vertex_edge);
  ve.acquire(Where::host, Mode::write, stream);
  std::memcpy(ve.host<std::int32_t>(), h.vedge.data(), h.vedge.size() * sizeof(std::int32_t));
  Field& st = s.field(mirror_fields::status);
  st.acquire(Where::host, Mode::write, stream);
  st.host<std::int32_t>()[0] = 1;
}

}  // namespace ff::voronoi
