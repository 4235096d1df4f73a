// The CUDA loops of pair.lj (cuda.cu), declared for stage.h; the CPU runs the functor of
// kernel.h through the backend object's element loop. nvcc-clean.
#pragma once
#include <cstddef>
#include <cstdint>

#include "core/backend/exec.h"
#include "core/backend/memory.h"
#include "plugins/pair/lj/kernel.h"

namespace ff::pair {

// Device buffers the CUDA loops keep between steps.
template <class R>
struct LJScratch {
  template <class Exec>
  explicit LJScratch(Exec exec)
      : packed(exec), type(exec), key(exec), key_sorted(exec), index(exec), perm(exec), rank(exec), slots(exec),
        slot_count(exec), temp(exec) {}
  Scratch<R> packed;               // N x 4: position (D components, then zeros) and diameter
  Scratch<std::int32_t> type;      // N: types in the loop's order
  Scratch<std::uint32_t> key;      // N: space-filling-curve keys
  Scratch<std::uint32_t> key_sorted;
  Scratch<std::uint32_t> index;    // 0 .. N-1
  Scratch<std::uint32_t> perm;     // N: the particle each thread takes
  Scratch<std::uint32_t> rank;     // N: perm's inverse
  Scratch<std::uint32_t> slots;    // capacity x N: the list in the loop's order, column-major
  Scratch<std::uint32_t> slot_count;
  Scratch<std::uint8_t> temp;      // the sort's own
  std::uint64_t seen[3] = {~0ull, ~0ull, ~0ull};  // the list's stamp the order was made for
  std::size_t seen_n = 0;
};

// What identifies one build of the list: the versions of neighbors.list and neighbors.count, and
// the row capacity.
struct ListStamp {
  std::uint64_t list, count, capacity;
};

template <class R>
struct LJLoops {
  void (*d2)(std::size_t n, const LJForce<R, 2>& f, LJScratch<R>& scratch, const ListStamp& stamp, CUstream_st* stream) = nullptr;
  void (*d3)(std::size_t n, const LJForce<R, 3>& f, LJScratch<R>& scratch, const ListStamp& stamp, CUstream_st* stream) = nullptr;
};

template <class R>
LJLoops<R> lj_loops(CudaExec);

}  // namespace ff::pair
