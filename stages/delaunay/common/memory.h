// Stage-private buffers on the stage's backend (host memory for CPU stages, device memory for
// CUDA stages): scratch arrays (flip decisions) and small counter blocks that a loop fills and
// the host reads to decide (rollback, another round). The backend is a table of functions
// (cpu: memory_cpu.cpp, cuda: memory_cuda.cu) picked in plugin.cpp. nvcc-clean.
#pragma once
#include <algorithm>
#include <array>
#include <cstddef>

#include "core/base/types.h"

namespace ff::delaunay {

struct MemOps {
  void* (*alloc)(std::size_t bytes);  // zeroed
  void (*release)(void* p);
  // Host memory that to_host can copy into directly (pinned on CUDA: a read from pageable
  // memory goes through a staging buffer, an extra copy on each of a step's counter reads).
  void* (*alloc_host)(std::size_t bytes);  // zeroed
  void (*release_host)(void* p);
  void (*to_host)(void* host_dst, const void* src, std::size_t bytes, CUstream_st* s);  // waits
  void (*copy)(void* dst, const void* src, std::size_t bytes, CUstream_st* s);         // same side
  // Every byte of [dst, dst + bytes) to `byte`, stream-ordered. On CUDA a memset node: unlike an
  // upload from pageable host memory it never waits for the stream.
  void (*fill)(void* dst, int byte, std::size_t bytes, CUstream_st* s);
  // to_host without the wait (host_dst from alloc_host: on CUDA a kernel writes it), and a
  // fence: recorded on a stream after some work, waited for by the host (CUDA: an event). Lets the host read counters while the stream goes on with later
  // work (detect_inversion's position_prev copy). On the CPU the copy is done at once and the
  // fence is nothing.
  void (*to_host_async)(void* host_dst, const void* src, std::size_t bytes, CUstream_st* s);
  void* (*fence_create)();
  void (*fence_destroy)(void* f);
  void (*fence_record)(void* f, CUstream_st* s);
  void (*fence_wait)(void* f);
};

MemOps cpu_mem_ops();
MemOps cuda_mem_ops();  // CUDA builds only

// A zeroed array of `count` T on the backend, reallocated when the count changes.
template <class T>
class Scratch {
 public:
  explicit Scratch(const MemOps& ops) : ops_(ops) {}
  ~Scratch() { ops_.release(p_); }
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;

  // Drop the contents: the next get() returns a fresh zeroed array.
  void reset() {
    ops_.release(p_);
    p_ = nullptr;
    count_ = 0;
  }
  T* get(std::size_t count) {
    if (count != count_) {
      ops_.release(p_);
      p_ = static_cast<T*>(ops_.alloc(count * sizeof(T)));
      count_ = count;
    }
    return p_;
  }

 private:
  MemOps ops_;
  T* p_ = nullptr;
  std::size_t count_ = 0;
};

// K unsigned counters: reset() before a group of loops, read() after them (waits on the stream),
// or start_read() after them, more work on the stream, then finish_read() (waits for the
// counters only).
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
  explicit Counters(const MemOps& ops)
      : ops_(ops),
        buf_(ops),
        landing_(static_cast<unsigned*>(ops.alloc_host(sizeof(unsigned) * K))),
        fence_(ops.fence_create()) {}
  ~Counters() {
    ops_.fence_destroy(fence_);
    ops_.release_host(landing_);
  }
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
  unsigned* landing() { return landing_; }
  void await_published(CUstream_st* s) { ops_.fence_record(fence_, s); }
  // Counts start at 0; slots listed in `min_slots` start at ~0u (they keep a minimum). One fill
  // per run of equal start values: keep the minimum slots together in the enum.
  template <std::size_t M>
  void reset(const std::array<int, M>& min_slots, CUstream_st* s) {
    bool ones[K] = {};
    for (int slot : min_slots) ones[slot] = true;
    for (int k = 0; k < K;) {
      int end = k + 1;
      while (end < K && ones[end] == ones[k]) ++end;
      ops_.fill(ptr() + k, ones[k] ? 0xFF : 0, sizeof(unsigned) * std::size_t(end - k), s);
      k = end;
    }
  }
  // Zero slots [first, first + count) only (the others keep what the loops left there).
  void zero(int first, int count, CUstream_st* s) {
    ops_.fill(ptr() + first, 0, sizeof(unsigned) * std::size_t(count), s);
  }
  const std::array<unsigned, K>& read(CUstream_st* s) {
    start_read(s);
    return finish_read();
  }
  void start_read(CUstream_st* s) {
    ops_.to_host_async(landing_, ptr(), sizeof(unsigned) * K, s);
    ops_.fence_record(fence_, s);
  }
  const std::array<unsigned, K>& finish_read() {
    ops_.fence_wait(fence_);
    std::copy(landing_, landing_ + K, host_.begin());
    return host_;
  }

 private:
  MemOps ops_;
  Scratch<unsigned> buf_;
  int bank_ = 0;
  bool next_reset_ = false;
  unsigned* landing_;  // alloc_host: where read() copies to (or a kernel writes)
  void* fence_;        // recorded after the copy into landing_
  std::array<unsigned, K> host_{};
};

}  // namespace ff::delaunay
