// The loops of neighbors.delaunay, one set per backend (cpu.cpp, cuda.cu). They leave their
// results in words of the backend's memory instead of returning them, so the search can read
// the gather's result on the device and the host reads them once, after the search:
//   words[0]  max over vertices of GatherRing::move_bits (the bits of an upper bound of m²),
//             with kRingOverflow set when the rows did not fit in the table
//   words[1]  max over particles of the search's result (slots held, or the overflow flags)
//   words[2]  the gather's fill counter: table slots taken so far
// The gather places each group of consecutive vertices' rows (a CUDA block, a CPU chunk) with
// one atomic add to words[2]. The stage zeroes the words before a step's loops.
// nvcc-clean.
#pragma once
#include <cstddef>
#include <cstdint>

#include "core/backend/exec.h"
#include "stages/neighbors/delaunay/search_parent.h"
#include "stages/neighbors/delaunay/search_visited.h"

namespace ff::neighbors {

template <class R>
struct DelaunayLoops {
  void (*gather)(std::size_t n, const GatherRing<R>& f, std::uint32_t* words, CUstream_st* s);
  void (*visited)(std::size_t n, const SearchVisited<R>& f, std::uint32_t* words, CUstream_st* s);
  void (*parent)(std::size_t n, const SearchParent<R>& f, std::uint32_t* words, CUstream_st* s);
};

template <class R>
DelaunayLoops<R> delaunay_loops(CpuExec);
template <class R>
DelaunayLoops<R> delaunay_loops(CudaExec);

}  // namespace ff::neighbors
