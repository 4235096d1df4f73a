// delaunay.check: an observer that compares the maintained triangulation with CGAL's Delaunay
// triangulation of the current positions (check.cpp, through build/cgal.cpp) and stops the run
// with a RunError naming the step and the first differing edges when they disagree. Edges that
// differ only where their four points are co-circular (within `tolerance` of the in-circle
// determinant's rounding scale) are ties, not mismatches: either diagonal is Delaunay there.
// Host-side; registered for cpu and cuda (it declares host reads, the core copies the fields).
// Schedule it sparingly (`every: 10000`): CGAL rebuilds the triangulation each time.
#pragma once
#include <sstream>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/delaunay/check/check.h"
#include "stages/delaunay/common/host.h"

namespace ff::delaunay {

struct CheckParams {
  double tolerance = 1e-9;
  std::string positions = "position";

  template <class P>
  void describe(P& p) {
    p(tolerance, "tolerance",
      "an edge that differs from CGAL's is a co-circular tie (not a mismatch) when |in-circle| <= tolerance x its "
      "permanent; keep it above delaunay.lawson's tolerance (1e-10)")
        .at_least(0);
    p(positions, "positions",
      "positions to triangulate with CGAL: 'position', or 'delaunay.position_prev' (the positions Lawson last made the "
      "triangulation Delaunay for) when a stage such as overlap_correct moves particles after delaunay.lawson")
        .one_of({"position", "delaunay.position_prev"});
  }
};

class Check final : public Stage {
 public:
  // Host work on either backend (the core copies the fields it declares).
  static StageDecl declaration() {
    return {"delaunay.check",
            "observer: compare the maintained triangulation with CGAL's Delaunay triangulation of the current "
            "positions (co-circular ties tolerated); RunError naming the step and edges on a mismatch",
            schema_of<CheckParams>(),
            {2},
            true};
  }

  Check(const ParamValues& v, const RunInfo&) : p_(params_from<CheckParams>(v)) {}

  std::vector<Access> accesses() const override {
    // Reads only; when no triangulation exists yet (an observer at step 0, before any topology
    // stage ran) it is built from the current positions, as the first topology stage would.
    std::vector<Access> a{{ff::fields::position, Where::host, Mode::read},
                          {fields::halfedge, Where::host, Mode::read},
                          {fields::vertex_edge, Where::host, Mode::read},
                          {fields::status, Where::host, Mode::read}};
    if (p_.positions != ff::fields::position) a.push_back({p_.positions, Where::host, Mode::read});
    return a;
  }
  void configure(State& s) override { add_topology_fields(s, "delaunay.check"); }

  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    ensure_topology(ctx, *this);
    const std::size_t n = s.n();
    Field& pos = s.field(p_.positions);
    std::vector<double> xy(2 * n);
    if (pos.dtype() == DType::f32)
      std::copy(pos.host<float>(), pos.host<float>() + 2 * n, xy.begin());
    else
      std::copy(pos.host<double>(), pos.host<double>() + 2 * n, xy.begin());
    const std::string where = "delaunay.check: step " + std::to_string(ctx.host_params.step) + ": ";
    CheckReport r;
    try {
      r = compare_with_cgal(s.field(fields::halfedge).host<std::int32_t>(),
                            s.field(fields::vertex_edge).host<std::int32_t>(), n, xy, s.box.L[0], s.box.L[1],
                            p_.tolerance);
    } catch (const InputError& e) {
      throw RunError(where + "CGAL cannot triangulate the current positions (" + e.what() + ")");
    }
    ctx.metrics.set("checked", 1);
    ctx.metrics.set("mismatches", double(r.mismatches));
    ctx.metrics.set("ties", double(r.ties));
    if (!r.structure.empty())
      throw RunError(where + "the maintained half-edges are not a triangulation of the torus: " + r.structure);
    if (r.inverted)
      throw RunError(where + std::to_string(r.inverted) +
                     " triangle(s) of the maintained triangulation are not positively oriented");
    if (r.mismatches) {
      std::string msg = where + "the maintained triangulation differs from CGAL's Delaunay triangulation of '" +
                        p_.positions + "' (" + r.method + ") in " + std::to_string(r.mismatches) +
                        " edge(s) that are not co-circular ties (tolerance " + format(p_.tolerance) +
                        "; " + std::to_string(r.edges_only_maintained) + " edge(s) only in the maintained one, " +
                        std::to_string(r.edges_only_cgal) + " only in CGAL's). First: ";
      for (std::size_t k = 0; k < r.first.size(); ++k) msg += (k ? "; " : "") + describe(r.first[k]);
      if (p_.positions == ff::fields::position)
        msg += ". (If a stage moves particles after delaunay.lawson, such as overlap_correct, check "
               "positions: delaunay.position_prev, the positions Lawson made the triangulation Delaunay for.)";
      throw RunError(msg);
    }
    return Outcome::ok();
  }

  const CheckParams& params() const { return p_; }

 private:
  static std::string format(double v) {
    std::ostringstream os;
    os << v;
    return os.str();
  }

  CheckParams p_;
};

}  // namespace ff::delaunay

FLIPFLOW_HOST_STAGE(ff::delaunay::Check)
