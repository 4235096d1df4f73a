#include "stages/delaunay/common/host.h"

#include <chrono>
#include <cstdio>

#include "core/backend/comm.h"
#include "core/base/error.h"
#include "stages/delaunay/build/build.h"

namespace ff::delaunay {

void add_topology_fields(State& s, const char* stage_name) {
  if (s.dim() != 2)
    throw InputError(std::string(stage_name) + ": the Delaunay triangulation stages are 2D only (system.dimensions is " +
                     std::to_string(s.dim()) + ")");
  if (s.n() < 3)
    throw InputError(std::string(stage_name) + ": a triangulation needs at least 3 particles (N = " +
                     std::to_string(s.n()) + ")");
  const std::size_t n = s.n();
  // In a decomposed team the particles a rank holds change at every migration: the fields sized
  // by them follow (the next build fills them). position_prev is per particle: it moves with
  // them, so a rank can triangulate its new particles where the triangulation alone is Delaunay.
  auto sized = [&](const char* name, DType t, int components, std::size_t count) {
    if (s.has_field(name) && s.field(name).count() != count) s.field(name).resize(count);
    s.add_field(name, t, components, count);
  };
  sized(fields::halfedge, DType::i32, 2, halfedge_count(n));
  sized(fields::opposite, DType::i32, 1, halfedge_count(n));
  sized(fields::vertex_edge, DType::i32, 1, n);
  s.add_particle_field(fields::position_prev, s.real(), 2);
  sized(fields::flip_mark, DType::u8, 1, edge_count(n));
  s.add_field(fields::status, DType::i32, kStatusSize, 1);
  sized(fields::lawson_candidates, DType::i32, 1, candidate_capacity(n));
  s.add_field(fields::lawson_candidate_count, DType::i32, 1, 1);
}

std::int32_t* status(State& s) { return s.field(fields::status).host<std::int32_t>(); }

void will_flip(const StepContext& ctx) {
  for (const char* f : {fields::halfedge, fields::opposite, fields::vertex_edge}) ctx.will_write(f);
}

void will_build(const StepContext& ctx) {
  will_flip(ctx);
  ctx.will_write(fields::position_prev);
}

bool ensure_topology(const StepContext& ctx, const Stage& stage) {
  State& s = ctx.state;
  CUstream_st* stream = ctx.stream;
  if (status(s)[kBuilt]) return false;
  will_build(ctx);
  // CGAL's build at the first step (again if that step is rolled back) takes ~1 s per 10^5
  // points on a CPU core: a large run's first progress line would otherwise come minutes after
  // its set-up. Said by a run alone (a team's ranks each build their share, at once).
  const bool large = s.n() >= 100000 && !in_team(ctx.run.team);
  const auto t0 = std::chrono::steady_clock::now();
  if (large)
    std::fprintf(ctx.run.messages, "flipflow: delaunay: triangulating %zu points (CGAL) ...\n", s.n());
  build_topology(s, stream);
  if (large)
    std::fprintf(ctx.run.messages, "flipflow: delaunay: triangulated in %.1f s\n",
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  for (const Access& a : stage.accesses()) s.field(a.field).acquire(a.where, a.mode, stream);
  return true;
}

namespace {
std::int32_t read_int(Field& f, Where w, const MemoryOps& mem, std::size_t index, CUstream_st* stream) {
  std::int32_t v = 0;
  const std::int32_t* base = f.data<std::int32_t>(w);
  mem.to_host(&v, base + index, sizeof v, stream);
  return v;
}
}  // namespace

std::vector<std::uint64_t> triangle_vertices(State& s, Where w, const MemoryOps& mem, int h, CUstream_st* stream) {
  Field& he = s.field(fields::halfedge);
  std::vector<std::uint64_t> v;
  for (int k = 0; k < 3; ++k) {
    v.push_back(std::uint64_t(read_int(he, w, mem, 2 * std::size_t(h), stream)));
    h = read_int(he, w, mem, 2 * std::size_t(h) + 1, stream);
  }
  return v;
}

std::vector<std::uint64_t> edge_vertices(State& s, Where w, const MemoryOps& mem, int e, CUstream_st* stream) {
  Field& he = s.field(fields::halfedge);
  return {std::uint64_t(read_int(he, w, mem, 4 * std::size_t(e), stream)),
          std::uint64_t(read_int(he, w, mem, 4 * std::size_t(e) + 2, stream))};
}

void throw_if_too_long(State& s, Where w, const MemoryOps& mem, unsigned count, unsigned at, CUstream_st* stream,
                       const char* stage) {
  if (!count) return;
  const auto ids = edge_vertices(s, w, mem, int(at), stream);
  throw RunError(std::string(stage) + ": a triangle at the edge between particles " + list_ids(ids) +
                 " no longer closes under minimum image (" + std::to_string(count) +
                 " edge(s)): an edge has grown longer than half the box, which the periodic triangulation cannot "
                 "store. Use a larger system (more particles at this density), a smaller run.dt (particles that move "
                 "far in a step stretch edges), or rebuild the triangulation more often (delaunay.build with every: k); "
                 "if the particles leave an empty region as wide as half the box (a trap, a droplet), find the "
                 "overlaps on a neighbour list instead: neighbors.verlet and overlap_correct.verlet "
                 "(pipelines/trap-hard-disks.yaml)");
}

std::string list_ids(const std::vector<std::uint64_t>& ids) {
  std::string out;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (i) out += i + 1 == ids.size() ? " and " : ", ";
    out += std::to_string(ids[i]);
  }
  return out;
}

}  // namespace ff::delaunay
