// CPU loops of neighbors.delaunay (loops.h): oneTBB max-reductions over the element functors of
// kernel.h; the visited search's fast slots are an array on the stack.
#include <algorithm>

#include "core/backend/exec_cpu.h"
#include "stages/neighbors/delaunay/loops.h"

namespace ff::neighbors {

namespace {

template <class R>
void cpu_gather(std::size_t n, const GatherRing<R>& f, std::uint32_t* words, CUstream_st*) {
  words[0] = std::max(words[0], cpu_max(n, f));
}

template <class R>
void cpu_visited(std::size_t n, const SearchVisited<R>& f, std::uint32_t* words, CUstream_st*) {
  const std::uint32_t m = cpu_max(n, [&f](std::size_t i) {
    std::uint32_t fast[kFastSlots];
    return f.template search<1>(i, fast);
  });
  words[1] = std::max(words[1], m);
}

template <class R>
void cpu_parent(std::size_t n, const SearchParent<R>& f, std::uint32_t* words, CUstream_st*) {
  words[1] = std::max(words[1], cpu_max(n, f));
}

}  // namespace

template <class R>
DelaunayLoops<R> delaunay_loops(CpuExec) {
  return {&cpu_gather<R>, &cpu_visited<R>, &cpu_parent<R>};
}
template DelaunayLoops<float> delaunay_loops<float>(CpuExec);
template DelaunayLoops<double> delaunay_loops<double>(CpuExec);

}  // namespace ff::neighbors
