// The body of cpu_backend_results / cuda_backend_results (tests/backend/reductions.h), for one
// backend object Exec. Included once by test_backend.cpp (CpuExec) and once by backend_cuda.cu.
#pragma once
#include <vector>

#include "backend/reductions.h"

namespace ff::test {

template <class Exec>
BackendResults backend_results(std::size_t n, CUstream_st* s) {
  BackendResults r;
  Reduction<std::uint32_t> rmax{Exec{}};
  Reduction<std::uint64_t> rsum{Exec{}};
  r.max = Exec::max(n, Scrambled{}, rmax, s);
  r.sum = Exec::sum(n, Square{}, rsum, s);
  r.count = Exec::count(n, MultipleOf7{}, rsum, s);
  r.max_again = Exec::max(n / 2, Scrambled{}, rmax, s);

  Scratch<unsigned> values{Exec{}};
  unsigned* v = values.get(n);
  std::vector<unsigned> head(1);
  Exec::memory().to_host(head.data(), v, sizeof(unsigned), s);
  r.first_scratch = head[0];
  Exec::for_each(n, Fill{v, 3}, s);

  Counters<2> counters{Exec{}};
  counters.reset(std::array<int, 0>{}, s);
  Exec::for_each(n, CountOdd{v, counters.ptr()}, s);
  r.odd_sync = counters.read(s)[0];
  counters.reset(std::array<int, 0>{}, s);
  Exec::for_each(n, CountOdd{v, counters.ptr()}, s);
  counters.start_read(s);
  Exec::for_each(n, Fill{values.get(n), 4}, s);  // more work after the read starts
  r.odd_deferred = counters.finish_read()[0];
  Exec::memory().to_host(head.data(), values.get(n) + 5, sizeof(unsigned), s);
  r.kept = head[0];
  return r;
}

}  // namespace ff::test
