// boids.polarisation: the polarisation Φ = |Σ_i u_i| / N of the boids' headings (1: all fly the same
// way; ~N^(-1/2) for random headings), reported as the metric `phi`: observe.h5md after it writes
// it under /observables/<stage id>/phi (tools/render --plot-observable boids.polarisation/phi).
// An observer: it runs after an accepted step, on the host (on CUDA the core copies the headings
// over on the steps it runs: give it `every`). Summed in index order in double: the same value on
// every backend and thread count.
#pragma once
#include <cmath>

#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "core/stage/state.h"
#include "plugins/boids/heading.h"

namespace ff::boids {

// Φ of a state's headings (host copy, acquired by the caller).
inline double polarisation(const State& s) {
  const Field& f = s.field(kHeading);
  double px = 0, py = 0;
  for (std::size_t i = 0; i < s.n(); ++i) {
    const double ux = s.precision() == Precision::f64 ? f.host<double>()[2 * i] : double(f.host<float>()[2 * i]);
    const double uy =
        s.precision() == Precision::f64 ? f.host<double>()[2 * i + 1] : double(f.host<float>()[2 * i + 1]);
    px += ux;
    py += uy;
  }
  return s.n() ? std::sqrt(px * px + py * py) / double(s.n()) : 0.0;
}

class Polarisation final : public Stage {
 public:
  static StageDecl declaration() {
    return {"boids.polarisation", "polarisation Φ = |Σ u_i|/N of the boids' headings (metric `phi`)", {}, {2}, true};
  }

  Polarisation(const ParamValues&, const RunInfo&) {}

  std::vector<Access> accesses() const override { return {{kHeading, Where::host, Mode::read}}; }

  void configure(State& s) override {
    if (!s.has_field(kHeading))
      throw InputError("boids.polarisation: there are no boids' headings (field 'boids.heading'); add the boids "
                       "stages (`- {stage: boids.forces}` and `- {stage: boids.integrate}`) to the step list");
  }

  Outcome run(StepContext& ctx) override {
    ctx.metrics.set("phi", polarisation(ctx.state));
    return Outcome::ok();
  }
};

}  // namespace ff::boids

FLIPFLOW_HOST_STAGE(ff::boids::Polarisation)
