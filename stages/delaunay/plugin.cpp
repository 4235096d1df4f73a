// The standard delaunay stage library: build, detect_inversion, flip, lawson (2D), and the
// observers check (against CGAL) and triangles (for H5MD /connectivity), and sort (particle order).
#include "core/plugin_api.h"

namespace ff::delaunay {
void register_build(Registry& r);
void register_detect_inversion(Registry& r);
void register_flip(Registry& r);
void register_lawson(Registry& r);
void register_check(Registry& r);
void register_triangles(Registry& r);
void register_sort(Registry& r);
}  // namespace ff::delaunay

static void register_delaunay(ff::Registry& r) {
  ff::delaunay::register_build(r);
  ff::delaunay::register_detect_inversion(r);
  ff::delaunay::register_flip(r);
  ff::delaunay::register_lawson(r);
  ff::delaunay::register_check(r);
  ff::delaunay::register_triangles(r);
  ff::delaunay::register_sort(r);
}

FLIPFLOW_PLUGIN(register_delaunay)
