// voronoi.geometry: the Voronoi cells of the particles, read off the maintained periodic
// Delaunay triangulation (2D; De Fabritiis & Coveney §2, spec D1): per particle the cell's area,
// perimeter, centroid and number of sides; optionally per Delaunay edge the length and midpoint
// of its Voronoi face (`faces: true`) and every circumcentre (Voronoi vertex). One pass over the
// particles (kernel.h), each summing its own cell in a fixed order: the same bits on both
// backends. The same pass sums the metrics' integer terms (geometry/cpu.cpp, geometry/cuda.cu);
// the host reads them after the step (after_step), so on CUDA the stages after this one queue
// behind its kernel instead of waiting for the host.
// List it after delaunay.lawson:
//
//   - {stage: delaunay.lawson}
//   - {stage: voronoi.geometry}                     # positions: delaunay (default) or current
//   - {stage: observe.h5md, every: 1000, fields: [position, voronoi.area, voronoi.sides]}
//
// `positions: delaunay` builds the cells on delaunay.position_prev, the positions Lawson made
// the triangulation Delaunay for: the true Voronoi cells of those positions. `current` builds
// them on `position`: after a stage that moves particles past Lawson (overlap_correct), the
// dual of a triangulation that may be slightly non-Delaunay for them, whose faces may then have
// small negative lengths (the cells still tile the box exactly).
#pragma once
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
#include "stages/voronoi/geometry/fields.h"
#include "stages/voronoi/geometry/kernel.h"

namespace ff::voronoi {

struct GeometryParams {
  std::string positions = "delaunay";
  bool faces = false;  // no pipeline reads them (bench/README.md, voronoi.geometry: what they cost)
  bool circumcenters = false;
  bool metrics = true;

  template <class P>
  void describe(P& p) {
    p(positions, "positions",
      "delaunay: the cells of delaunay.position_prev, the positions the triangulation is Delaunay for; current: "
      "the cells of `position` on the maintained triangulation (after overlap_correct possibly slightly "
      "non-Delaunay: faces of small negative length)")
        .one_of({"delaunay", "current"});
    p(faces, "faces",
      "write each Delaunay edge's Voronoi face: voronoi.face_length (3N) and voronoi.face_midpoint (3N x 2). Off "
      "by default: in double they add 72 bytes a particle to the 104 the cells move, and on CUDA the cells alone "
      "take a faster kernel");
    p(circumcenters, "circumcenters",
      "write voronoi.circumcenter (6N x 2): per half-edge h, the circumcentre of the triangle left of h (each "
      "Voronoi vertex three times, once per corner of its triangle)");
    p(metrics, "metrics",
      "report area_mean, area_variance, sides_variance and area_sum_error (integer sums over the particles, "
      "made in the cells' pass and read after the step)");
  }
};

// The loop of each backend (geometry/cpu.cpp, geometry/cuda.cu): the cells of particles [0, n),
// and with sums.out their metric terms' sums (kernel.h, MetricSums).
template <class R>
struct GeometryLoops {
  void (*cells)(std::size_t n, const CellGeometry<R>& f, MetricSums sums, CUstream_st* s);
};
template <class R>
GeometryLoops<R> geometry_loops(CpuExec);
template <class R>
GeometryLoops<R> geometry_loops(CudaExec);

template <class R>
class Geometry final : public Stage {
 public:
  static StageDecl declaration() {
    return {"voronoi.geometry",
            "Voronoi cells from the maintained Delaunay triangulation: area, perimeter, centroid, sides per particle; "
            "with faces: true face length and midpoint per edge (list it after delaunay.lawson)",
            schema_of<GeometryParams>(), {2}, false};
  }

  template <class Exec>
  Geometry(const ParamValues& v, const RunInfo&, Exec exec)
      : p_(params_from<GeometryParams>(v)),
        where_(Exec::where),
        loops_(geometry_loops<R>(exec)),
        mem_(exec.memory()),
        sums_(exec),
        landing_(exec),
        fence_(mem_.fence_create()) {}
  ~Geometry() override { mem_.fence_destroy(fence_); }
  Geometry(const Geometry&) = delete;
  Geometry& operator=(const Geometry&) = delete;

  std::vector<Access> accesses() const override {
    std::vector<Access> a{{source(), where_, Mode::read},
                          {delaunay::fields::halfedge, where_, Mode::read},
                          {delaunay::fields::vertex_edge, where_, Mode::read},
                          {delaunay::fields::status, Where::host, Mode::read},
                          {fields::area, where_, Mode::write},
                          {fields::perimeter, where_, Mode::write},
                          {fields::centroid, where_, Mode::write},
                          {fields::sides, where_, Mode::write}};
    if (p_.faces) {
      a.push_back({fields::face_length, where_, Mode::write});
      a.push_back({fields::face_midpoint, where_, Mode::write});
    }
    if (p_.circumcenters) a.push_back({fields::circumcenter, where_, Mode::write});
    return a;
  }

