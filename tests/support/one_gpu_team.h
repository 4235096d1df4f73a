// A CUDA team whose ranks all run on one GPU (tests only): NCCL refuses two ranks on a GPU, so
// these ranks move the data of their collectives and exchanges through host memory and a CPU
// thread team (core/backend/comm_threads.cpp). Everything else is the CUDA team path of several
// GPUs: each rank's Simulation on the device, its stages' kernels, the decomposed team's device
// packing and migration test (core/run/cuda/ghost_traffic.h), the coherence of each field's host
// and device copies across an exchange. So a bug of that path shows on a machine with one GPU.
// What it does not cover: NCCL itself and the ordering of its kernels on the ranks' streams (here
// every exchange waits for its stream and returns with the data in place).
#pragma once
#ifdef FLIPFLOW_HAVE_CUDA
#include <cuda_runtime.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/backend/comm.h"
#include "core/base/error.h"
#include "core/run/team.h"

namespace ff::test {

class OneGpuRank final : public Communicator {
 public:
  explicit OneGpuRank(std::unique_ptr<Communicator> threads) : threads_(std::move(threads)) {}
  int rank() const override { return threads_->rank(); }
  int size() const override { return threads_->size(); }

  void all_gather_slices(void* data, const std::vector<std::size_t>& offsets, CUstream_st* stream) override {
    wait(stream);
    std::vector<unsigned char> host(offsets.back());
    copy(host.data(), data, host.size(), cudaMemcpyDeviceToHost);
    threads_->all_gather_slices(host.data(), offsets, nullptr);
    copy(data, host.data(), host.size(), cudaMemcpyHostToDevice);
  }
  void all_reduce(double* values, std::size_t n, ReduceOp op) override { threads_->all_reduce(values, n, op); }
  void all_reduce(std::int64_t* values, std::size_t n, ReduceOp op) override { threads_->all_reduce(values, n, op); }
  void exchange(const std::vector<Transfer>& transfers, CUstream_st* stream) override {
    wait(stream);
    std::vector<std::vector<unsigned char>> host(transfers.size());
    std::vector<Transfer> on_host = transfers;
    for (std::size_t k = 0; k < transfers.size(); ++k) {
      host[k].resize(transfers[k].bytes);
      on_host[k].data = host[k].data();
      if (transfers[k].send) copy(host[k].data(), transfers[k].data, transfers[k].bytes, cudaMemcpyDeviceToHost);
    }
    threads_->exchange(on_host, nullptr);
    for (std::size_t k = 0; k < transfers.size(); ++k)
      if (!transfers[k].send) copy(transfers[k].data, host[k].data(), transfers[k].bytes, cudaMemcpyHostToDevice);
  }
  void barrier() override { threads_->barrier(); }
  void abort(const std::string& why) override { threads_->abort(why); }
  double communication_seconds() override { return threads_->communication_seconds(); }
  void reset_communication_seconds() override { threads_->reset_communication_seconds(); }

 private:
  static void check(cudaError_t e, const char* what) {
    if (e != cudaSuccess) throw RunError(std::string("one-GPU team: ") + what + ": " + cudaGetErrorString(e));
  }
  static void wait(CUstream_st* stream) {
    check(stream ? cudaStreamSynchronize(stream) : cudaDeviceSynchronize(), "waiting for the rank's stream");
  }
  // Synchronous, and landed when it returns (a copy from pageable memory may return once staged;
  // the rank's streams are non-blocking and do not order with this one).
  static void copy(void* dst, const void* src, std::size_t bytes, cudaMemcpyKind kind) {
    if (!bytes) return;
    check(cudaMemcpy(dst, src, bytes, kind), "copying an exchange's data");
    check(cudaDeviceSynchronize(), "copying an exchange's data");
  }

  std::unique_ptr<Communicator> threads_;
};

// `ranks` ranks on CUDA device 0, through the host (above).
inline Team one_gpu_team(int ranks) {
  Team t;
  t.backend = Backend::cuda;
  for (auto& c : make_thread_team(ranks)) {
    t.devices.push_back(0);
    t.ranks.push_back(std::make_unique<OneGpuRank>(std::move(c)));
  }
  return t;
}

// body(comm) on every rank of one_gpu_team(ranks).
inline void on_one_gpu(int ranks, const std::function<void(Communicator*)>& body) {
  Team team = one_gpu_team(ranks);
  run_team(team, [&](Communicator& comm) { body(&comm); });
}

}  // namespace ff::test
#endif

#include <functional>

#include "support/team.h"

namespace ff::test {

// The team a test case asks for: `ranks` ranks of `backend` (on_ranks), or with `one_gpu` (CUDA
// builds) that many CUDA ranks sharing one GPU (on_one_gpu).
inline void on_team(Backend backend, int ranks, bool one_gpu, const std::function<void(Communicator*)>& body) {
#ifdef FLIPFLOW_HAVE_CUDA
  if (one_gpu && ranks > 1) {
    on_one_gpu(ranks, body);
    return;
  }
#else
  (void)one_gpu;
#endif
  on_ranks(backend, ranks, body);
}

}  // namespace ff::test
