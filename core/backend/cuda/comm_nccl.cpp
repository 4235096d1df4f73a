// The CUDA backend's Communicator: NCCL, one communicator per GPU of one process
// (ncclCommInitAll), each used by the thread of its rank.
//
// NCCL is opened at run time (dlopen), not linked: a CPU or one-GPU run never needs it, the
// bundle (tools/bundle) does not carry its ~200 MB, and the GPU machine's own libnccl.so.2 is
// used. Search order: $FLIPFLOW_NCCL_LIBRARY (a file), "libnccl.so.2" through the loader's
// search path (LD_LIBRARY_PATH, the ld.so cache), then the folder where CMake found it at build
// time (FLIPFLOW_NCCL_HINT, e.g. /usr/local/cuda/lib64), then $CUDA_HOME/lib64 and
// /usr/local/cuda/lib64. Only nccl.h's types and declarations are used at compile time.
//
// NVLink multicast (NVLS) is switched off (NCCL_NVLS_ENABLE=0) before the communicators are
// made: on shared hosts it can take GPUs out of service (issue 21).
#ifdef FLIPFLOW_HAVE_NCCL_HEADER
#include <cuda_runtime.h>
#include <dlfcn.h>
#include <nccl.h>
#endif

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <mutex>
#include <thread>
#include <type_traits>

#include "core/backend/comm.h"
#include "core/backend/cuda/check.h"
#include "core/backend/host_wait.h"
#include "core/base/error.h"

#ifdef FLIPFLOW_HAVE_NCCL_HEADER
#ifndef FLIPFLOW_NCCL_HINT
#define FLIPFLOW_NCCL_HINT ""
#endif

