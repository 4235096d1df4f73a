// Running a loaded pipeline on a team of ranks in a test (core/run/team.h): one thread a rank,
// or alone when there is one rank, each rank's Simulation set up one at a time as `pipeline run`
// sets them up.
#pragma once
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

#include <catch2/catch.hpp>

#include "core/backend/comm.h"
#include "core/backend/device.h"
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

// The sizes of {2, 4} a team of GPUs can have on this machine; WARNs "SKIPPED" for the others
// (none at all with fewer than 2 GPUs: NCCL refuses two ranks on one GPU), so a run with fewer
// GPUs says what it left out.
inline std::vector<int> gpu_team_sizes() {
  const int gpus = cuda_device_count();
  std::vector<int> sizes;
  if (gpus < 2) {
    WARN("SKIPPED (" << gpus << " CUDA device(s); " << nccl_description()
                     << "): a decomposed team of GPUs needs 2 or more (NCCL refuses two ranks on one GPU)");
    return sizes;
  }
  for (int ranks : {2, 4}) {
    if (ranks > gpus)
      WARN("SKIPPED: " << ranks << " GPUs asked, " << gpus << " present");
    else
      sizes.push_back(ranks);
  }
  return sizes;
}

}  // namespace ff::test
