// Host-side helpers of the delaunay stage classes: adding the topology fields, building the
// triangulation on first use, views of the fields on the stage's side, and naming the
// particles of an edge or triangle in messages. nvcc-clean (declarations and plain inlines).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "core/backend/memory.h"
#include "core/physics/box.h"
#include "core/stage/stage.h"
#include "stages/delaunay/common/fields.h"
#include "stages/delaunay/common/mesh.h"

namespace ff::delaunay {

// Adds every topology field (idempotent). InputError unless the state is 2D with N >= 3.
void add_topology_fields(State& s, const char* stage_name);

// The status record (host side; stages declare it as a host access).
std::int32_t* status(State& s);

// If no triangulation exists yet (status kBuilt == 0), build one from the current positions
// (delaunay.build's CGAL path) and re-acquire the stage's accesses so its declared side is
// current. Announces the writes first (will_build). Returns true when it built. (The stage, not
// its accesses: they are a vector of names built on each call, wanted only when it builds.)
bool ensure_topology(const StepContext& ctx, const Stage& stage);

// The topology fields a flip rewrites (declared Access::on_demand by the stages that flip only
// on some steps): announce them before the first flip of a step.
void will_flip(const StepContext& ctx);
// Everything build_topology writes that the stages declare on demand: the flipped fields and
// delaunay.position_prev. Announce before every build, so that a rollback restores them and
// detect_inversion can tell a triangulation built earlier in the step from the one the step
// inherited (StepContext::at_step_start(position_prev) is then the snapshot's copy).
void will_build(const StepContext& ctx);

inline Mesh mesh_view(State& s, Where w) {
  return {s.field(fields::halfedge).data<std::int32_t>(w), s.field(fields::vertex_edge).data<std::int32_t>(w),
          s.field(fields::opposite).data<std::int32_t>(w)};
}

template <class R>
Points<R> points_view(State& s, const char* field, Where w) {
  return {s.field(field).data<R>(w), PeriodicBox<double>::make(s.box.L)};
}

// The vertices of the triangle left of half-edge h, read from the stage's side (small copies
// on the device; used only for messages).
std::vector<std::uint64_t> triangle_vertices(State& s, Where w, const MemoryOps& mem, int h, CUstream_st* stream);
// The endpoints of edge e.
std::vector<std::uint64_t> edge_vertices(State& s, Where w, const MemoryOps& mem, int e, CUstream_st* stream);
// RunError when `count` triangles (lowest at edge `at`) do not close under minimum image.
void throw_if_too_long(State& s, Where w, const MemoryOps& mem, unsigned count, unsigned at, CUstream_st* stream,
                       const char* stage);
// "12, 57 and 60"
std::string list_ids(const std::vector<std::uint64_t>& ids);

}  // namespace ff::delaunay
