// Running a loaded pipeline on a team of ranks in a test (core/run/team.h): one thread a rank,
// or alone when there is one rank, each rank's Simulation set up one at a time as `pipeline run`
// sets them up.
#pragma once
#include <functional>
#include <memory>
#include <mutex>

#include "core/backend/comm.h"
#include "core/run/simulation.h"
#include "core/run/team.h"
#include "support/pipeline.h"

namespace ff::test {

// body(comm) on every rank of a team of `ranks` on `backend`; body(nullptr) once when ranks == 1.
inline void on_ranks(Backend backend, int ranks, const std::function<void(Communicator*)>& body) {
  if (ranks == 1) {
    body(nullptr);
    return;
  }
  Team team = make_team(backend, ranks);
  run_team(team, [&](Communicator& comm) { body(&comm); });
}

// The Simulation of `l` for one rank (comm null: alone), without output files (dry run).
inline std::unique_ptr<Simulation> rank_simulation(const LoadedPipeline& l, Backend backend, Communicator* comm) {
  RunOptions o;
  o.backend = backend;
  o.dry_run = true;
  o.team = comm;
  static std::mutex setup;
  std::lock_guard<std::mutex> lock(setup);
  return std::make_unique<Simulation>(l.spec, *l.registry, o);
}

}  // namespace ff::test
