// overlap_correct's CUDA launch shapes: who runs the persistent kernel's iterations (the grid,
// a cluster of 16 blocks, or of 8 when runs share the GPU) and each block's tile; included by
// cuda.cu after correct_kernel.cuh, whose kernel they launch. Host code and constants only.
#pragma once
#include <map>
#include <mutex>
#include <utility>

#include "core/backend/cuda/cluster.cuh"
#include "stages/overlap_correct/correct_kernel.cuh"
#include "stages/overlap_correct/dense_block.cuh"

namespace ff::overlap {

namespace {

// Blocks and tile for n particles: at most what fits on the device at once (a cooperative
// launch needs every block resident), tiles of at least kMinTile particles, a multiple of 16.
// One block of 512 per SM (128 registers): against 2 blocks of 256 (the shape from session 4 to
// 24) the same at 2^14 and 4-7 % faster from 2^16 to 2^20 on the H200 (bench/README.md, "Session
// 25": half as many blocks meet at each grid barrier); with tiles of 256 rather than 512, 2.4 %
// faster at 2^14 (64 SMs instead of 32), and of 128 rather than 256 1.9 % more (128 SMs; session
// 28). 3 blocks of 256 get 80 registers and spill, and 8
// loads in flight (kInFlight) gain nothing. The best shape changed with the kernel (3 blocks with
// one load after the other, 4 with fan walks only), so measure again after changing it
// (bench/overlap_correct-PERF.md and bench/README.md, "Numbers formerly in source comments").
constexpr int kMinBlocks = 1;

// Small systems: a cluster of kClusterBlocks blocks of kClusterThreads runs the iterations
// instead of the grid for n ≤ kClusterMaxN: there an iteration's walks are short, and the grid's
// barriers per iteration and its cooperative launch are the time. The shape comes from the
// A/B in bench/overlap_correct-PERF.md (session 13; one block alone, a variant there, lost at
// every size), the threshold from session 25's (bench/README.md, "Session 25"): the cluster wins
// at 8192 particles and ties the grid at 16384, above which the grid's SMs do more than the
// cluster's barrier saves. On a GPU that many runs share, team_for gives a run fewer SMs. Below
// that, a run alone without walls or the touched field takes the dense block or cluster instead
// (dense_block.cuh: every iteration an edge pass in shared memory; dense_shape).
constexpr int kClusterBlocks = 16;
static_assert(kClusterBlocks == kClusterTailTeam, "correct_kernel.cuh's tail threshold names this cluster");
constexpr int kClusterThreads = 512;
constexpr std::size_t kClusterMaxN = 8192;
// Runs that share the GPU and would not fit side by side as grids take a cluster of 8 blocks (8
// SMs, the portable cluster size) instead of 16: a correction takes a little longer, but twice
// as many run at once, and a sweep's corrections side by side are what bounds it (bench/README.md,
// "Session 20": 64 runs of bench-abp 2^14).
constexpr int kSharedClusterBlocks = 8;

// A team's block size; 128 registers a thread, as the grid's kernel (kMinBlocks).
template <int Team>
constexpr int threads_of = Team == kGrid ? kThreads : kClusterThreads;
template <int Team>
constexpr int min_blocks_of = Team == kGrid ? kMinBlocks : std::max(1, 512 / threads_of<Team>);

template <class R, int Team, bool Walls, bool Mark, bool SharedTail = false>
void* kernel_ptr() {
  return reinterpret_cast<void*>(correct_kernel<R, threads_of<Team>, min_blocks_of<Team>, Team, Walls, Mark, SharedTail>);
}

// A cluster of Team blocks (core/backend/cuda/cluster.cuh), launched after the previous kernel
// programmatically (core/backend/cuda/pdl.cuh; attr holds two): in a small step the cluster is
// scheduled while Lawson's tail kernel runs.
template <int Team>
cudaLaunchConfig_t team_config_after_previous(cudaLaunchAttribute* attr, CUstream_st* s) {
  cudaLaunchConfig_t cfg = cluster_config(Team, threads_of<Team>, s, attr);
  cfg.numAttrs = programmatic_attr(attr, cfg.numAttrs);
  return cfg;
}

// The cooperative grid's launch (every block resident for its grid barriers), after the previous
// kernel programmatically as a team's (attr holds two): above kClusterMaxN particles the grid
// is what follows Lawson's tail kernel in a small step.
inline cudaLaunchConfig_t grid_config_after_previous(int blocks, cudaLaunchAttribute* attr, CUstream_st* s) {
  cudaLaunchConfig_t cfg = {};
  cfg.gridDim = dim3(blocks);
  cfg.blockDim = dim3(kThreads);
  cfg.stream = s;
  attr[0].id = cudaLaunchAttributeCooperative;
  attr[0].val.cooperative = 1;
  cfg.attrs = attr;
  cfg.numAttrs = programmatic_attr(attr, 1);
  return cfg;
}

// Whether the device can run a cluster team of Team blocks (core/backend/cuda/cluster.cuh).
template <class R, int Team, bool Walls, bool Mark>
bool team_fits() {
  return cluster_fits(kernel_ptr<R, Team, Walls, Mark>(), Team, threads_of<Team>, 0, "overlap_correct: a cluster team");
}

// The grid for n particles: blocks of kThreads, at most what fits on the device at once (a
// cooperative launch needs every block resident), tiles of at least kMinTile particles; and how
// many SMs those blocks hold (per_sm to an SM). When runs share the GPU (runs_sharing_gpu) the
// tiles are at least 512, as a grid's were before session 25 (two blocks of 256 to an SM: 32 SMs
// at 2^14, where 128 holds 128), so up to 4 runs of 2^14 still take grids side by side (team_for),
// the sweeps measured so far.
constexpr std::size_t kMinTile = 128;
constexpr std::size_t kMinTileShared = 512;
struct GridShape {
  int blocks = 0, sms_held = 0, sms = 0;
};
template <class R, bool Walls, bool Mark>
GridShape grid_shape(std::size_t n) {
  int dev = 0, sms = 0, per_sm = 0, coop = 0;
  FF_CUDA_CHECK(cudaGetDevice(&dev), "overlap_correct: current device");
  FF_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, dev), "overlap_correct: SM count");
  FF_CUDA_CHECK(cudaDeviceGetAttribute(&coop, cudaDevAttrCooperativeLaunch, dev), "overlap_correct: cooperative");
  if (!coop) throw RunError("overlap_correct: the CUDA device does not support cooperative launches");
  FF_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, kernel_ptr<R, kGrid, Walls, Mark>(), kThreads, 0),
                "overlap_correct: occupancy");
  per_sm = std::max(1, per_sm);
  const std::size_t most = std::size_t(per_sm) * std::size_t(sms);
  const std::size_t tile = runs_sharing_gpu() > 1 ? kMinTileShared : kMinTile;
  const std::size_t want = std::max<std::size_t>(1, (n + tile - 1) / tile);
  GridShape g;
  g.blocks = int(std::min(most, want));
  g.sms_held = (g.blocks + per_sm - 1) / per_sm;
  g.sms = sms;
  return g;
}

