// Thread-block clusters (sm_90): the launch of a kernel as one cluster of `blocks` blocks (the
// whole grid), and whether the device runs such a cluster at once. The stages whose small systems
// run on a cluster use both: overlap_correct's teams (team_shape.cuh) and delaunay.lawson's tail
// rounds (lawson/cuda.cu). Include only from .cu files.
#pragma once
#include <cuda_runtime.h>

#include <cstddef>

#include "core/backend/cuda/check.h"

namespace ff {

// One cluster of `blocks` blocks of `threads` on stream s: attr holds the cluster's attribute
// (attr[0]; a caller may add more at cfg.numAttrs, as pdl.cuh's programmatic_attr does).
inline cudaLaunchConfig_t cluster_config(int blocks, int threads, CUstream_st* s, cudaLaunchAttribute* attr) {
  cudaLaunchConfig_t cfg = {};
  cfg.gridDim = dim3(unsigned(blocks));
  cfg.blockDim = dim3(unsigned(threads));
  cfg.stream = s;
  attr[0].id = cudaLaunchAttributeClusterDimension;
  attr[0].val.clusterDim.x = unsigned(blocks);
  attr[0].val.clusterDim.y = attr[0].val.clusterDim.z = 1;
  cfg.attrs = attr;
  cfg.numAttrs = 1;
  return cfg;
}

// Whether the current device runs one cluster of `kernel` in `blocks` blocks of `threads`, with
// `shared_bytes` of dynamic shared memory each, at once: sm_90 clusters, and the blocks on SMs of
// one GPC. Above 8 blocks (the portable size; sm_90 runs 16) it allows the kernel the
// non-portable size first. `who` names the caller in a CUDA error.
inline bool cluster_fits(const void* kernel, int blocks, int threads, std::size_t shared_bytes, const char* who) {
  int dev = 0, cluster = 0;
  FF_CUDA_CHECK(cudaGetDevice(&dev), who);
  FF_CUDA_CHECK(cudaDeviceGetAttribute(&cluster, cudaDevAttrClusterLaunch, dev), who);
  if (!cluster) return false;
  if (blocks > 8) FF_CUDA_CHECK(cudaFuncSetAttribute(kernel, cudaFuncAttributeNonPortableClusterSizeAllowed, 1), who);
  cudaLaunchAttribute attr[1];
  cudaLaunchConfig_t cfg = cluster_config(blocks, threads, nullptr, attr);
  cfg.dynamicSmemBytes = shared_bytes;
  int clusters = 0;
  FF_CUDA_CHECK(cudaOccupancyMaxActiveClusters(&clusters, kernel, &cfg), who);
  return clusters >= 1;
}

}  // namespace ff
