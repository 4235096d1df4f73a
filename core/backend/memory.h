// Stage-private memory on a stage's backend (host memory for CPU stages, device memory for CUDA
// stages), kept across steps: scratch arrays, counter blocks that a loop fills and the host
// reads to decide (a rollback, another round), host memory a kernel writes directly, and the
// result word of a reduction. Reached from the backend object a stage's constructor receives
// (CpuExec, CudaExec: `Scratch<T> s{exec}`), whose memory() is a table of functions (cpu:
// memory_cpu.cpp, cuda: cuda/memory.cu). nvcc-clean.
#pragma once
#include <algorithm>
#include <array>
#include <cstddef>

#include "core/base/types.h"

namespace ff {

struct MemoryOps {
  void* (*alloc)(std::size_t bytes);  // zeroed
  void (*release)(void* p);
  // Host memory that to_host can copy into directly and a kernel can write (pinned on CUDA: a
  // read into pageable memory goes through a staging buffer, an extra copy on each counter read).
  void* (*alloc_host)(std::size_t bytes);  // zeroed
  void (*release_host)(void* p);
  void (*to_host)(void* host_dst, const void* src, std::size_t bytes, CUstream_st* s);  // waits
  void (*copy)(void* dst, const void* src, std::size_t bytes, CUstream_st* s);         // same side
  // Every byte of [dst, dst + bytes) to `byte`, stream-ordered. On CUDA a memset node: unlike an
  // upload from pageable host memory it never waits for the stream.
  void (*fill)(void* dst, int byte, std::size_t bytes, CUstream_st* s);
  // to_host without the wait (host_dst from alloc_host: on CUDA a kernel writes it), and a
  // fence: recorded on a stream after some work, waited for by the host (CUDA: an event). Lets
  // the host read counters while the stream goes on with later work (detect_inversion's
  // position_prev copy). On the CPU the copy is done at once and the fence is nothing.
  void (*to_host_async)(void* host_dst, const void* src, std::size_t bytes, CUstream_st* s);
  void* (*fence_create)();
  void (*fence_destroy)(void* f);
  void (*fence_record)(void* f, CUstream_st* s);
  void (*fence_wait)(void* f);
};

const MemoryOps& cpu_memory();   // core/backend/memory_cpu.cpp
const MemoryOps& cuda_memory();  // core/backend/cuda/memory.cu (CUDA builds only)

// A zeroed array of `count` T on the backend, reallocated when the count changes.
template <class T>
class Scratch {
 public:
  explicit Scratch(const MemoryOps& ops) : ops_(&ops) {}
  template <class Exec>
  explicit Scratch(Exec) : Scratch(Exec::memory()) {}
  ~Scratch() { ops_->release(p_); }
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;

  // Drop the contents: the next get() returns a fresh zeroed array.
  void reset() {
    ops_->release(p_);
    p_ = nullptr;
    count_ = 0;
  }
  T* get(std::size_t count) {
    if (count != count_) {
      ops_->release(p_);
      p_ = nullptr;
      count_ = 0;
      p_ = static_cast<T*>(ops_->alloc(count * sizeof(T)));
      count_ = count;
    }
    return p_;
  }
  const MemoryOps& ops() const { return *ops_; }

 private:
  const MemoryOps* ops_;
  T* p_ = nullptr;
  std::size_t count_ = 0;
};

// A zeroed array of `count` T in host memory that the backend's kernels write directly (pinned
// on CUDA, by the same pointer: a kernel publishes its results there, no copy after it),
// reallocated when the count changes.
template <class T>
class HostScratch {
 public:
  explicit HostScratch(const MemoryOps& ops) : ops_(&ops) {}
  template <class Exec>
  explicit HostScratch(Exec) : HostScratch(Exec::memory()) {}
  ~HostScratch() { ops_->release_host(p_); }
  HostScratch(const HostScratch&) = delete;
  HostScratch& operator=(const HostScratch&) = delete;

  T* get(std::size_t count) {
    if (count != count_) {
      ops_->release_host(p_);
      p_ = nullptr;
      count_ = 0;
      p_ = static_cast<T*>(ops_->alloc_host(count * sizeof(T)));
      count_ = count;
    }
    return p_;
  }