// The team for n particles. A run alone: the cluster where the device runs it (n ≤ kClusterMaxN),
// else the grid, the fastest (bench/overlap_correct-PERF.md). On a GPU that K runs share
// (runs_sharing_gpu: `pipeline sweep`): a cluster of kSharedClusterBlocks also where K grids would
// not fit on the GPU at once. What bounds a sweep is how many corrections run side by side: at
// 2^14 a shared grid holds 32 SMs (32 blocks, one to an SM), the cluster of 16 holds 16 and that of 8
// holds 8 for somewhat longer, so more runs correct at once; alone the grid stays, since a cluster
// is slower there, and one block a run was slower in a sweep too (numbers: bench/README.md,
// "Sweeps on one GPU" and "Session 20"). Who runs the iterations does not change the bits.
template <class R, bool Walls, bool Mark>
int team_for(std::size_t n) {
  if (!team_fits<R, kClusterBlocks, Walls, Mark>()) return kGrid;
  if (n <= kClusterMaxN) return kClusterBlocks;
  const int sharing = runs_sharing_gpu();
  if (sharing <= 1) return kGrid;
  const GridShape g = grid_shape<R, Walls, Mark>(n);
  if (std::size_t(sharing) * std::size_t(g.sms_held) <= std::size_t(g.sms)) return kGrid;
  return team_fits<R, kSharedClusterBlocks, Walls, Mark>() ? kSharedClusterBlocks : kClusterBlocks;
}

