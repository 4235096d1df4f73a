// voronoi.mirror: each particle's Voronoi cell clipped by the hard walls of a slab (De Fabritiis
// & Coveney §4.2, spec D2 W2), CPU and CUDA with the same bits. For a pipeline with walls
// (overlap_correct's `walls: y`): list it after the correction to have the cells in every step
// (a model that reads them), or its observer form voronoi.mirror_observer (end of this file)
// before observe.h5md for the cells of the frames only:
//
//   - {stage: overlap_correct, mode: reflect, cap: 0.25, walls: y}
//   - {stage: voronoi.mirror, walls: y}
//   - {stage: observe.h5md, every: 1000, fields: [position, image, voronoi.area, voronoi.sides]}
//
// It writes voronoi.geometry's per-particle fields (voronoi.area, .perimeter, .centroid, .sides)
// for the real particles, so everything that reads those (observe.h5md, tools/render) serves
// both; voronoi.geometry and voronoi.mirror are alternatives in one pipeline.
//
// How: the doubled box (spec W2). With walls at 0 and L along the wall axis, particle i's mirror
// image N + i sits at 2L − c (c its coordinate along the axis) in the periodic box doubled
// along that axis, whose seams are then the two walls. Among the 2N points, a real particle's
// Voronoi cell is its cell among the real particles clipped by the walls: the bisector of i and
// its own image is the wall, and for any point x on the real side the image j' of another
// particle is never nearer than j (|x − j'| ≥ |x − j|), so images cut nothing but the walls.
// The stage writes the 2N points from `position` (kernel.h MirrorPoints), keeps its own Delaunay
// triangulation of them in its own fields (voronoi.mirror.*), and reads the real cells off it
// with voronoi.geometry's kernel (geometry/kernel.h, one thread per real particle).
//
// Its triangulation is maintained from call to call like the pipeline's. Lawson's first round
// (kernel.h FirstRound: every edge) also checks that it is still a triangulation at the new
// points: every triangle closes under minimum image and is surely positive, and the triangles
// cover the doubled box once (an integer sum of their areas). If so, Lawson's rounds
// (delaunay.lawson's test and tolerance; common/flip.h's lowest-id conflict rule; later rounds
// test only the edges around a flip and the marked edges that lost, as delaunay.lawson's) make
// it Delaunay, with the same flips on both backends. If not (the first call, or moves that
// inverted a triangle: typical when the stage runs only every few hundred steps), it is rebuilt
// on the host with delaunay.build's CGAL code (build.cpp). Either way the result is the Delaunay
// triangulation of the points, so the cells are exact.
//
// Why its own triangulation and not the pipeline's:
// - The pipeline's torus triangulation clipped at the walls is not exact. Its edges across the
//   seam join particles at opposite walls: a particle at distance a below the top wall and one
//   at distance b above the bottom wall facing it have their bisector at (b − a)/2 from the
//   wall, inside the slab when a > b, cutting the cell short; and two particles at the same wall
//   whose clipped cells share a face need not be joined (a particle at the other wall, between
//   them in x, takes their place across the seam: disks at 2σ along the top wall, one in contact
//   with the bottom wall half way between them). No clipping of the torus cells repairs that.
// - Making the pipeline's triangulation the doubled one (the spec's first sketch: 2N vertices,
//   images slaved) changes N for every stage: the integrators, the force stages, overlap_correct
//   (which would have to skip real–image pairs), the observers and the output would all have to
//   know which half is real. Here nothing else changes; the cost is a second triangulation of
//   2N points (memory 12N half-edges; per call one pass over its 6N edges, a few cheaper rounds,
//   one pass over the N cells) paid only on the steps the cells are asked for, and the stage
//   works with any pipeline (Delaunay or Verlet corrections alike): it reads only `position`.
#pragma once
#include <array>
#include <cmath>
#include <cstdint>
#include <string>

#include "core/backend/exec.h"
#include "core/backend/memory.h"
#include "core/base/error.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/delaunay/common/fields.h"
#include "stages/delaunay/common/flip.h"
#include "stages/voronoi/geometry/kernel.h"
#include "stages/voronoi/geometry/fields.h"
#include "stages/voronoi/mirror/build.h"
#include "stages/voronoi/mirror/kernel.h"

namespace ff::voronoi {

struct MirrorParams {
  std::string walls = "y";
  double tolerance = 1e-10;
  std::int64_t max_rounds = 1000;

  template <class P>
  void describe(P& p) {
    p(walls, "walls", "the axis the two hard walls are perpendicular to, at 0 and L along it (as overlap_correct's walls)")
        .one_of({"x", "y"});
    p(tolerance, "tolerance",
      "Lawson's in-circle tolerance relative to the determinant's rounding scale (as delaunay.lawson's): co-circular "
      "points within it are left as they are (a particle and a neighbour near the same wall, with their images, are "
      "four co-circular points: the cells get a face of length 0)")
        .at_least(0);
    p(max_rounds, "max_rounds", "most Lawson rounds per call before the run stops with an error").at_least(1);
  }
};

template <class R>
class Mirror : public Stage {
 public:
  static StageDecl declaration() {
    return {"voronoi.mirror",
            "each particle's Voronoi cell clipped by the hard walls of a slab (mirror images in the doubled box, its own "
            "triangulation): writes voronoi.area, .perimeter, .centroid, .sides",
            schema_of<MirrorParams>(), {2}, false};
  }

