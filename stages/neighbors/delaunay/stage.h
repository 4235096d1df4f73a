// neighbors.delaunay: for every particle, all particles within `radius`, found by graph search on
// the maintained 2D periodic Delaunay triangulation (Porro et al.; spec seed-gaps P1): no grid,
// no list to rebuild. The search and why it is exact are in kernel.h.
//
// Output: the list fields of stages/neighbors/list.h (neighbors.list / count / cutoff = radius /
// position_at_build), rows sorted ascending, so the consumers of neighbors.verlet's list (pair
// forces through pair_force.h, phoretic short range, observe.clusters with pairs: verlet) take
// either source unchanged. Unlike a Verlet list it has no skin: every row is exact for the
// positions of this step (position_at_build) and holds no pair beyond `radius`. It does not
// write neighbors.build_params or the cell fields, which only a Verlet list's own rebuild
// (verlet/build.h) can use: overlap_correct.verlet, which rebuilds the list it corrects on,
// refuses it and asks for neighbors.verlet. Its rows are a multiple of 4 slots long.
//
// Place it after delaunay.lawson (and after overlap_correct when that runs), or at the start of a
// step after the first triangulation exists (delaunay.build before it): anywhere but between
// delaunay.detect_inversion and delaunay.lawson. It searches the positions the triangulation was
// made Delaunay for (delaunay.position_prev), widened by twice the largest move since (moves of
// the overlap correction, or of the integrator when it runs at the start of the step). Each
// step: the gather of the table of one-rings (compact rows and a 16-byte record per vertex),
// which also reduces the largest move, and the search, which reads that move where the gather
// left it and reduces the row slots it needed (loops.h); the host reads the results once, after
// the search. A row that overflowed is grown and the search repeated (metrics `max_visited`,
// `capacity`).
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "core/backend/exec.h"
#include "core/base/error.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/delaunay/common/fields.h"
#include "stages/neighbors/delaunay/search_parent.h"
#include "stages/neighbors/delaunay/search_visited.h"
#include "stages/neighbors/delaunay/loops.h"
#include "stages/neighbors/list.h"

namespace ff::neighbors {

struct DelaunaySearchParams {
  double radius = 1.5;
  std::string traversal = "visited";
  std::int64_t capacity = 0;

  template <class P>
  void describe(P& p) {
    p(radius, "radius", "r (a length in the box's units, not scaled by σ): every pair closer than r (and no other) is listed; neighbors.cutoff = r").above(0);
    p(traversal, "traversal",
      "visited: breadth-first with a visited set in the row (fewer distance evaluations); parent: depth-first "
      "along parent links (the ring member closest to the centre), no visited set")
        .one_of({"visited", "parent"});
    p(capacity, "capacity",
      "initial row length of the list, rounded up to a multiple of 4, which is also the search's working memory "
      "beyond 16 queue slots (0: from the density); grown when a search overflows it")
        .at_least(0);
  }
};

template <class R>
class DelaunaySearch final : public Stage {
 public:
  static StageDecl declaration() {
    return {"neighbors.delaunay",
            "particles within a radius by graph search on the maintained Delaunay triangulation (fields "
            "neighbors.list/count, no grid, no rebuild)",
            schema_of<DelaunaySearchParams>(), {2}, false};
  }

  template <class Exec>
  DelaunaySearch(const ParamValues& v, const RunInfo&, Exec exec)
      : p_(params_from<DelaunaySearchParams>(v)),
        where_(Exec::where),
        loops_(delaunay_loops<R>(exec)),
        words_(exec),
        table_(exec),
        record_(exec) {}

  std::vector<Access> accesses() const override {
    namespace df = delaunay::fields;
    return {{fields::position, where_, Mode::read},         {df::position_prev, where_, Mode::read},
            {df::halfedge, where_, Mode::read},             {df::vertex_edge, where_, Mode::read},
            {df::status, Where::host, Mode::read},          {kList, where_, Mode::write},
            {kCount, where_, Mode::write},                  {kPositionAtBuild, where_, Mode::write}};
  }

