// Counters that loops bump when something rare happens (an inverted triangle, a flip, a step
// too long). The
// results are sums and minima, so they do not depend on thread count or launch order.
// FF_HD; host side uses GCC builtins, device side CUDA atomics. nvcc-clean.
#pragma once
#include "core/base/hd.h"

namespace ff {

FF_HD void count_one(unsigned* p) {
#if defined(__CUDA_ARCH__)
  atomicAdd(p, 1u);
#else
  __atomic_fetch_add(p, 1u, __ATOMIC_RELAXED);
#endif
}

FF_HD void keep_min(unsigned* p, unsigned v) {
#if defined(__CUDA_ARCH__)
  atomicMin(p, v);
#else
  unsigned cur = __atomic_load_n(p, __ATOMIC_RELAXED);
  while (v < cur && !__atomic_compare_exchange_n(p, &cur, v, true, __ATOMIC_RELAXED, __ATOMIC_RELAXED)) {
  }
#endif
}

// Set *p to `desired` if it holds `expected`; returns what it held before.
FF_HD unsigned compare_and_swap(unsigned* p, unsigned expected, unsigned desired) {
#if defined(__CUDA_ARCH__)
  return atomicCAS(p, expected, desired);
#else
  __atomic_compare_exchange_n(p, &expected, desired, false, __ATOMIC_RELAXED, __ATOMIC_RELAXED);
  return expected;
#endif
}

// Reserve k consecutive slots of a list whose length is *counter; returns the first.
FF_HD unsigned append_index(unsigned* counter, unsigned k) {
#if defined(__CUDA_ARCH__)
  return atomicAdd(counter, k);
#else
  return __atomic_fetch_add(counter, k, __ATOMIC_RELAXED);
#endif
}

// Count an event and remember the lowest element id it happened at (for the error message).
FF_HD void record(unsigned* counters, int count_slot, int where_slot, unsigned id) {
  count_one(counters + count_slot);
  keep_min(counters + where_slot, id);
}

}  // namespace ff
