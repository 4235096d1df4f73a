// FF_HD marks per-element math shared by the CPU and CUDA backends (kernel.h files).
#pragma once
#if defined(__CUDACC__)
#define FF_HD __host__ __device__ __forceinline__
#define FF_DEVICE_CODE 1
#else
#define FF_HD inline
#endif
