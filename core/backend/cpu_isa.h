// A second build of a hot CPU loop for x86-64-v4 (AVX-512), chosen at run time. The loops are
// built for x86-64-v3 (AVX2; cmake/flipflow_plugin.cmake, flipflow_cpu_loop_flags); a loop body
// compiled again in a function with FF_TARGET_X86_64_V4 runs the same operations (no fma
// contraction in either), so it gives the same bits, with AVX-512's encodings and its 32 vector
// registers, wherever cpu_has_x86_64_v4() says the CPU has them. Host only.
#pragma once
#include <cstdlib>

#if defined(__AVX2__) && defined(__x86_64__) && defined(__GNUC__) && !defined(__CUDACC__)
#define FF_CPU_V4_DISPATCH 1
#define FF_TARGET_X86_64_V4 __attribute__((target("arch=x86-64-v4")))
#else
#define FF_CPU_V4_DISPATCH 0
#define FF_TARGET_X86_64_V4
#endif

namespace ff {

// Whether this CPU has what -march=x86-64-v4 assumes (AVX-512 F, BW, CD, DQ, VL), and
// FLIPFLOW_NO_AVX512 is not set in the environment (to time or test the AVX2 loops on such a
// CPU). Asked once per library.
inline bool cpu_has_x86_64_v4() {
#if FF_CPU_V4_DISPATCH
  static const bool yes = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                          __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512dq") &&
                          __builtin_cpu_supports("avx512vl") && !std::getenv("FLIPFLOW_NO_AVX512");
  return yes;
#else
  return false;
#endif
}

}  // namespace ff