 private:
  const MemoryOps* ops_;
  T* p_ = nullptr;
  std::size_t count_ = 0;
};

// K unsigned counters: reset() before a group of loops, read() after them (waits on the stream),
// or start_read() after them, more work on the stream, then finish_read() (the deferred read:
// waits for the counters only).
// Writes are fills (memsets), never uploads: on CUDA an upload from pageable host memory may
// wait for the stream, which between two rounds of loops stalls the host for a whole round.
// Two ways to take host calls off a step's critical path:
//  - Two banks: begin() starts a run's counting in the bank the last run's loop set to its start
//    values (next(), then next_was_reset() once that loop is launched), or fills one (no fills
//    after the first run).
//  - A kernel may write the final counts into landing() itself (pinned host memory, which a
//    CUDA kernel can write directly); await_published() then records the fence after it, and
//    finish_read() waits for that kernel and returns what it wrote (no copy on the stream).
template <int K>
class Counters {
 public:
  explicit Counters(const MemoryOps& ops) : ops_(&ops), buf_(ops), landing_(ops), fence_(ops.fence_create()) {
    landing_.get(K);
  }
  template <class Exec>
  explicit Counters(Exec) : Counters(Exec::memory()) {}
  ~Counters() { ops_->fence_destroy(fence_); }
  Counters(const Counters&) = delete;
  Counters& operator=(const Counters&) = delete;

  unsigned* ptr() { return buf_.get(2 * K) + bank_ * K; }
  unsigned* next() { return buf_.get(2 * K) + (1 - bank_) * K; }
  // Before a run's loops: the other bank if a loop of the last run reset it, else reset().
  template <std::size_t M>
  void begin(const std::array<int, M>& min_slots, CUstream_st* s) {
    if (next_reset_) {
      bank_ = 1 - bank_;
      next_reset_ = false;
    } else {
      reset(min_slots, s);
    }
  }
  // A loop that sets next() to the start values was launched in this run.
  void next_was_reset() { next_reset_ = true; }
  unsigned* landing() { return landing_.get(K); }
  void await_published(CUstream_st* s) { ops_->fence_record(fence_, s); }
  // Counts start at 0; slots listed in `min_slots` start at ~0u (they keep a minimum). One fill
  // per run of equal start values: keep the minimum slots together in the enum.
  template <std::size_t M>
  void reset(const std::array<int, M>& min_slots, CUstream_st* s) {
    bool ones[K] = {};
    for (int slot : min_slots) ones[slot] = true;
    for (int k = 0; k < K;) {
      int end = k + 1;
      while (end < K && ones[end] == ones[k]) ++end;
      ops_->fill(ptr() + k, ones[k] ? 0xFF : 0, sizeof(unsigned) * std::size_t(end - k), s);
      k = end;
    }
  }
  // Zero slots [first, first + count) only (the others keep what the loops left there).
  void zero(int first, int count, CUstream_st* s) {
    ops_->fill(ptr() + first, 0, sizeof(unsigned) * std::size_t(count), s);
  }
  // The synchronous read.
  const std::array<unsigned, K>& read(CUstream_st* s) {
    start_read(s);
    return finish_read();
  }
  void start_read(CUstream_st* s) {
    ops_->to_host_async(landing(), ptr(), sizeof(unsigned) * K, s);
    ops_->fence_record(fence_, s);
  }
  const std::array<unsigned, K>& finish_read() {
    ops_->fence_wait(fence_);
    const unsigned* l = landing();
    std::copy(l, l + K, host_.begin());
    return host_;
  }

 private:
  const MemoryOps* ops_;
  Scratch<unsigned> buf_;
  int bank_ = 0;
  bool next_reset_ = false;
  HostScratch<unsigned> landing_;  // where start_read() copies to (or a kernel writes)
  void* fence_;                    // recorded after the copy into landing_
  std::array<unsigned, K> host_{};
};

// The result of a backend reduction (CpuExec / CudaExec: max, sum, count), kept across calls:
// on CUDA one word of device memory that the reduction's kernel combines into and the host
// reads back (no allocation per call); the CPU reduces in registers and never touches it.
template <class T>
class Reduction {
 public:
  explicit Reduction(const MemoryOps& ops) : word_(ops) {}
  template <class Exec>
  explicit Reduction(Exec) : Reduction(Exec::memory()) {}

  // The word, every byte set to `byte` on the stream (the reduction's identity: 0 for max of
  // unsigned values and for sums).
  T* clear(int byte, CUstream_st* s) {
    T* w = word_.get(1);
    word_.ops().fill(w, byte, sizeof(T), s);
    return w;
  }
  // Waits for the stream and returns the word.
  T read(CUstream_st* s) {
    T h{};
    word_.ops().to_host(&h, word_.get(1), sizeof(T), s);
    return h;
  }

 private:
  Scratch<T> word_;
};

}  // namespace ff
