// A team of ranks that run one simulation together (issue 21; `pipeline run --gpus N`): one
// process, one thread per rank, each rank with its own Simulation on its own device. The
// Communicator is what a rank uses to talk to the others; two implementations:
//   - CPU backend: a thread team in shared memory (core/backend/comm_threads.cpp), so the logic
//     that splits work among ranks runs in CI without GPUs or NCCL;
//   - CUDA backend: NCCL (core/backend/cuda/comm_nccl.cpp), one communicator per GPU, made by
//     ncclCommInitAll in the process that starts the threads.
// Buffers are on the rank's side of the backend: host memory on the CPU, device memory of the
// rank's GPU on CUDA. Data operations are ordered on `stream` (CUDA: enqueued, the host does not
// wait; CPU: done when the call returns). The reductions of host values wait for every rank.
// nvcc-clean (the standard library only): CUDA stages include it.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

struct CUstream_st;

namespace ff {

enum class ReduceOp { max, sum };

// The share of `n` items (targets, particles) that rank `rank` of `ranks` takes: [first, last).
// Contiguous and balanced to one item; the same on every backend, so a split is reproducible.
inline std::pair<std::size_t, std::size_t> share_of(std::size_t n, int rank, int ranks) {
  return {n * std::size_t(rank) / std::size_t(ranks), n * std::size_t(rank + 1) / std::size_t(ranks)};
}

class Communicator {
 public:
  virtual ~Communicator() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;

  // In place: on entry each rank holds its own slice, bytes [offsets[rank], offsets[rank + 1])
  // of `data` (offsets has size() + 1 entries, the same on every rank); on return (CPU) or once
  // `stream` reaches this point (CUDA), every rank holds every slice.
  virtual void all_gather_slices(void* data, const std::vector<std::size_t>& offsets, CUstream_st* stream) = 0;

  // Host values, element-wise over the ranks; every rank gets the same result. Waits for all.
  // The sum of doubles is formed in rank order on the CPU (NCCL's order is its own).
  virtual void all_reduce(double* values, std::size_t n, ReduceOp op) = 0;
  virtual void all_reduce(std::int64_t* values, std::size_t n, ReduceOp op) = 0;

  // Point to point: a batch of sends and receives that completes together, so the order in
  // which ranks list them cannot deadlock. The k-th send from a to b matches the k-th receive
  // of b from a; their sizes must agree.
  struct Transfer {
    int peer;
    void* data;
    std::size_t bytes;
    bool send;  // false: receive into data
  };
  virtual void exchange(const std::vector<Transfer>& transfers, CUstream_st* stream) = 0;

  // Waits until every rank got here (host).
  virtual void barrier() = 0;

  // A rank that failed calls this (the team runner does, core/run/team.h): every rank waiting in,
  // or later entering, a collective throws RunError instead of waiting for it forever.
  virtual void abort(const std::string& why) = 0;

  // Seconds this rank spent in communication since the last reset: host time in the calls on
  // the CPU (waiting for the other ranks included), device time between events around each
  // operation on CUDA (which includes waiting for the slowest rank to arrive). For `pipeline
  // bench`'s communication share; synchronizes with the rank's streams on CUDA.
  virtual double communication_seconds() = 0;
  virtual void reset_communication_seconds() = 0;
};

// Whether `comm` splits work: a team of more than one rank.
inline bool in_team(const Communicator* comm) { return comm && comm->size() > 1; }

// A thread team of `ranks` in shared memory (CPU backend): element r is rank r's communicator,
// to be used by one thread.
std::vector<std::unique_ptr<Communicator>> make_thread_team(int ranks);

// An NCCL team, rank r on CUDA device devices[r] (ncclCommInitAll). NCCL is opened at run time
// (dlopen of libnccl.so.2: FLIPFLOW_NCCL_LIBRARY, then the loader's search path, then the CUDA
// library folder found at build time), so flipflow links no NCCL and runs without it on one
// device. InputError when this build has no CUDA, NCCL is not found, or NCCL refuses the
// devices (it does not put two ranks on one GPU). NVLink multicast (NVLS) is switched off.
std::vector<std::unique_ptr<Communicator>> make_nccl_team(const std::vector<int>& devices);
// "NCCL 2.28.9 (libnccl.so.2)", or why NCCL cannot be used (for logs and skipped tests).
std::string nccl_description();

}  // namespace ff