  void configure(State& s) override {
    if (s.dim() != 2)
      throw InputError("voronoi.geometry works on the 2D Delaunay triangulation (system.dimensions is " +
                       std::to_string(s.dim()) + ")");
    for (const char* f : {delaunay::fields::halfedge, delaunay::fields::vertex_edge, delaunay::fields::status,
                          delaunay::fields::position_prev})
      if (!s.has_field(f))
        throw InputError(std::string("voronoi.geometry needs the Delaunay triangulation (field '") + f +
                         "'), which no stage before it provides: put it after the delaunay stages in `step:` "
                         "(delaunay.detect_inversion, delaunay.flip, delaunay.lawson after the integrator, or "
                         "delaunay.build)");
    const std::size_t n = s.n();
    s.add_field(fields::area, s.real(), 1, n);
    s.add_field(fields::perimeter, s.real(), 1, n);
    s.add_field(fields::centroid, s.real(), 2, n);
    s.add_field(fields::sides, DType::i32, 1, n);
    if (p_.faces) {
      s.add_field(fields::face_length, s.real(), 1, delaunay::edge_count(n));
      s.add_field(fields::face_midpoint, s.real(), 2, delaunay::edge_count(n));
    }
    if (p_.circumcenters) s.add_field(fields::circumcenter, s.real(), 2, delaunay::halfedge_count(n));
  }

  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    if (!s.field(delaunay::fields::status).host<std::int32_t>()[delaunay::kBuilt])
      throw RunError("voronoi.geometry: step " + std::to_string(ctx.host_params.step) +
                     ": no Delaunay triangulation has been built yet; put delaunay.build (or "
                     "delaunay.detect_inversion) before voronoi.geometry");
    const std::size_t n = s.n();
    const CellGeometry<R> cells{s.field(delaunay::fields::halfedge).data<std::int32_t>(ctx),
                                s.field(delaunay::fields::vertex_edge).data<std::int32_t>(ctx),
                                {s.field(source()).template data<R>(ctx), PeriodicBox<double>::make(s.box.L)},
                                int(n),
                                s.field(fields::area).data<R>(ctx),
                                s.field(fields::perimeter).data<R>(ctx),
                                s.field(fields::centroid).data<R>(ctx),
                                s.field(fields::sides).data<std::int32_t>(ctx),
                                p_.faces ? s.field(fields::face_length).data<R>(ctx) : nullptr,
                                p_.faces ? s.field(fields::face_midpoint).data<R>(ctx) : nullptr,
                                p_.circumcenters ? s.field(fields::circumcenter).data<R>(ctx) : nullptr,
                                scales(s)};
    pending_ = p_.metrics && n > 0;
    loops_.cells(n, cells, pending_ ? MetricSums{sums_.get(4), landing_.get(3)} : MetricSums{}, st);
    if (pending_) mem_.fence_record(fence_, st);
    return Outcome::ok();
  }

  // The metrics of this step's cells (waits for the cells' loop only). Not called when a later
  // stage rolls the step back: the next run() starts over.
  void after_step(StepContext& ctx) override {
    if (!pending_) return;
    pending_ = false;
    mem_.fence_wait(fence_);
    const std::uint64_t* t = landing_.get(3);
    report(ctx, t[0], t[1], t[2]);
  }

 private:
  const char* source() const {
    return p_.positions == "current" ? ff::fields::position : delaunay::fields::position_prev;
  }

  // The metrics from integer sums (the same on both backends): the areas in fixed point relative
  // to the mean area L_x L_y / N, with as many fraction bits as keep Σ (= N at the mean) at most
  // 2^61, so that area_sum_error is exact to N × 2^-(bits+1) / N = 2^-42 at N = 2^20; their
  // squares with the bits that keep Σ q² ≤ (Σ |q|)² ≈ N² at most 2^61 (any distribution of areas).
  struct Bits {
    int bits, bits2;
  };
  static Bits fraction_bits(const State& s) {
    const int log2n = int(std::ceil(std::log2(double(s.n()))));
    return {61 - log2n, 61 - 2 * log2n};
  }
  static double mean_area(const State& s) { return s.box.L[0] * s.box.L[1] / double(s.n()); }
  static MetricScales scales(const State& s) {
    if (s.n() == 0) return {};
    const Bits b = fraction_bits(s);
    const double mean = mean_area(s);
    return {std::ldexp(1.0, b.bits) / mean, 1.0 / mean, std::ldexp(1.0, b.bits2)};
  }

  void report(StepContext& ctx, std::uint64_t sum_area, std::uint64_t sum_area2, std::uint64_t s2) {
    const State& s = ctx.state;
    const double N = double(s.n()), mean = mean_area(s);
    const Bits b = fraction_bits(s);
    const double one = std::ldexp(1.0, b.bits), one2 = std::ldexp(1.0, b.bits2);
    const auto q = std::int64_t(sum_area);
    const auto q2 = std::int64_t(sum_area2);
    if (const std::uint64_t broken = s2 >> kBrokenShift)
      throw RunError("voronoi.geometry: step " + std::to_string(ctx.host_params.step) + ": the half-edges around " +
                     std::to_string(broken) + " particle(s) do not form a closed fan of at most " +
                     std::to_string(kMaxSides) + " triangles (a corrupt triangulation); a delaunay stage before "
                     "voronoi.geometry failed to keep it valid");
    const double qm = double(q) / one / N;  // Σ V_i / (L_x L_y)
    ctx.metrics.set("area_mean", qm * mean);
    ctx.metrics.set("area_variance", double(q2) / one2 / N - qm * qm);
    // Σ sides = 6N on the torus (every half-edge leaves one vertex): the mean is 6.
    ctx.metrics.set("sides_variance", double(s2) / N - 36.0);
    ctx.metrics.set("area_sum_error", qm - 1.0);
  }

  GeometryParams p_;
  Where where_;
  GeometryLoops<R> loops_;
  const MemoryOps& mem_;
  Scratch<std::uint64_t> sums_;         // MetricSums::device
  HostScratch<std::uint64_t> landing_;  // MetricSums::out
  void* fence_;                         // recorded after the cells' loop
  bool pending_ = false;                // metrics to read in after_step
};

}  // namespace ff::voronoi

FLIPFLOW_STAGE(ff::voronoi::Geometry)
