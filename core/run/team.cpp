#include "core/run/team.h"

#include <exception>
#include <mutex>
#include <string>
#include <thread>

#include "core/backend/device.h"
#include "core/base/error.h"

namespace ff {

Team make_team(Backend backend, int ranks) {
  if (ranks < 1) throw InputError("--gpus must be at least 1 (got " + std::to_string(ranks) + ")");
  Team t;
  t.backend = backend;
  if (backend == Backend::cpu) {
    t.ranks = make_thread_team(ranks);
    return t;
  }
  const int have = cuda_device_count();
  if (ranks > have)
    throw InputError("--gpus " + std::to_string(ranks) + ": this machine shows " + std::to_string(have) +
                     " CUDA device(s) (CUDA_VISIBLE_DEVICES limits them)");
  for (int r = 0; r < ranks; ++r) t.devices.push_back(r);
  t.ranks = make_nccl_team(t.devices);
  return t;
}

void run_team(Team& team, const std::function<void(Communicator&)>& body) {
  std::mutex m;
  std::exception_ptr first;
  std::string first_what;
  std::exception_ptr lead;  // rank 0's
  std::string lead_what;
  auto rank_main = [&](int r) {
    Communicator& comm = *team.ranks[std::size_t(r)];
    auto keep = [&](std::exception_ptr e, const std::string& what) {
      {
        std::lock_guard<std::mutex> lock(m);
        if (!first) {
          first = e;
          first_what = what;
        }
        if (r == 0) {
          lead = e;
          lead_what = what;
        }
      }
      comm.abort(what);
    };
    try {
      if (team.backend == Backend::cuda) use_cuda_device(team.devices[std::size_t(r)]);
      body(comm);
    } catch (const std::exception& e) {
      keep(std::current_exception(), e.what());
    } catch (...) {
      keep(std::current_exception(), "unknown exception");
    }
  };
  if (team.size() == 1) {
    rank_main(0);
  } else {
    std::vector<std::thread> threads;
    for (int r = 0; r < team.size(); ++r) threads.emplace_back(rank_main, r);
    for (auto& t : threads) t.join();
  }
  // Every rank meets a failure of the step together; rank 0, which writes the outputs and the
  // checkpoints, may have added to its message (the newest checkpoint and how to continue) after
  // a faster rank's plain one arrived first.
  if (lead && lead != first && lead_what.rfind(first_what, 0) == 0) std::rethrow_exception(lead);
  if (first) std::rethrow_exception(first);
}

}  // namespace ff
