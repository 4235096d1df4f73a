// The CPU backend's Communicator: ranks are threads of one process sharing memory. Every
// operation is a rendezvous: each rank publishes what it has (a pointer), all meet at a barrier,
// each rank copies or reduces what it needs from the others' buffers, and all meet again before
// anyone may touch its buffer. Reductions are formed by every rank in rank order, so every rank
// gets the same bits (and the same as a one-rank run for max).
#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <mutex>

#include "core/backend/comm.h"
#include "core/base/error.h"

namespace ff {

namespace {

#ifndef FLIPFLOW_HAVE_NCCL_HEADER
const char* built_without_nccl_reason() {
#ifdef FLIPFLOW_HAVE_CUDA
  return "NCCL (nccl.h was not found at configure time)";
#else
  return "CUDA";
#endif
}
#endif

struct ThreadTeamShared {
  explicit ThreadTeamShared(int n) : ranks(n), published(std::size_t(n)), lists(std::size_t(n)) {}
  const int ranks;
  std::mutex m;
  std::condition_variable cv;
  std::uint64_t generation = 0;
  int arrived = 0;
  bool aborted = false;
  std::string why;
  std::vector<const void*> published;
  std::vector<const std::vector<Communicator::Transfer>*> lists;

  // Waits until every rank arrived; RunError if the team was aborted before (or while) waiting.
  void meet() {
    std::unique_lock<std::mutex> lock(m);
    if (aborted) throw RunError("team aborted: " + why);
    const std::uint64_t g = generation;
    if (++arrived == ranks) {
      arrived = 0;
      ++generation;
      cv.notify_all();
      return;
    }
    cv.wait(lock, [&] { return generation != g || aborted; });
    if (generation == g) throw RunError("team aborted: " + why);
  }
};

class ThreadCommunicator final : public Communicator {
 public:
  ThreadCommunicator(std::shared_ptr<ThreadTeamShared> team, int rank) : team_(std::move(team)), rank_(rank) {}
  int rank() const override { return rank_; }
  int size() const override { return team_->ranks; }

  void all_gather_slices(void* data, const std::vector<std::size_t>& offsets, CUstream_st*) override {
    const Timer t(*this);
    check_offsets(offsets);
    team_->published[std::size_t(rank_)] = data;
    team_->meet();
    auto* mine = static_cast<unsigned char*>(data);
    for (int r = 0; r < size(); ++r) {
      if (r == rank_) continue;
      const auto* theirs = static_cast<const unsigned char*>(team_->published[std::size_t(r)]);
      std::memcpy(mine + offsets[std::size_t(r)], theirs + offsets[std::size_t(r)],
                  offsets[std::size_t(r) + 1] - offsets[std::size_t(r)]);
    }
    team_->meet();  // nobody writes its buffer while another still copies from it
  }

  void all_reduce(double* values, std::size_t n, ReduceOp op) override { reduce(values, n, op); }
  void all_reduce(std::int64_t* values, std::size_t n, ReduceOp op) override { reduce(values, n, op); }

  void exchange(const std::vector<Transfer>& transfers, CUstream_st*) override {
    const Timer t(*this);
    team_->lists[std::size_t(rank_)] = &transfers;
    team_->meet();
    std::vector<int> received(std::size_t(size()), 0);  // receives from each peer so far
    for (const Transfer& x : transfers) {
      if (x.send) continue;
      if (x.peer < 0 || x.peer >= size() || x.peer == rank_)
        throw RunError("Communicator::exchange: rank " + std::to_string(rank_) + " receives from rank " +
                       std::to_string(x.peer));
      const int k = received[std::size_t(x.peer)]++;
      int seen = 0;
      const Transfer* match = nullptr;
      for (const Transfer& y : *team_->lists[std::size_t(x.peer)])
        if (y.send && y.peer == rank_ && seen++ == k) {
          match = &y;
          break;
        }
      if (!match || match->bytes != x.bytes)
        throw RunError("Communicator::exchange: rank " + std::to_string(rank_) + "'s receive " + std::to_string(k) +
                       " from rank " + std::to_string(x.peer) + " (" + std::to_string(x.bytes) +
                       " bytes) has no matching send of that size");
      std::memcpy(x.data, match->data, x.bytes);
    }
    team_->meet();
  }

  void barrier() override {
    const Timer t(*this);
    team_->meet();
  }

  void abort(const std::string& why) override {
    std::lock_guard<std::mutex> lock(team_->m);
    if (team_->aborted) return;
    team_->aborted = true;
    team_->why = "rank " + std::to_string(rank_) + ": " + why;
    team_->cv.notify_all();
  }

  double communication_seconds() override { return seconds_; }
  void reset_communication_seconds() override { seconds_ = 0; }

 private:
  struct Timer {
    explicit Timer(ThreadCommunicator& c) : c_(c), t0_(std::chrono::steady_clock::now()) {}
    ~Timer() { c_.seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count(); }
    ThreadCommunicator& c_;
    std::chrono::steady_clock::time_point t0_;
  };

  void check_offsets(const std::vector<std::size_t>& offsets) const {
    if (offsets.size() != std::size_t(size()) + 1)
      throw RunError("Communicator::all_gather_slices: " + std::to_string(offsets.size()) + " offsets for " +
                     std::to_string(size()) + " ranks (give ranks + 1)");
  }

  template <class T>
  void reduce(T* values, std::size_t n, ReduceOp op) {
    const Timer t(*this);
    team_->published[std::size_t(rank_)] = values;
    team_->meet();
    std::vector<T> out(static_cast<const T*>(team_->published[0]), static_cast<const T*>(team_->published[0]) + n);
    for (int r = 1; r < size(); ++r) {
      const T* v = static_cast<const T*>(team_->published[std::size_t(r)]);
      for (std::size_t i = 0; i < n; ++i) out[i] = op == ReduceOp::max ? std::max(out[i], v[i]) : out[i] + v[i];
    }
    team_->meet();  // every rank has read every input before any input is overwritten
    std::copy(out.begin(), out.end(), values);
  }

  std::shared_ptr<ThreadTeamShared> team_;
  int rank_;
  double seconds_ = 0;
};

}  // namespace

std::vector<std::unique_ptr<Communicator>> make_thread_team(int ranks) {
  if (ranks < 1) throw InputError("a team needs at least one rank (got " + std::to_string(ranks) + ")");
  auto shared = std::make_shared<ThreadTeamShared>(ranks);
  std::vector<std::unique_ptr<Communicator>> team;
  for (int r = 0; r < ranks; ++r) team.push_back(std::make_unique<ThreadCommunicator>(shared, r));
  return team;
}

#ifndef FLIPFLOW_HAVE_NCCL_HEADER
// Built without CUDA, or without nccl.h: teams of GPUs are not available.
std::vector<std::unique_ptr<Communicator>> make_nccl_team(const std::vector<int>&) {
  throw InputError("several GPUs need NCCL, and this flipflow was built without " +
                   std::string(built_without_nccl_reason()));
}
std::string nccl_description() { return std::string("built without ") + built_without_nccl_reason(); }
#endif

}  // namespace ff