  void configure(State& s) override {
    namespace df = delaunay::fields;
    if (s.dim() != 2)
      throw InputError("neighbors.delaunay searches the 2D Delaunay triangulation (system.dimensions is " +
                       std::to_string(s.dim()) + "): use neighbors.verlet in 3D");
    for (const char* f : {df::halfedge, df::vertex_edge, df::position_prev, df::status})
      if (!s.has_field(f))
        throw InputError(std::string("neighbors.delaunay needs the maintained Delaunay triangulation (field '") + f +
                         "'), which no stage before it provides: list `delaunay.build` (every: a large k, for the first "
                         "step's triangulation) before it, and delaunay.detect_inversion, delaunay.flip and "
                         "delaunay.lawson after the integrator to keep it, as pipelines/bench-boids-delaunay.yaml does");
    if (s.has_field(kList))
      throw InputError("neighbors.delaunay: a stage before it already writes neighbors.list (neighbors.verlet or "
                       "another neighbors.delaunay); a pipeline has one neighbour list: keep one of them");
    const double lmin = std::min(s.box.L[0], s.box.L[1]);
    if (!(2 * p_.radius < lmin))
      throw InputError("neighbors.delaunay: radius = " + std::to_string(p_.radius) +
                       " is not less than half the smallest box edge (" + std::to_string(lmin) +
                       "); the minimum image would miss pairs: use a larger box or a smaller radius");
    const std::size_t n = s.n();
    if (table_slots(n) >= (std::size_t(1) << 32))
      throw InputError("neighbors.delaunay: " + std::to_string(n) + " particles are more than its 32-bit ring "
                       "table addresses (2^32 / 9): use neighbors.verlet");
    s.add_field(kList, DType::u32, 1, n * initial_capacity(s));
    s.add_particle_field(kCount, DType::u32, 1);
    s.add_particle_field(kPositionAtBuild, s.real(), 2);
    Field& cut = s.add_field(kCutoff, s.real(), 1, 1);
    cut.acquire(Where::host, Mode::write);
    cut.host<R>()[0] = R(p_.radius);
  }

