// A team of ranks running one simulation in one process (issue 21, `pipeline run --gpus N`):
// one thread per rank, each with its own Simulation built on its own device, talking through
// its Communicator (core/backend/comm.h). Either every rank holds the whole state and the stages
// that split their work (TeamWork::split) exchange their results so that every rank ends each
// step with the bits one rank alone would have, or the team is decomposed (core/run/domain.h):
// each rank holds a slab of particles and ghosts. Rank 0 writes every output.
#pragma once
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/backend/comm.h"
#include "core/base/types.h"

namespace ff {

struct Team {
  Backend backend = Backend::cpu;
  std::vector<int> devices;  // CUDA: the device of each rank; empty on the CPU
  std::vector<std::unique_ptr<Communicator>> ranks;
  int size() const { return int(ranks.size()); }
};

// `ranks` ranks: a thread team on the CPU; on CUDA one rank per device 0..ranks-1 through NCCL
// (InputError naming what is missing: GPUs, NCCL).
Team make_team(Backend backend, int ranks);

// Runs body(rank's communicator) on one thread per rank (CUDA: the thread's current device is
// the rank's first). When a rank throws, the team is aborted, so the other ranks' waits in
// collectives end in RunError instead of hanging; after every thread has ended, the first
// exception thrown (the cause, not the aborts it caused) is rethrown.
void run_team(Team& team, const std::function<void(Communicator&)>& body);

}  // namespace ff
