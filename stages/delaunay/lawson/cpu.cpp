// CPU loops of delaunay.lawson. The per-edge math is kernel.h's (marks, wins, flip_and_list); what
// differs from the device is how the lists are filled. Nearly every element of a round appends
// to a list, and on the host one shared counter bumped from two threads moves its cache line
// between the cores on every append (most of Lawson's time went there). So each chunk of
// elements fills its own list, and the chunks' lists are appended in chunk order
// afterwards: no shared counter, and the lists' order no longer depends on the thread count.
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/parallel_reduce.h>
#include <oneapi/tbb/partitioner.h>
#include <oneapi/tbb/task_arena.h>

#include <algorithm>
#include <type_traits>
#include <vector>

#include "core/backend/exec_cpu.h"
#include "stages/delaunay/lawson/stage.h"

namespace ff::delaunay {

namespace {

constexpr std::size_t kChunk = 1024;  // elements per task: a few tasks per round at N = 2^16

// Calls body(i, out) for i in [0, n), chunk by chunk on the oneTBB threads (out: the chunk's
// own list), then appends the chunks' lists to list[*len ...] in chunk order, each entry e only
// if keep(e) (called on one thread, in that order), and adds their total to *len. The chunk lists
// are kept between calls (per calling thread), so a warm run allocates nothing.
struct KeepAll {
  bool operator()(std::int32_t) const { return true; }
};
template <class Body, class Keep = KeepAll>
void append_by_chunks(std::size_t n, std::int32_t* list, unsigned* len, const Body& body, const Keep& keep = {}) {
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  thread_local std::vector<std::vector<std::int32_t>> lists;
  if (lists.size() < chunks) lists.resize(chunks);
  const auto out = lists.begin();
  auto run = [&](std::size_t c) __attribute__((flatten)) {
    std::vector<std::int32_t>& o = out[std::ptrdiff_t(c)];
    o.clear();
    for (std::size_t i = c * kChunk, end = std::min(n, i + kChunk); i < end; ++i) body(i, o);
  };
  if (chunks <= 1) {
    for (std::size_t c = 0; c < chunks; ++c) run(c);
  } else {
    // Isolated: while this thread waits for the chunks it must not take up an outer task that
    // could call this function again on this thread and reuse `lists` under its feet.
    tbb::this_task_arena::isolate([&] {
      tbb::parallel_for(
          tbb::blocked_range<std::size_t>(0, chunks, 1),
          [&](const tbb::blocked_range<std::size_t>& r) {
            for (std::size_t c = r.begin(); c != r.end(); ++c) run(c);
          },
          tbb::simple_partitioner());
    });
  }
  unsigned at = *len;
  for (std::size_t c = 0; c < chunks; ++c) {
    const std::vector<std::int32_t>& o = out[std::ptrdiff_t(c)];
    if constexpr (std::is_same_v<Keep, KeepAll>) {  // a plain copy (memmove) where nothing is dropped
      std::copy(o.begin(), o.end(), list + at);
      at += unsigned(o.size());
    } else {
      for (const std::int32_t e : o)
        if (keep(e)) list[at++] = e;
    }
  }
  *len = at;
}

template <class R>
void mark(std::size_t n, const MarkNonDelaunay<R>& f, CUstream_st*) {
  const std::size_t len = f.length(n);
  append_by_chunks(len, f.marked_list, f.counters + kLawsonMarked, [&](std::size_t i, std::vector<std::int32_t>& out) {
    const int e = f.edge_at(i, len);
    if (f.marks(e)) out.push_back(e);
  });
}

void decide(std::size_t n, const DecideMarked& f, CUstream_st*) {
  if (f.len) n = std::min<std::size_t>(n, *f.len);
  if (n) ++f.counters[kLawsonRounds];
  // Each element decides its own edge (go[e]); the flips are counted per task and added once.
  const unsigned flips = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, kChunk), 0u,
      [&](const tbb::blocked_range<std::size_t>& r, unsigned sum) __attribute__((flatten)) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) sum += f.wins(f.marked_list[i]) ? 1u : 0u;
        return sum;
      },
      [](unsigned a, unsigned b) { return a + b; });
  f.counters[kLawsonFlips] += flips;
}

void apply(std::size_t n, const ApplyMarked& f, CUstream_st*) {
  if (f.len) n = std::min<std::size_t>(n, *f.len);
  // The edges to retest are listed by each flip and kept once each afterwards, on one thread with
  // plain stamps: a locked exchange per edge (the device's claim) waited for the flip's stores
  // to drain and took most of this loop's time.
  append_by_chunks(
      n, f.next_list, f.counters + kLawsonQueued,
      [&](std::size_t i, std::vector<std::int32_t>& out) {
        int q[4];
        const int k = f.flip_and_list(f.marked_list[i], q);
        out.insert(out.end(), q, q + k);
      },
      [&](std::int32_t e) {
        if (f.queued[e] == f.next_round) return false;
        f.queued[e] = f.next_round;
        return true;
      });
}

}  // namespace

template <class R>
LawsonLoops<R> lawson_loops(CpuExec) {
  return {&mark<R>, &decide, &apply};
}
template LawsonLoops<float> lawson_loops<float>(CpuExec);
template LawsonLoops<double> lawson_loops<double>(CpuExec);

}  // namespace ff::delaunay