// Whether kernel f, in blocks of `threads`, can have `bytes` of dynamic shared memory beside its
// static arrays on the current device; if so, raises f's limit to at least that. The limit
// belongs to the device's kernel, not to this run, and only grows: runs of other sizes on this
// GPU (ranks of a team, a sweep's runs) set it too, and a lower limit set last would make a larger
// run's launch fail.
inline bool fits_dynamic_shared(void* f, int threads, std::size_t bytes, const char* what) {
  int dev = 0, optin = 0;
  FF_CUDA_CHECK(cudaGetDevice(&dev), "overlap_correct: current device");
  FF_CUDA_CHECK(cudaDeviceGetAttribute(&optin, cudaDevAttrMaxSharedMemoryPerBlockOptin, dev),
                "overlap_correct: shared memory per block");
  cudaFuncAttributes attr = {};
  FF_CUDA_CHECK(cudaFuncGetAttributes(&attr, f), what);
  if (attr.sharedSizeBytes + bytes > std::size_t(optin) || attr.maxThreadsPerBlock < threads) return false;
  static std::mutex mutex;
  static std::map<std::pair<void*, int>, std::size_t> limits;  // by kernel and device
  std::lock_guard<std::mutex> lock(mutex);
  std::size_t& limit = limits[{f, dev}];
  if (bytes > limit) {
    FF_CUDA_CHECK(cudaFuncSetAttribute(f, cudaFuncAttributeMaxDynamicSharedMemorySize, int(bytes)), what);
    limit = bytes;
  }
  return true;
}

// The dynamic shared memory of a tail in shared memory (shared_tail.cuh) of n particles, set as the
// limit of the cluster kernel that runs one; 0 where it does not fit beside the kernel's static
// arrays or the cluster would not be resident with it.
template <class R, bool Mark>
std::size_t shared_tail_bytes(std::size_t n) {
  if (n >= 65536) return 0;  // (16-bit ids)
  void* f = kernel_ptr<R, kClusterBlocks, false, Mark, true>();
  const std::size_t bytes = TailState<R>::bytes(n);
  const char* what = "overlap_correct: the shared-memory tail";
  if (!fits_dynamic_shared(f, threads_of<kClusterBlocks>, bytes, what)) return 0;
  return cluster_fits(f, kClusterBlocks, threads_of<kClusterBlocks>, bytes, what) ? bytes : 0;
}

// The dense block or cluster (dense_block.cuh) for n particles: its blocks and each one's dynamic
// shared memory, set as its kernel's limit; no blocks where it does not take the run (n >
// kDenseClusterMaxN, the state does not fit one block's shared memory beside the kernel's static
// arrays, or the device does not run the cluster at once).
struct DenseShape {
  int blocks = 0, shift = 0;  // shift: dense_kernel's (0: one block)
  std::size_t bytes = 0;
};
// dense_kernel<R, shift> for shift 0 or in [kDenseMinShift, kDenseMaxShift].
template <class R, int S = kDenseMinShift>
void* dense_kernel_ptr(int shift) {
  if (shift == 0) return reinterpret_cast<void*>(dense_kernel<R, 0>);
  if constexpr (S <= kDenseMaxShift) {
    if (shift == S) return reinterpret_cast<void*>(dense_kernel<R, S>);
    return dense_kernel_ptr<R, S + 1>(shift);
  } else {
    throw RunError("overlap_correct: no dense cluster kernel for that share (internal error)");
  }
}
template <class R>
DenseShape dense_shape(std::size_t n) {
  if (n == 0 || n > kDenseClusterMaxN) return {};
  DenseShape d;
  if (n <= kDenseMaxN) {
    d.blocks = 1;
    d.bytes = DenseLayout<R>(n).bytes;
  } else {
    d.shift = dense_shift(n);
    d.blocks = int((n + (std::size_t(1) << d.shift) - 1) >> d.shift);
    d.bytes = DenseLayout<R, true>(std::size_t(1) << d.shift).bytes;
  }
  void* f = dense_kernel_ptr<R>(d.shift);
  if (!fits_dynamic_shared(f, kDenseThreads, d.bytes, "overlap_correct: the dense block's shared memory")) return {};
  if (d.blocks > 1 && !cluster_fits(f, d.blocks, kDenseThreads, d.bytes, "overlap_correct: the dense cluster")) return {};
  return d;
}

template <class R, bool Walls, bool Mark>
void shape(std::size_t n, int team, int& grid, int& tile) {
  grid = team != kGrid ? team : grid_shape<R, Walls, Mark>(n).blocks;  // a team's blocks share the particles
  const std::size_t t = (n + grid - 1) / grid;
  tile = int(std::max<std::size_t>(16, (t + 15) / 16 * 16));
}

}  // namespace

}  // namespace ff::overlap
