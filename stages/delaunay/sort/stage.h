// delaunay.sort: renumbers the particles along a Hilbert curve over the box, once, when the
// pipeline is configured (before any step or output); in 2D the periodic curve of
// common/hilbert.h, in 3D CGAL's (sort/hilbert3.cpp). Every field with one element per
// particle (position, image, type, diameter, and whatever the stages listed before it added)
// is permuted the same way, so the initial state is the same set of particles in another
// order. Afterwards neighbours in space are neighbours in memory: the triangulation's edge loops
// and any per-particle loop that gathers from neighbours (Verlet rows: pair.lj, phoretic short
// range, the 3D pipelines, which have no triangulation) hit the cache instead of memory. The
// order is made once: over a long run particles diffuse away from it, and the gain fades with
// the distance they travel relative to the box (neighbours stay near in memory while they stay
// within a few diameters).
//
// List it first in `step:` (or at least before any stage that keeps per-particle data outside
// State fields). It refuses to run on a state that already has a triangulation. Its per-step
// run() does nothing (capturable on CUDA). Particle numbers in outputs and messages are the
// sorted ones; for `init: random` (placed in random order anyway) nothing else changes.
#pragma once
#include <string>
#include <vector>

#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"

namespace ff::delaunay {

// Permutes every per-particle field of `s` (count == N) into Hilbert order of the positions.
// Returns the names of the fields permuted. InputError unless 2D or 3D, or if a triangulation
// exists.
std::vector<std::string> sort_particles_hilbert(State& s);

class Sort final : public Stage {
 public:
  // Host work on either backend (the core copies the fields it declares).
  static StageDecl declaration() {
    return {"delaunay.sort",
            "renumber the particles along a Hilbert curve once, at configure time (every per-particle field "
            "permuted alike), for memory locality; list it first",
            {},
            {2, 3},
            false};
  }
  Sort(const ParamValues&, const RunInfo&) {}

  std::vector<Access> accesses() const override { return {}; }
  void configure(State& s) override { sorted_ = sort_particles_hilbert(s); }
  Outcome run(StepContext&) override { return Outcome::ok(); }
  // In a decomposed team it has sorted the whole state before the particles are split among the
  // ranks (configure runs first), so every rank, and one rank alone, numbers them alike.
  Scheduling scheduling() const override {
    Scheduling sch{false, false, /*graph_capturable=*/true, false};
    sch.team = TeamWork::local;
    return sch;
  }
  const std::vector<std::string>& sorted_fields() const { return sorted_; }

 private:
  std::vector<std::string> sorted_;
};

}  // namespace ff::delaunay

FLIPFLOW_HOST_STAGE(ff::delaunay::Sort)