namespace ff {

namespace {

// The NCCL entry points flipflow calls, from the library dlopen found.
struct NcclApi {
  void* handle = nullptr;
  std::string path;
  decltype(&ncclGetVersion) get_version = nullptr;
  decltype(&ncclGetErrorString) error_string = nullptr;
  decltype(&ncclCommInitAll) init_all = nullptr;
  decltype(&ncclCommDestroy) destroy = nullptr;
  decltype(&ncclCommAbort) abort = nullptr;
  decltype(&ncclCommGetAsyncError) async_error = nullptr;
  decltype(&ncclAllGather) all_gather = nullptr;
  decltype(&ncclBroadcast) broadcast = nullptr;
  decltype(&ncclAllReduce) all_reduce = nullptr;
  decltype(&ncclSend) send = nullptr;
  decltype(&ncclRecv) recv = nullptr;
  decltype(&ncclGroupStart) group_start = nullptr;
  decltype(&ncclGroupEnd) group_end = nullptr;
};

const NcclApi& nccl() {
  static const NcclApi api = [] {
    NcclApi a;
    std::vector<std::string> tried;
    std::vector<std::string> candidates;
    if (const char* p = std::getenv("FLIPFLOW_NCCL_LIBRARY")) candidates.push_back(p);
    candidates.push_back("libnccl.so.2");
    if (*FLIPFLOW_NCCL_HINT) candidates.push_back(std::string(FLIPFLOW_NCCL_HINT) + "/libnccl.so.2");
    if (const char* p = std::getenv("CUDA_HOME")) candidates.push_back(std::string(p) + "/lib64/libnccl.so.2");
    candidates.push_back("/usr/local/cuda/lib64/libnccl.so.2");
    for (auto& c : candidates) {
      a.handle = dlopen(c.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (a.handle) {
        a.path = c;
        break;
      }
      tried.push_back(c);
    }
    if (!a.handle) {
      std::string list;
      for (auto& t : tried) list += " " + t;
      throw InputError("several GPUs need NCCL, and libnccl.so.2 was not found (tried:" + list +
                       "); install NCCL, or point FLIPFLOW_NCCL_LIBRARY at libnccl.so.2");
    }
    auto sym = [&](auto& fn, const char* name) {
      fn = reinterpret_cast<std::remove_reference_t<decltype(fn)>>(dlsym(a.handle, name));
      if (!fn) throw InputError("NCCL library " + a.path + " has no " + name + " (too old? flipflow needs NCCL >= 2.7)");
    };
    sym(a.get_version, "ncclGetVersion");
    sym(a.error_string, "ncclGetErrorString");
    sym(a.init_all, "ncclCommInitAll");
    sym(a.destroy, "ncclCommDestroy");
    sym(a.abort, "ncclCommAbort");
    sym(a.async_error, "ncclCommGetAsyncError");
    sym(a.all_gather, "ncclAllGather");
    sym(a.broadcast, "ncclBroadcast");
    sym(a.all_reduce, "ncclAllReduce");
    sym(a.send, "ncclSend");
    sym(a.recv, "ncclRecv");
    sym(a.group_start, "ncclGroupStart");
    sym(a.group_end, "ncclGroupEnd");
    return a;
  }();
  return api;
}

void check(ncclResult_t r, const std::string& what) {
  if (r != ncclSuccess && r != ncclInProgress)
    throw RunError("NCCL: " + what + ": " + nccl().error_string(r));
}

// Switches the current device for the life of the object (constructors and destructors run on
// the thread that made the team, not the rank's).
struct OnDevice {
  explicit OnDevice(int device) {
    cudaGetDevice(&previous);
    FF_CUDA_CHECK(cudaSetDevice(device), "NCCL team: selecting a device");
  }
  ~OnDevice() { cudaSetDevice(previous); }
  int previous = 0;
};

// An abort must end waits on kernels that wait for a rank that will never come (ncclCommAbort),
// but must not free a communicator while its rank's thread is inside an NCCL call on it. So each
// rank marks its calls (in_call, under m); abort() aborts the communicators of ranks outside a
// call, and a rank inside one aborts its own when the call returns. No lock is held during a
// call: an NCCL call may wait for its peers.
struct NcclTeamShared {
  std::vector<ncclComm_t> comms;
  std::vector<int> devices;
  std::vector<bool> gone;     // aborted or destroyed
  std::vector<bool> in_call;  // the rank's thread is inside an NCCL call
  std::mutex m;
  bool aborted = false;
  std::string why;

  ~NcclTeamShared() {
    for (std::size_t r = 0; r < comms.size(); ++r)
      if (!gone[r]) nccl().destroy(comms[r]);
  }
};

class NcclCommunicator final : public Communicator {
 public:
  NcclCommunicator(std::shared_ptr<NcclTeamShared> team, int rank)
      : team_(std::move(team)), rank_(rank), device_(team_->devices[std::size_t(rank)]),
        comm_(team_->comms[std::size_t(rank)]) {
    OnDevice on(device_);
    FF_CUDA_CHECK(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking), "NCCL team: a stream");
    FF_CUDA_CHECK(cudaMalloc(&scratch_, kScratchBytes), "NCCL team: reduction scratch");
    FF_CUDA_CHECK(cudaMallocHost(&host_scratch_, kScratchBytes), "NCCL team: pinned reduction scratch");
  }
  ~NcclCommunicator() override {
    OnDevice on(device_);
    cudaStreamSynchronize(stream_);
    for (auto& p : pending_) {
      cudaEventDestroy(p.first);
      cudaEventDestroy(p.second);
    }
    for (auto& p : spare_) {
      cudaEventDestroy(p.first);
      cudaEventDestroy(p.second);
    }
    cudaFreeHost(host_scratch_);
    cudaFree(scratch_);
    cudaStreamDestroy(stream_);
  }

  int rank() const override { return rank_; }
  int size() const override { return int(team_->comms.size()); }

  void all_gather_slices(void* data, const std::vector<std::size_t>& offsets, CUstream_st* stream) override {
    if (offsets.size() != std::size_t(size()) + 1)
      throw RunError("Communicator::all_gather_slices: " + std::to_string(offsets.size()) + " offsets for " +
                     std::to_string(size()) + " ranks (give ranks + 1)");
    auto* bytes = static_cast<unsigned char*>(data);
    const std::size_t first = offsets[1] - offsets[0];
    bool equal = offsets[0] == 0;
    for (int r = 0; r < size(); ++r) equal = equal && offsets[std::size_t(r) + 1] - offsets[std::size_t(r)] == first;
    const auto ev = begin_timed(stream);
    guarded([&] {
      if (equal) {
        // Equal slices: one all-gather, in place (the send buffer is this rank's slice).
        check(nccl().all_gather(bytes + offsets[std::size_t(rank_)], bytes, first, ncclUint8, comm_, stream),
              "all-gather");
      } else {
        // Unequal slices (N not a multiple of the ranks): one broadcast per owner, grouped.
        check(nccl().group_start(), "group start");
        for (int r = 0; r < size(); ++r) {
          unsigned char* slice = bytes + offsets[std::size_t(r)];
          check(nccl().broadcast(slice, slice, offsets[std::size_t(r) + 1] - offsets[std::size_t(r)], ncclUint8, r,
                                 comm_, stream),
                "broadcast");
        }
        check(nccl().group_end(), "group end");
      }
    });
    end_timed(ev, stream);
  }

  void all_reduce(double* values, std::size_t n, ReduceOp op) override { reduce(values, n, op, ncclFloat64); }
  void all_reduce(std::int64_t* values, std::size_t n, ReduceOp op) override { reduce(values, n, op, ncclInt64); }

  void exchange(const std::vector<Transfer>& transfers, CUstream_st* stream) override {
    const auto ev = begin_timed(stream);
    guarded([&] {
      check(nccl().group_start(), "group start");
      for (const Transfer& x : transfers) {
        if (x.send) check(nccl().send(x.data, x.bytes, ncclUint8, x.peer, comm_, stream), "send");
        else check(nccl().recv(x.data, x.bytes, ncclUint8, x.peer, comm_, stream), "receive");
      }
      check(nccl().group_end(), "group end");
    });
    end_timed(ev, stream);
  }

  void barrier() override {
    std::int64_t zero = 0;
    all_reduce(&zero, 1, ReduceOp::sum);
  }

  void abort(const std::string& why) override {
    // Aborting every communicator makes NCCL kernels that wait for a rank that will never come
    // return, so the other ranks' threads stop waiting on their streams and fail too.
    std::lock_guard<std::mutex> lock(team_->m);
    if (team_->aborted) return;
    team_->aborted = true;
    team_->why = "rank " + std::to_string(rank_) + ": " + why;
    for (std::size_t r = 0; r < team_->comms.size(); ++r)
      if (!team_->in_call[r] && !team_->gone[r]) {
        nccl().abort(team_->comms[r]);
        team_->gone[r] = true;
      }
  }

  // One all-reduce and one all-gather of a few bytes, enqueued on this rank's own stream: called
  // for every rank inside one NCCL group from the thread that made the team (make_nccl_team),
  // then waited for with wait_idle().
  void enqueue_warm_up() {
    OnDevice on(device_);
    FF_CUDA_CHECK(cudaMemsetAsync(scratch_, 0, kScratchBytes, stream_), "NCCL team: clearing scratch");
    check(nccl().all_reduce(scratch_, scratch_, 1, ncclFloat64, ncclSum, comm_, stream_), "warm-up all-reduce");
    auto* bytes = static_cast<unsigned char*>(scratch_);
    check(nccl().all_gather(bytes + 4 * rank_, bytes, 4, ncclUint8, comm_, stream_), "warm-up all-gather");
  }
  void wait_idle() {
    OnDevice on(device_);
    FF_CUDA_CHECK(cudaStreamSynchronize(stream_), "NCCL team: warming up the communicators");
  }

  double communication_seconds() override {
    drain(true);
    return seconds_;
  }
  void reset_communication_seconds() override {
    drain(true);
    seconds_ = 0;
  }

 private:
  static constexpr std::size_t kScratchBytes = 64 * sizeof(double);
  using EventPair = std::pair<cudaEvent_t, cudaEvent_t>;

  // An NCCL call on comm_ (NcclTeamShared says why it is marked).
  template <class F>
  void guarded(F&& call) {
    {
      std::lock_guard<std::mutex> lock(team_->m);
      if (team_->aborted) throw RunError("team aborted: " + team_->why);
      team_->in_call[std::size_t(rank_)] = true;
    }
    auto leave = [&] {
      std::lock_guard<std::mutex> lock(team_->m);
      team_->in_call[std::size_t(rank_)] = false;
      if (team_->aborted && !team_->gone[std::size_t(rank_)]) {
        nccl().abort(comm_);
        team_->gone[std::size_t(rank_)] = true;
      }
    };
    try {
      call();
    } catch (...) {
      leave();
      throw;
    }
    leave();
  }

  EventPair begin_timed(CUstream_st* stream) {
    drain(false);
    EventPair p{};
    if (!spare_.empty()) {
      p = spare_.back();
      spare_.pop_back();
    } else {
      FF_CUDA_CHECK(cudaEventCreate(&p.first), "NCCL team: an event");
      FF_CUDA_CHECK(cudaEventCreate(&p.second), "NCCL team: an event");
    }
    FF_CUDA_CHECK(cudaEventRecord(p.first, stream), "NCCL team: recording an event");
    return p;
  }
  void end_timed(EventPair p, CUstream_st* stream) {
    FF_CUDA_CHECK(cudaEventRecord(p.second, stream), "NCCL team: recording an event");
    pending_.push_back(p);
  }
  // Adds the device time of finished operations (all of them when `wait`).
  void drain(bool wait) {
    while (!pending_.empty()) {
      EventPair p = pending_.front();
      if (wait) {
        const HostWait waiting;
        FF_CUDA_CHECK(cudaEventSynchronize(p.second), "NCCL team: waiting for an operation");
      } else if (cudaEventQuery(p.second) != cudaSuccess) {
        cudaGetLastError();  // cudaErrorNotReady is not an error
        break;
      }
      float ms = 0;
      FF_CUDA_CHECK(cudaEventElapsedTime(&ms, p.first, p.second), "NCCL team: timing an operation");
      seconds_ += 1e-3 * double(ms);
      pending_.pop_front();
      spare_.push_back(p);
    }
  }

  // Waits for stream_ without blocking in the driver, so that a team abort or an NCCL error
  // (a rank that failed) ends the wait.
  void wait_for_stream() {
    for (;;) {
      const cudaError_t e = cudaStreamQuery(stream_);
      if (e == cudaSuccess) return;
      if (e != cudaErrorNotReady) FF_CUDA_CHECK(e, "NCCL team: waiting for a reduction");
      ncclResult_t async = ncclSuccess;
      guarded([&] { check(nccl().async_error(comm_, &async), "asking for errors"); });
      check(async, "a reduction failed");
      std::this_thread::yield();
    }
  }

  template <class T>
  void reduce(T* values, std::size_t n, ReduceOp op, ncclDataType_t type) {
    if (n * sizeof(T) > kScratchBytes)
      throw RunError("Communicator::all_reduce: " + std::to_string(n) + " values, at most " +
                     std::to_string(kScratchBytes / sizeof(T)) + " at once");
    const auto t0 = std::chrono::steady_clock::now();
    std::memcpy(host_scratch_, values, n * sizeof(T));
    FF_CUDA_CHECK(cudaMemcpyAsync(scratch_, host_scratch_, n * sizeof(T), cudaMemcpyHostToDevice, stream_),
                  "NCCL team: reduction input");
    guarded([&] {
      check(nccl().all_reduce(scratch_, scratch_, n, type, op == ReduceOp::max ? ncclMax : ncclSum, comm_, stream_),
            "all-reduce");
    });
    FF_CUDA_CHECK(cudaMemcpyAsync(host_scratch_, scratch_, n * sizeof(T), cudaMemcpyDeviceToHost, stream_),
                  "NCCL team: reduction output");
    wait_for_stream();
    {
      // An abort ends NCCL's kernels early: what they left is not a reduction.
      std::lock_guard<std::mutex> lock(team_->m);
      if (team_->aborted) throw RunError("team aborted: " + team_->why);
    }
    std::memcpy(values, host_scratch_, n * sizeof(T));
    seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }

  std::shared_ptr<NcclTeamShared> team_;
  int rank_;
  int device_;
  ncclComm_t comm_;
  cudaStream_t stream_ = nullptr;
  void* scratch_ = nullptr;
  void* host_scratch_ = nullptr;
  std::deque<EventPair> pending_;
  std::vector<EventPair> spare_;
  double seconds_ = 0;
};

}  // namespace

std::vector<std::unique_ptr<Communicator>> make_nccl_team(const std::vector<int>& devices) {
  if (devices.empty()) throw InputError("an NCCL team needs at least one device");
  const NcclApi& api = nccl();
  // Never NVLink multicast (issue 21: on shared hosts it can take GPUs out of service).
  setenv("NCCL_NVLS_ENABLE", "0", 1);
  // Connect the collectives' channels in ncclCommInitAll rather than in each rank's first
  // collective (NCCL >= 2.22 connects lazily by default), where a first collective would wait
  // inside the NCCL call for a rank that failed before it came.
  setenv("NCCL_RUNTIME_CONNECT", "0", 0);
  auto shared = std::make_shared<NcclTeamShared>();
  shared->devices = devices;
  shared->comms.resize(devices.size());
  shared->gone.assign(devices.size(), false);
  shared->in_call.assign(devices.size(), false);
  const ncclResult_t r = api.init_all(shared->comms.data(), int(devices.size()), devices.data());
  if (r != ncclSuccess) {
    shared->comms.clear();
    std::string list;
    for (int d : devices) list += (list.empty() ? "" : ",") + std::to_string(d);
    throw InputError("NCCL (" + api.path + ") could not make a team of CUDA devices " + list + ": " +
                     api.error_string(r) +
                     (r == ncclInvalidUsage ? " (NCCL puts at most one rank on a GPU; use --gpus up to the number of "
                                              "GPUs, or CUDA_VISIBLE_DEVICES)"
                                            : ""));
  }
  std::vector<std::unique_ptr<Communicator>> team;
  for (std::size_t k = 0; k < devices.size(); ++k)
    team.push_back(std::make_unique<NcclCommunicator>(shared, int(k)));
  if (4 * devices.size() > 64 * sizeof(double))
    throw InputError("an NCCL team of more than 128 GPUs is not supported");
  // Every rank's first collectives, from this thread, in one group (NCCL's pattern for one thread
  // driving several GPUs): a team that cannot talk fails here, before any rank's thread starts.
  check(api.group_start(), "group start");
  for (auto& c : team) static_cast<NcclCommunicator&>(*c).enqueue_warm_up();
  check(api.group_end(), "group end");
  for (auto& c : team) static_cast<NcclCommunicator&>(*c).wait_idle();
  return team;
}

// "NCCL 2.28.9 (/usr/local/cuda/lib64/libnccl.so.2)", or why it cannot be used.
std::string nccl_description() {
  try {
    const NcclApi& api = nccl();
    int v = 0;
    api.get_version(&v);
    return "NCCL " + std::to_string(v / 10000) + "." + std::to_string(v / 100 % 100) + "." + std::to_string(v % 100) +
           " (" + api.path + ")";
  } catch (const std::exception& e) {
    return e.what();
  }
}

}  // namespace ff
#endif  // FLIPFLOW_HAVE_NCCL_HEADER
