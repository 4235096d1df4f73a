// What the backend test measures on each backend: the same loops, reductions and memory calls,
// instantiated once for CpuExec (test_backend.cpp) and once for CudaExec (backend_cuda.cu).
// nvcc-clean.
#pragma once
#include <cstddef>
#include <cstdint>

#include "core/backend/atomics.h"
#include "core/backend/memory.h"
#include "core/base/hd.h"

namespace ff::test {

// A scrambled value per index: max, sum and count are checked against a serial host loop.
struct Scrambled {
  FF_HD std::uint32_t operator()(std::size_t i) const { return std::uint32_t((i * 2654435761ull) % 1000003ull); }
};
struct Square {
  FF_HD std::uint64_t operator()(std::size_t i) const { return std::uint64_t(i) * std::uint64_t(i); }
};
struct MultipleOf7 {
  FF_HD bool operator()(std::size_t i) const { return i % 7 == 0; }
};
// Writes i + offset into out[i] (an element loop over scratch memory).
struct Fill {
  unsigned* out;
  unsigned offset;
  FF_HD void operator()(std::size_t i) const { out[i] = unsigned(i) + offset; }
};
// Counts into counter slot 0 the elements whose value is odd (the counters' atomics).
struct CountOdd {
  const unsigned* in;
  unsigned* counters;
  FF_HD void operator()(std::size_t i) const {
    if (in[i] & 1u) count_one(counters);
  }
};

struct BackendResults {
  std::uint32_t max = 0;
  std::uint64_t sum = 0, count = 0;
  std::uint32_t max_again = 0;   // the same Reduction reused: no stale word
  unsigned odd_sync = 0;         // Counters::read
  unsigned odd_deferred = 0;     // Counters::start_read, more work, finish_read
  unsigned first_scratch = 0;    // a fresh Scratch reads zero
  unsigned kept = 0;             // Scratch keeps its contents across get() of the same count
};

BackendResults cpu_backend_results(std::size_t n);
BackendResults cuda_backend_results(std::size_t n);  // CUDA builds only

}  // namespace ff::test