  template <class Exec>
  Mirror(const ParamValues& v, const RunInfo&, Exec exec)
      : p_(params_from<MirrorParams>(v)),
        where_(Exec::where),
        axis_(p_.walls == "x" ? 0 : 1),
        mirror_(&Exec::template for_each<MirrorPoints<R>>),
        first_(&Exec::template sum<FirstRound<R>>),
        mark_(&Exec::template for_each<MarkRound<R>>),
        decide_(&Exec::template for_each<delaunay::DecideFlips>),
        apply_(&Exec::template for_each<ApplyRound>),
        cells_(&Exec::template for_each<CellGeometry<R>>),
        sum_area_(&Exec::template sum<AreaTerm<R>>),
        reduction_(exec),
        marks_(exec),
        stamps_(exec),
        counters_(exec) {}

  std::vector<Access> accesses() const override {
    return {{ff::fields::position, where_, Mode::read},
            {mirror_fields::position, where_, Mode::write},
            {mirror_fields::halfedge, where_, Mode::readwrite},
            {mirror_fields::opposite, where_, Mode::readwrite},
            {mirror_fields::vertex_edge, where_, Mode::readwrite},
            {mirror_fields::status, Where::host, Mode::readwrite},
            {fields::area, where_, Mode::write},
            {fields::perimeter, where_, Mode::write},
            {fields::centroid, where_, Mode::write},
            {fields::sides, where_, Mode::write}};
  }

  void configure(State& s) override {
    if (s.dim() != 2)
      throw InputError("voronoi.mirror: the doubled-box triangulation is 2D (system.dimensions is " +
                       std::to_string(s.dim()) + ")");
    if (s.n() < 2) throw InputError("voronoi.mirror needs at least 2 particles");
    const std::size_t n = s.n(), m = 2 * n;
    s.add_field(mirror_fields::position, s.real(), 2, m);
    s.add_field(mirror_fields::halfedge, DType::i32, 2, delaunay::halfedge_count(m));
    s.add_field(mirror_fields::opposite, DType::i32, 1, delaunay::halfedge_count(m));
    s.add_field(mirror_fields::vertex_edge, DType::i32, 1, m);
    s.add_field(mirror_fields::status, DType::i32, 1, 1);
    s.add_field(fields::area, s.real(), 1, n);
    s.add_field(fields::perimeter, s.real(), 1, n);
    s.add_field(fields::centroid, s.real(), 2, n);
    s.add_field(fields::sides, DType::i32, 1, n);
  }

  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    const std::size_t n = s.n(), m = 2 * n, edges = delaunay::edge_count(m);
    double L2[3] = {s.box.L[0], s.box.L[1], 0};
    L2[axis_] *= 2;
    const PeriodicBox<double> box2 = PeriodicBox<double>::make(L2);
    R* pts = s.field(mirror_fields::position).data<R>(ctx);
    mirror_(n, MirrorPoints<R>{s.field(ff::fields::position).data<R>(ctx), pts, int(n), axis_, R(L2[axis_])}, st);

    std::uint8_t* mark = marks_.get(2 * edges);
    std::uint8_t* go = mark + edges;
    std::int32_t* stamp = stamps_.get(edges);
    unsigned* c = counters_.ptr();
    const double scale = std::ldexp(1.0, kAreaBits) / (L2[0] * L2[1]);
    // Round 0 with the validity test; a rebuild when the triangulation is not one any more (or
    // none was built yet), then round 0 again on the new one.
    bool rebuilt = false;
    std::array<unsigned, kMirrorCounters> h{};
    for (int attempt = 0;; ++attempt) {
      const bool built = s.field(mirror_fields::status).host<std::int32_t>()[0] != 0;
      if (built) {
        counters_.reset(std::array<int, 0>{}, st);
        const std::uint64_t area = first_(
            edges, FirstRound<R>{mesh_of(ctx), {pts, box2}, p_.tolerance, scale, mark, stamp, c}, reduction_, st);
        h = counters_.read(st);
        // 3 x the doubled box's area: each triangle is on the sides of three edges.
        if (h[kMirrorBad] == 0 && std::fabs(double(area) * std::ldexp(1.0, -kAreaBits) / 3.0 - 1.0) < 1e-6) break;
        if (attempt > 0)
          throw RunError("voronoi.mirror: step " + std::to_string(ctx.host_params.step) +
                         ": the triangulation just built for the particles and their mirror images is not valid (" +
                         std::to_string(h[kMirrorBad]) + " bad triangle sides)");
      }
      build_mirror_mesh(s, L2, st);
      for (const Access& a : accesses()) s.field(a.field).acquire(a.where, a.mode, st);
      pts = s.field(mirror_fields::position).data<R>(ctx);
      rebuilt = true;
    }

