// delaunay.lawson: parallel Lawson flips until every edge is locally Delaunay (Navarro et al.,
// as used by Carter et al. 2017). Rounds of mark / decide / apply over lists (kernel.h): round 0
// tests every edge, later rounds only the edges whose quad changed. The lowest marked edge id
// wins both of its triangles, so the result is independent of thread scheduling and backend.
// One host read per round. The input must be a valid (all triangles positive) triangulation:
// run delaunay.flip first.
#pragma once
#include <algorithm>
#include <array>

#include "core/error.h"
#include "core/exec.h"
#include "core/stage.h"
#include "stages/delaunay/common/host.h"
#include "stages/delaunay/common/memory.h"
#include "stages/delaunay/lawson/kernel.h"

namespace ff::delaunay {

struct LawsonParams {
  std::int64_t max_rounds = 1000;
  double tolerance = 1e-10;

  static std::vector<ParamSpec> schema() {
    return {ParamSpec::integer("max_rounds", 1000, "flip rounds before the run stops with an error").at_least(1),
            ParamSpec::real("tolerance", 1e-10,
                            "in-circle tolerance relative to the determinant's rounding scale (co-circular points "
                            "within it are left as they are)")
                .at_least(0)};
  }
  static LawsonParams from(const ParamValues& v) { return LawsonParams{v.integer("max_rounds"), v.real("tolerance")}; }
};

template <class R>
struct LawsonOps {
  ElementLoop<MarkNonDelaunay<R>> mark;
  ElementLoop<DecideMarked> decide;
  ElementLoop<ApplyMarked> apply;
  MemOps mem;
};

template <class R>
class Lawson final : public Stage {
 public:
  Lawson(LawsonParams p, Where where, LawsonOps<R> ops)
      : p_(p),
        where_(where),
        ops_(ops),
        counters_(ops.mem),
        marked_(ops.mem),
        queued_(ops.mem),
        go_(ops.mem),
        list_(ops.mem),
        marked_list_(ops.mem) {}

  std::vector<Access> accesses() const override {
    return {{ff::fields::position, where_, Mode::read},
            {fields::lawson_candidates, where_, Mode::read},
            {fields::halfedge, where_, Mode::readwrite, true},
            {fields::opposite, where_, Mode::readwrite, true},
            {fields::vertex_edge, where_, Mode::readwrite, true},
            {fields::status, Where::host, Mode::readwrite}};
  }
  void configure(State& s) override { add_topology_fields(s, "delaunay.lawson"); }

  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    CUstream_st* st = ctx.stream;
    ensure_topology(ctx, accesses());
    if (status(s)[kPending])
      throw RunError("delaunay.lawson: " + std::to_string(status(s)[kPending]) +
                     " inverted triangle(s) found by delaunay.detect_inversion were not repaired; put delaunay.flip "
                     "between delaunay.detect_inversion and delaunay.lawson");
    const Mesh m = mesh_view(s, where_);
    const Points<R> pts = points_view<R>(s, ff::fields::position, where_);
    const std::size_t E = edge_count(s.n());
    if (round_ > 2000000000) {  // stamps are round ids: start over long before they wrap
      marked_.reset();
      queued_.reset();
      round_ = 0;
    }
    std::int32_t* marked = marked_.get(E);
    std::int32_t* queued = queued_.get(E);
    std::uint8_t* go = go_.get(E);
    std::int32_t* list = list_.get(E);
    std::int32_t* marked_list = marked_list_.get(E);
    unsigned* c = counters_.ptr();

    counters_.reset(std::array<int, 1>{kLawsonTooLongAt}, st);
    std::size_t launch = E;             // round 0 tests every edge ...
    const std::int32_t* test = nullptr;
    const unsigned* test_len = nullptr;  // later rounds: the list's length, on the backend
    // ... or only detect_inversion's candidates (a superset of the edges round 0 would mark),
    // when they are current: no flip or rebuild since (status kCandidates) and nothing wrote
    // the positions since (their Field::version, recorded by detect_inversion).
    const std::int32_t hint = status(s)[kCandidates];
    status(s)[kCandidates] = 0;  // consumed: the flips below change quads
    // The candidates are those with in-circle determinant > 0, computed by the same code in
    // another loop; at tolerance 0 a co-circular quad (determinant at rounding level) could
    // in principle round differently there (FMA contraction on the device), so test all.
    if (hint > 0 && p_.tolerance >= 1e-13 &&
        position_version(status(s)) == s.field(ff::fields::position).version()) {
      launch = unsigned(hint - 1);  // the list's length: the launch's own size
      test = data<std::int32_t>(s.field(fields::lawson_candidates), where_);
    }
    unsigned flips = 0;
    std::int64_t rounds = 0;  // rounds that flipped something
    for (;;) {
      const std::int32_t round = ++round_;
      ops_.mark(launch,
                MarkNonDelaunay<R>{m, pts, p_.tolerance, test, test_len, marked, round, marked_list, c, unsigned(launch)},
                st);
      const auto& h = counters_.read(st);
      throw_if_too_long_flip(s, h[kLawsonTooLong], h[kLawsonTooLongAt], st);
      const unsigned n_marked = h[kLawsonMarked];
      flips = h[kLawsonFlips];
      if (!n_marked) break;
      if (rounds >= p_.max_rounds)
        throw RunError("delaunay.lawson: the triangulation is still not Delaunay after max_rounds = " +
                       std::to_string(p_.max_rounds) + " rounds (" + std::to_string(flips) + " flips; " +
                       std::to_string(n_marked) +
                       " edge(s) left). Raise max_rounds, or raise tolerance if points are (nearly) co-circular");
      if (rounds == 0) will_flip(ctx);  // announce before the first flip (rollback snapshot)
      counters_.zero(kLawsonMarked, 2, st);  // marked and queued lengths
      ops_.decide(n_marked, DecideMarked{m, marked, round, marked_list, go, c}, st);
      ops_.apply(n_marked, ApplyMarked{m, marked_list, go, queued, round + 1, list, c}, st);
      test = list;
      test_len = c + kLawsonQueued;
      launch = std::min<std::size_t>(4 * std::size_t(n_marked), E);  // each queues at most 4 (apply)
      ++rounds;
    }
    ctx.metrics.set("lawson_rounds", double(rounds));
    ctx.metrics.set("lawson_flips", flips);
    return Outcome::ok();
  }

 private:
  void throw_if_too_long_flip(State& s, unsigned count, unsigned at, CUstream_st* st) {
    if (!count) return;
    const auto ids = edge_vertices(s, where_, ops_.mem, int(at), st);
    throw RunError("delaunay.lawson: restoring the Delaunay property needs an edge longer than half the box (next to "
                   "the edge between particles " +
                   list_ids(ids) + "; " + std::to_string(count) +
                   " such flip(s)); the periodic triangulation is stored by minimum image and cannot hold it. Use a "
                   "larger system (more particles at this density)");
  }

  LawsonParams p_;
  Where where_;
  LawsonOps<R> ops_;
  Counters<kLawsonCounters> counters_;
  Scratch<std::int32_t> marked_;  // round stamps: marked in that round
  Scratch<std::int32_t> queued_;  // round stamps: queued for that round
  Scratch<std::uint8_t> go_;
  Scratch<std::int32_t> list_;         // edges to test in the next round
  Scratch<std::int32_t> marked_list_;  // edges marked in this round
  std::int32_t round_ = 0;
};

}  // namespace ff::delaunay
