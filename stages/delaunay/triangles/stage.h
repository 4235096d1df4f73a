// delaunay.triangles: an observer that writes the maintained triangulation's 2N triangles into
// the field `delaunay.triangles` (i32 x 3, count 2N, each CCW: positively oriented under minimum
// image), so observe.h5md can write them under /connectivity/delaunay.triangles:
//
//   - {stage: delaunay.triangles, every: 1000}
//   - {stage: observe.h5md, every: 1000, fields: [position, delaunay.triangles]}
//
// List it before observe.h5md (observers run in the listed order, and the field must exist when
// observe.h5md is configured) and give both the same `every`. Triangle k is the k-th triangle in
// half-edge order, written from its lowest half-edge h: (origin(h), origin(next(h)),
// origin(next(next(h)))). A separate observer rather than part of delaunay.check: this is O(N)
// and cheap, wanted as often as frames are written, while the CGAL check is a costly validation
// run rarely (or not at all). Host-side (an O(N) pass over the half-edges, done only when a
// frame is due); registered for cpu and cuda, the core copies the half-edges to the host.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/delaunay/common/host.h"

namespace ff::delaunay {

namespace fields {
// i32 x 3, count 2N: the triangles, CCW vertex triples (written by the delaunay.triangles observer).
inline constexpr const char* triangles = "delaunay.triangles";
}  // namespace fields

// Triangles of the half-edges `he` (2 x 6n) into out (3 x 2n), in half-edge order, each from its
// lowest half-edge. Returns how many were found (2n for a triangulation of the torus).
inline std::size_t fill_triangles(const std::int32_t* he, std::size_t n, std::int32_t* out, std::size_t capacity) {
  const Mesh m{const_cast<std::int32_t*>(he), nullptr};
  std::size_t t = 0;
  for (int h = 0; h < int(6 * n); ++h) {
    if (!m.canonical(h)) continue;
    if (t < capacity) {
      const int hn = m.next(h);
      out[3 * t] = m.origin(h);
      out[3 * t + 1] = m.origin(hn);
      out[3 * t + 2] = m.origin(m.next(hn));
    }
    ++t;
  }
  return t;
}

class Triangles final : public Stage {
 public:
  // Host work on either backend (the core copies the fields it declares).
  static StageDecl declaration() {
    return {"delaunay.triangles",
            "observer: the maintained triangles into the field delaunay.triangles (i32 x 3, 2N, CCW) for "
            "observe.h5md's /connectivity; list it before observe.h5md with the same every",
            {},
            {2},
            true};
  }
  Triangles(const ParamValues&, const RunInfo&) {}

  std::vector<Access> accesses() const override {
    return {{fields::halfedge, Where::host, Mode::read},
            {fields::status, Where::host, Mode::read},
            {fields::triangles, Where::host, Mode::write}};
  }
  void configure(State& s) override {
    add_topology_fields(s, "delaunay.triangles");
    s.add_field(fields::triangles, DType::i32, 3, 2 * s.n());
  }
  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    // At step 0, before any topology stage ran, build the triangulation the first one would.
    ensure_topology(ctx, *this);
    const std::size_t n = s.n();
    const std::size_t found = fill_triangles(s.field(fields::halfedge).host<std::int32_t>(), n,
                                             s.field(fields::triangles).host<std::int32_t>(), 2 * n);
    if (found != 2 * n)
      throw RunError("delaunay.triangles: step " + std::to_string(ctx.host_params.step) + ": the half-edges hold " +
                     std::to_string(found) + " triangles for " + std::to_string(n) +
                     " particles (a triangulation of the torus has 2N)");
    ctx.metrics.set("triangles", double(found));
    return Outcome::ok();
  }
};

}  // namespace ff::delaunay

FLIPFLOW_HOST_STAGE(ff::delaunay::Triangles)