  Outcome run(StepContext& ctx) override {
    namespace df = delaunay::fields;
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    const std::size_t n = s.n();
    const std::string at = "neighbors.delaunay: step " + std::to_string(ctx.host_params.step) + ": ";
    const std::int32_t* status = s.field(df::status).host<std::int32_t>();
    if (!status[delaunay::kBuilt])
      throw RunError(at + "no Delaunay triangulation has been built yet; put delaunay.lawson (or delaunay.build) "
                          "before neighbors.delaunay in `step:`");
    // Between delaunay.detect_inversion and delaunay.lawson the triangulation is not yet Delaunay
    // for position_prev (detection has just set it to the new positions): repairs pending, or
    // Lawson's candidates listed and not yet consumed. (A candidate list that overflowed leaves no
    // trace; the order in `step:` is what guarantees exactness.)
    if (status[delaunay::kPending] || status[delaunay::kCandidates])
      throw RunError(at + "the triangulation is not Delaunay yet (delaunay.detect_inversion ran after the last "
                          "delaunay.lawson); put neighbors.delaunay after delaunay.flip and delaunay.lawson in `step:`");
    if (n == 0) return Outcome::ok();

    const R* x = s.field(fields::position).data<R>(ctx);
    const R* prev = s.field(df::position_prev).data<R>(ctx);
    const auto box = PeriodicBox<double>::make(s.box.L);
    const double lmax = std::max(s.box.L[0], s.box.L[1]), lmin = std::min(s.box.L[0], s.box.L[1]);
    // expand_radius's margin, and the float rounding of the positions in GatherRing's records
    // (half an ulp of the box edge per coordinate, wrapped positions, at both ends of a distance).
    const double margin = 16 * double(std::numeric_limits<R>::epsilon()) * lmax +
                          4 * double(std::numeric_limits<float>::epsilon()) * lmax;
    const delaunay::Points<R> old{prev, box};
    const std::int32_t* he = s.field(df::halfedge).data<std::int32_t>(ctx);
    const std::int32_t* ve = s.field(df::vertex_edge).data<std::int32_t>(ctx);
    Field& list = s.field(kList);
    std::uint32_t* count = s.field(kCount).data<std::uint32_t>(ctx);
    R* at_build = s.field(kPositionAtBuild).data<R>(ctx);
    words_.reset(std::array<int, 0>{}, st);
    std::uint32_t* words = words_.ptr();
    const std::uint32_t slots = std::uint32_t(table_slots(n));
    std::uint32_t* table = table_.get(slots);
    std::uint32_t* record = record_.get(4 * n);
    loops_.gather(n, GatherRing<R>{he, ve, std::uint32_t(n), table, slots, record, {x, box}, prev}, words, st);
    std::uint32_t m2_bits = 0, result = 0;
    for (;;) {
      const std::uint32_t cap = list_capacity(s);
      SearchBase<R> base{old,   x,     PeriodicBox<R>::make(s.box.L), R(p_.radius * p_.radius), p_.radius, margin,
                         lmin,  words, table, record, cap, list.data<std::uint32_t>(ctx), count, at_build};
      if (p_.traversal == "parent") loops_.parent(n, SearchParent<R>{base}, words, st);
      else loops_.visited(n, SearchVisited<R>{base}, words, st);
      const auto& w = words_.read(st);  // the step's one wait for the device
      m2_bits = w[0];
      result = w[1];
      if (result & kRingOverflow)  // more than the 6N half-edges of a periodic triangulation
        throw RunError(at + "the one-rings of the triangulation hold more than its 6N half-edges, which a valid "
                            "triangulation never does; run delaunay.check to find what is wrong with it");
      if (result & kTooFar) {
        const double m = std::sqrt(double(bits_float(m2_bits)));
        throw RunError(at + "particles moved up to " + std::to_string(m) +
                       " since delaunay.lawson, so the search must reach radius + 2·move = " +
                       std::to_string(expand_radius(m2_bits, p_.radius, margin)) +
                       ", not less than half the smallest box edge (" + std::to_string(lmin) +
                       "); lower run.dt, or use a larger box or a smaller radius");
      }
      if (result <= cap) break;
      // A row overflowed: double it (its working set is not known) and search again.
      if (cap >= 2 * n + 2)
        throw RunError(at + "the search of some particle needed more than 2N row slots, which a valid triangulation "
                            "never does; run delaunay.check to find what is wrong with it");
      list.resize(n * std::min<std::size_t>(2 * std::size_t(cap), round4(2 * n + 2)));
      list.acquire(where_, Mode::write, st);
      words_.zero(1, 1, st);
    }
    ctx.metrics.set("max_visited", double(result));
    ctx.metrics.set("capacity", double(list_capacity(s)));
    ctx.metrics.set("max_move", std::sqrt(double(bits_float(m2_bits))));
    return Outcome::ok();
  }

 private:
  // Slots of the ring table: a periodic triangulation's rings hold its 6N half-edges, and each
  // row is padded to a multiple of 4 (at most 3 more per vertex).
  static std::size_t table_slots(std::size_t n) { return 9 * n; }

  // n rounded up to a multiple of 4 (rows are written four slots at a time).
  static std::size_t round4(std::size_t n) { return (n + 3) & ~std::size_t(3); }

  // The ball of r at the mean density, with room for clusters and the visited rim.
  std::uint32_t initial_capacity(const State& s) const {
    const double most = 2 * double(s.n()) + 2;
    if (p_.capacity > 0) return std::uint32_t(round4(std::size_t(std::min(double(p_.capacity), most))));
    constexpr double pi = 3.14159265358979323846;
    const double ball = double(s.n()) / s.box.volume() * pi * p_.radius * p_.radius;
    return std::uint32_t(round4(std::size_t(std::min(std::ceil(2 * ball) + 16, most))));
  }

  DelaunaySearchParams p_;
  Where where_;
  DelaunayLoops<R> loops_;
  Counters<3> words_;                // the loops' result words (loops.h)
  Scratch<std::uint32_t> table_;     // 9n: the one-rings (GatherRing)
  Scratch<std::uint32_t> record_;    // 4n: each vertex's position, row start and degree
};

}  // namespace ff::neighbors

FLIPFLOW_STAGE(ff::neighbors::DelaunaySearch)
