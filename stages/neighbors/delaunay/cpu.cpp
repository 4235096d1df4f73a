// CPU loops of neighbors.delaunay (loops.h): oneTBB max-reductions over the element functors of
// kernel.h; the gather places each chunk's rows with one atomic add; the visited search's fast
// slots are an array on the stack.
#include <algorithm>
#include <atomic>
#include <vector>

#include "core/backend/exec_cpu.h"
#include "stages/neighbors/delaunay/loops.h"

namespace ff::neighbors {

namespace {

template <class R>
void cpu_gather(std::size_t n, const GatherRing<R>& f, std::uint32_t* words, CUstream_st*) {
  std::atomic<std::uint32_t> fill{words[2]};
  std::atomic<bool> full{false};
  const std::uint32_t m = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, 4096), std::uint32_t(0),
      [&](const tbb::blocked_range<std::size_t>& r, std::uint32_t m) {
        std::vector<HeldRing> held(r.size());
        std::uint32_t slots = 0;
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          held[i - r.begin()] = f.walk(i);
          slots += ring_slots(held[i - r.begin()].degree);
        }
        std::uint32_t start = fill.fetch_add(slots);
        const bool fits = std::uint64_t(start) + slots <= f.table_slots;
        if (!fits) full = true;
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          const HeldRing& h = held[i - r.begin()];
          if (fits) f.write(i, start, h);
          start += ring_slots(h.degree);
          m = std::max(m, f.move_bits(i));
        }
        return m;
      },
      [](std::uint32_t a, std::uint32_t b) { return std::max(a, b); });
  words[0] = std::max(words[0], full ? (m | kRingOverflow) : m);
  words[2] = fill;
}

template <class R>
void cpu_visited(std::size_t n, const SearchVisited<R>& f, std::uint32_t* words, CUstream_st*) {
  const std::uint32_t m = cpu_max(n, [&f](std::size_t i) {
    std::uint32_t fast[kFastSlots];
    return f.template search<1>(i, fast, 0);
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
