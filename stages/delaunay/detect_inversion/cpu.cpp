#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include "core/exec_cpu.h"
#include "stages/delaunay/detect_inversion/cpu.h"

namespace ff::delaunay {

namespace {
// MarkInversions over the edges, each task appending its Lawson candidates in batches of up to
// kBatch (one update of the shared counter per batch instead of per candidate).
template <class R>
void mark(std::size_t n, const MarkInversions<R>& f, CUstream_st*) {
  constexpr std::size_t kGrain = 2048, kBatch = 256;
  auto run = [&](std::size_t begin, std::size_t end) __attribute__((flatten)) {
    const MarkInversions<R> local = f;  // as cpu_for_each: members stay in registers
    int batch[kBatch];
    unsigned k = 0;
    for (std::size_t i = begin; i != end; ++i) {
      if (!local.test(int(i))) continue;
      batch[k++] = int(i);
      if (k == kBatch) {
        local.append(batch, k);
        k = 0;
      }
    }
    if (k) local.append(batch, k);
  };
  if (n <= kGrain) return run(0, n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) { run(r.begin(), r.end()); });
}
}  // namespace

template <class R>
DetectOps<R> detect_cpu_ops() {
  return {&mark<R>, &cpu_for_each<CheckInverted<R>>, cpu_mem_ops()};
}
template DetectOps<float> detect_cpu_ops<float>();
template DetectOps<double> detect_cpu_ops<double>();

}  // namespace ff::delaunay