    // Lawson's rounds: the lowest marked id wins both its triangles (common/flip.h), the winners
    // flip, and the next round tests only what changed.
    const delaunay::Mesh mesh = mesh_of(ctx);
    const delaunay::Points<R> points{pts, box2};
    std::int32_t round = 0;
    for (;; ++round) {
      if (h[kMirrorTooLong])
        throw RunError("voronoi.mirror: step " + std::to_string(ctx.host_params.step) + ": " +
                       std::to_string(h[kMirrorTooLong]) +
                       " Delaunay flip(s) of the doubled box would need an edge longer than half the box; "
                       "the slab holds too few particles for its size");
      if (!h[kMirrorMarked]) break;
      if (round == p_.max_rounds)
        throw RunError("voronoi.mirror: step " + std::to_string(ctx.host_params.step) + ": " +
                       std::to_string(h[kMirrorMarked]) + " edges still not locally Delaunay after max_rounds = " +
                       std::to_string(p_.max_rounds) + " Lawson rounds");
      decide_(edges, delaunay::DecideFlips{mesh, mark, go, c, kMirrorFlips}, st);
      apply_(edges, ApplyRound{mesh, mark, go, stamp, round + 1}, st);
      counters_.zero(kMirrorMarked, 2, st);  // marked and too long; the flips add up
      mark_(edges, MarkRound<R>{mesh, points, p_.tolerance, mark, stamp, round + 1, c}, st);
      h = counters_.read(st);
    }

    // The real particles' cells (vertices 0..N-1 of the 2N; faces and circumcentres not kept).
    R* area = s.field(fields::area).data<R>(ctx);
    const CellGeometry<R> cells{mesh.he, mesh.vedge, points, int(m), area, s.field(fields::perimeter).data<R>(ctx),
                                s.field(fields::centroid).data<R>(ctx), s.field(fields::sides).data<std::int32_t>(ctx),
                                nullptr, nullptr, nullptr};
    cells_(n, cells, st);

    // Σ V_i over the real particles in fixed point (as voronoi.geometry's metric): L_x L_y up to
    // rounding.
    const double N = double(n), mean = s.box.L[0] * s.box.L[1] / N;
    const double one = std::ldexp(1.0, 61 - int(std::ceil(std::log2(N))));
    const auto q = std::int64_t(sum_area_(n, AreaTerm<R>{area, one / mean}, reduction_, st));
    ctx.metrics.set("area_sum_error", double(q) / one / N - 1.0);
    ctx.metrics.set("rebuilt", rebuilt ? 1.0 : 0.0);
    ctx.metrics.set("lawson_rounds", double(round));
    ctx.metrics.set("lawson_flips", double(h[kMirrorFlips]));
    return Outcome::ok();
  }

 private:
  delaunay::Mesh mesh_of(StepContext& ctx) const {
    State& s = ctx.state;
    return {s.field(mirror_fields::halfedge).data<std::int32_t>(ctx),
            s.field(mirror_fields::vertex_edge).data<std::int32_t>(ctx),
            s.field(mirror_fields::opposite).data<std::int32_t>(ctx)};
  }

  MirrorParams p_;
  Where where_;
  int axis_;
  ElementLoop<MirrorPoints<R>> mirror_;
  ReduceLoop<FirstRound<R>, std::uint64_t> first_;
  ElementLoop<MarkRound<R>> mark_;
  ElementLoop<delaunay::DecideFlips> decide_;
  ElementLoop<ApplyRound> apply_;
  ElementLoop<CellGeometry<R>> cells_;
  ReduceLoop<AreaTerm<R>, std::uint64_t> sum_area_;
  Reduction<std::uint64_t> reduction_;
  Scratch<std::uint8_t> marks_;    // per edge: Lawson's marks, then the decisions (go)
  Scratch<std::int32_t> stamps_;   // per edge: the round in which to test it again
  Counters<kMirrorCounters> counters_;
};

// voronoi.mirror_observer: the same stage in the observer phase, after a step is accepted, at
// the steps of its `every:` / `at:` like observe.h5md. A compute stage with `every: k` runs on
// steps k, 2k, ... before they move the particles, so its cells would be a step old in a frame
// written at step k; listed before observe.h5md with the same `every`, the observer's cells are
// those of the frame. Between frames the particles move far, so each call usually rebuilds (on
// the host): cheap when frames are rare, and the pipeline's steps pay nothing.
template <class R>
class MirrorObserver final : public Mirror<R> {
 public:
  static StageDecl declaration() {
    StageDecl d = Mirror<R>::declaration();
    d.name = "voronoi.mirror_observer";
    d.summary =
        "voronoi.mirror as an observer: the cells clipped by the walls of the accepted step's positions, at the steps "
        "of its every/at (list it before observe.h5md with the same every)";
    d.observer = true;
    return d;
  }
  using Mirror<R>::Mirror;
};

}  // namespace ff::voronoi

FLIPFLOW_STAGE(ff::voronoi::Mirror)
FLIPFLOW_STAGE(ff::voronoi::MirrorObserver)
