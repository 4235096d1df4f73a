#include "core/run/cuda/streams.h"

#include <string>

#include "core/backend/cuda/check.h"
#include "core/backend/host_wait.h"

namespace ff {

StreamSet::StreamSet(const StepGraph& graph, bool device_flags) : graph_(graph), device_flags_(device_flags) {
  const auto& nodes = graph.nodes();
  stream_of_.assign(nodes.size(), 0);
  std::vector<bool> stream_taken_by_successor(nodes.size(), false);
  int n_streams = 1;
  bool first = true;
  for (int i : graph.compute_nodes()) {
    const auto& preds = nodes[i].preds;
    if (first) {
      stream_of_[i] = 0;
      first = false;
    } else if (!preds.empty() && !stream_taken_by_successor[preds.front()]) {
      stream_of_[i] = stream_of_[preds.front()];
      stream_taken_by_successor[preds.front()] = true;
    } else {
      stream_of_[i] = n_streams++;
    }
  }
  for (int i : graph.observer_nodes()) stream_of_[i] = 0;  // observers run after the join
  streams_.resize(n_streams);
  for (auto& s : streams_) FF_CUDA_CHECK(cudaStreamCreateWithFlags(&s, cudaStreamNonBlocking), "creating a stream");
  events_.resize(nodes.size());
  for (auto& e : events_) FF_CUDA_CHECK(cudaEventCreateWithFlags(&e, cudaEventDisableTiming), "creating an event");
  FF_CUDA_CHECK(cudaEventCreateWithFlags(&start_, cudaEventDisableTiming), "creating an event");
  const std::size_t bytes = sizeof(DeviceRollbackFlag) * (nodes.size() ? nodes.size() : 1);
  FF_CUDA_CHECK(cudaMalloc(&flags_, bytes), "allocating rollback flags");
  FF_CUDA_CHECK(cudaMallocHost(&host_flags_, bytes), "allocating pinned rollback flags");
  FF_CUDA_CHECK(cudaMemsetAsync(flags_, 0, bytes, main()), "zeroing rollback flags");
  FF_CUDA_CHECK(cudaMalloc(&gate_, sizeof(unsigned)), "allocating the gate");
  FF_CUDA_CHECK(cudaMemsetAsync(gate_, 0, sizeof(unsigned), main()), "zeroing the gate");
}

StreamSet::~StreamSet() {
  for (auto s : streams_) cudaStreamSynchronize(s);
  for (auto e : events_) cudaEventDestroy(e);
  if (start_) cudaEventDestroy(start_);
  for (auto s : streams_) cudaStreamDestroy(s);
  cudaFree(flags_);
  cudaFree(gate_);
  cudaFreeHost(host_flags_);
}

void StreamSet::begin_attempt() {
  // Flags only matter when some stage can raise one; otherwise skip the per-step memset (on a
  // step of tiny kernels it is one launch in eight).
  if (device_flags_)
    FF_CUDA_CHECK(cudaMemsetAsync(flags_, 0, sizeof(DeviceRollbackFlag) * graph_.nodes().size(), main()),
                  "zeroing rollback flags");
  if (streams_.size() > 1) FF_CUDA_CHECK(cudaEventRecord(start_, main()), "recording the step start");
}

void StreamSet::before(int node) {
  cudaStream_t mine = stream(node);
  const auto& preds = graph_.nodes()[node].preds;
  if (preds.empty() && mine != main())
    FF_CUDA_CHECK(cudaStreamWaitEvent(mine, start_, 0), "joining the step start");
  for (int p : preds)
    if (stream_of_[p] != stream_of_[node])
      FF_CUDA_CHECK(cudaStreamWaitEvent(mine, events_[p], 0), "joining a predecessor stage");
}

void StreamSet::after(int node) {
  if (streams_.size() > 1) FF_CUDA_CHECK(cudaEventRecord(events_[node], stream(node)), "recording a stage event");
}

void StreamSet::join_all() {
  if (streams_.size() == 1) return;
  for (int i : graph_.compute_nodes())
    if (stream_of_[i] != 0) FF_CUDA_CHECK(cudaStreamWaitEvent(main(), events_[i], 0), "joining the step");
}

std::optional<RollbackRequest> StreamSet::read_rollback_flags(const StepGraph& graph,
                                                              const std::vector<StageSlot>& slots) {
  if (!device_flags_) return std::nullopt;
  const std::size_t bytes = sizeof(DeviceRollbackFlag) * graph.nodes().size();
  FF_CUDA_CHECK(cudaMemcpyAsync(host_flags_, flags_, bytes, cudaMemcpyDeviceToHost, main()), "reading rollback flags");
  {
    const HostWait waiting;
    FF_CUDA_CHECK(cudaStreamSynchronize(main()), "waiting for the step's rollback decision");
  }
  for (int i : graph.compute_nodes()) {
    if (!slots[i].ran || host_flags_[i].requested == 0) continue;
    Outcome o = Outcome::request_rollback(
        "requested on the device (code " + std::to_string(host_flags_[i].requested) + ")",
        {std::uint64_t(host_flags_[i].particle)});
    return RollbackRequest{i, o};
  }
  return std::nullopt;
}

void StreamSet::synchronize() {
  const HostWait waiting;
  for (auto s : streams_) FF_CUDA_CHECK(cudaStreamSynchronize(s), "waiting for the step");
}

}  // namespace ff
