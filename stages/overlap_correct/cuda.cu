// CUDA loop of overlap_correct, host side: DeviceLoops sizes the scratch, launches
// correct_kernel.cuh's kernels (on the grid the wide kernels' first iterations, then a cooperative
// grid launch; or a cluster) or, for a small run alone, dense_block.cuh's block or cluster, and reads
// their counters.
// Compiled with -fmad=false (CMakeLists.txt), as the kernels it includes must be.
#include <cuda_runtime.h>

#include <algorithm>

#include "core/backend/cuda/check.h"
#include "stages/overlap_correct/correct_kernel.cuh"
#include "stages/overlap_correct/dense_block.cuh"
#include "stages/overlap_correct/team_shape.cuh"
#include "stages/overlap_correct/wide_kernels.cuh"

namespace ff::overlap {

namespace {

// The device's loop and its scratch (device arrays, the counters' landing in pinned host memory),
// sized for n particles on the first iteration and again when n changes.
template <class R>
class DeviceLoops final : public OverlapCorrectLoops<R> {
 public:
  explicit DeviceLoops(CudaExec exec)
      : marks_(exec),
        cand_(exec),
        seed_(exec),
        disp_(exec),
        crossed_(exec),
        nb_(exec),
        degree_(exec),
        fan_(exec),
        state_(exec),
        next_(exec),
        slots_{Scratch<u64>(exec), Scratch<u64>(exec)},
        result_(exec),
        ops_(&exec.memory()),
        done_(ops_->fence_create()) {}
  ~DeviceLoops() override { ops_->fence_destroy(done_); }
  DeviceLoops(const DeviceLoops&) = delete;
  DeviceLoops& operator=(const DeviceLoops&) = delete;

  void start(const Problem<R>& p, std::int64_t k0, std::int64_t max_iterations, Batch&, CUstream_st* s) override {
    const bool walls = p.overlaps.wall_axis >= 0, mark = p.touched != nullptr;
    if (walls && mark)
      launch<true, true>(p, k0, max_iterations, s);
    else if (walls)
      launch<true, false>(p, k0, max_iterations, s);
    else if (mark)
      launch<false, true>(p, k0, max_iterations, s);
    else
      launch<false, false>(p, k0, max_iterations, s);
  }
  // Waits for the launch (its fence: a read left past the step must not wait for what the next
  // step queued behind it since) and copies its counters (written by the kernel into pinned memory).
  void finish(Batch& out) override {
    ops_->fence_wait(done_);
    unread_ = false;
    const u64* result = result_.get(kResultWords);
    out.gathers = int(result[std::size_t(kDeviceBatch) * kCounters]);
    last_gathers_ = out.gathers;
    for (int j = 0; j < out.gathers; ++j) {
      for (int c = 0; c < kCounters; ++c) out.counters[j][c] = result[std::size_t(j) * kCounters + c];
      if (!mark_) out.counters[j][kTouched] = 0;
    }
  }
  int max_gathers() const override { return kDeviceBatch; }

 private:
  template <bool Walls, bool Mark>
  void launch(const Problem<R>& p, std::int64_t k0, std::int64_t max_iterations, CUstream_st* s) {
    const int variant = 2 * int(Walls) + int(Mark);
    if (!made_ || n_ != p.n || variant_ != variant) prepare<Walls, Mark>(p.n, variant);
    // The other parity's slots were used by the last launch (its gathers' counters): this one
    // zeroes those for the next (all when the last one was never read back).
    const std::size_t zero = unread_ ? kSlotWords
                                     : std::min(kSlotWords, std::size_t(last_gathers_) * kDevCounters * kShards * kShardStride);
    Args<R, Walls> a{p,
                     p.overlaps.template with_walls<Walls>(),
                     marks_.get(cap_),
                     cand_.get(cap_),
                     seed_.get(cap_),
                     disp_.get(cap_),
                     crossed_.get(cap_),
                     nb_.get(kCached * cap_),
                     degree_.get(cap_),
                     fan_.get(kCached * cap_),
                     slots_[parity_].get(kSlotWords + 1),
                     slots_[parity_].get(kSlotWords + 1) + kSlotWords,
                     slots_[1 - parity_].get(kSlotWords + 1),
                     result_.get(kResultWords),
                     state_.get(cap_),
                     wide_ ? nullptr : next_.get(2 * cap_),
                     p.overlaps.template with_walls<Walls>(),
                     tile_,
                     0,
                     static_cast<long long>(k0),
                     static_cast<long long>(max_iterations),
                     static_cast<long long>(zero)};
    if (a.next) a.ov_check.pos = a.next;
    // The grid's first iterations run in the wide kernels (wide_kernels.cuh), queued at once:
    // each does nothing after an iteration that did not go on.
    if (wide_ && k0 == 0) a.j0 = run_wide<Walls, Mark>(a, s);
    void* args[] = {&a};
    if (dense_.blocks > 0) {  // (prepare: only without walls and mark)
      if constexpr (!Walls && !Mark) {
        cudaLaunchAttribute attr[2];
        cudaLaunchConfig_t cfg = {};
        if (dense_.blocks > 1) {
          cfg = cluster_config(dense_.blocks, kDenseThreads, s, attr);
        } else {
          cfg.gridDim = dim3(1);
          cfg.blockDim = dim3(kDenseThreads);
          cfg.stream = s;
          cfg.attrs = attr;
        }
        cfg.dynamicSmemBytes = dense_.bytes;
        cfg.numAttrs = programmatic_attr(attr, cfg.numAttrs);
        FF_CUDA_CHECK(cudaLaunchKernelExC(&cfg, dense_kernel_ptr<R>(dense_.shift), args),
                      "launching overlap_correct (dense)");
      } else {
        throw RunError("overlap_correct: the dense block prepared for a run with walls or the touched field (internal error)");
      }
    } else if (team_ == kGrid) {
      cudaLaunchAttribute attr[2];
      const cudaLaunchConfig_t cfg = grid_config_after_previous(grid_, attr, s);
      FF_CUDA_CHECK(cudaLaunchKernelExC(&cfg, kernel_ptr<R, kGrid, Walls, Mark>(), args), "launching overlap_correct");
    } else if (team_ == kSharedClusterBlocks) {
      launch_team<kSharedClusterBlocks, Walls, Mark>(args, 0, s);
    } else if (tail_bytes_ > 0 && max_iterations < kDeviceBatch) {  // (one launch runs the whole step)
      if constexpr (!Walls) launch_team<kClusterBlocks, Walls, Mark, true>(args, tail_bytes_, s);
    } else {
      launch_team<kClusterBlocks, Walls, Mark>(args, 0, s);
    }
    parity_ = 1 - parity_;
    ops_->fence_record(done_, s);
    mark_ = Mark;
    unread_ = true;
  }

  // Launches the wide kernels' iterations 0 .. kWideIterations - 1; returns how many.
  template <bool Walls, bool Mark>
  static int run_wide(const Args<R, Walls>& a, CUstream_st* s) {
    const int blocks = int((a.p.n + kWideThreads - 1) / kWideThreads);
    for (int j = 0; j < kWideIterations; ++j) {
      launch_after_previous("launching overlap_correct's wide gather",
                            wide_gather<R, kWideThreads, kWideMinBlocks, Walls, Mark>, dim3(blocks),
                            dim3(kWideThreads), s, a, j);
      launch_after_previous("launching overlap_correct's wide apply", wide_apply<R, kWideThreads, Walls, Mark>,
                            dim3(blocks), dim3(kWideThreads), s, a, j);
      launch_after_previous("launching overlap_correct's wide check",
                            wide_check<R, kWideThreads, kWideMinBlocks, Walls, Mark>, dim3(blocks),
                            dim3(kWideThreads), s, a, j);
    }
    return kWideIterations;
  }

  // A cluster launch of the team's blocks.
  template <int Team, bool Walls, bool Mark, bool SharedTail = false>
  static void launch_team(void** args, std::size_t shared_bytes, CUstream_st* s) {
    cudaLaunchAttribute attr[2];
    cudaLaunchConfig_t cfg = team_config_after_previous<Team>(attr, s);
    cfg.dynamicSmemBytes = shared_bytes;
    FF_CUDA_CHECK(cudaLaunchKernelExC(&cfg, kernel_ptr<R, Team, Walls, Mark, SharedTail>(), args),
                  "launching overlap_correct (a team of blocks)");
  }

  // Every array zeroed (the marks and the counters must start so).
  template <bool Walls, bool Mark>
  void prepare(std::size_t n, int variant) {
    team_ = team_for<R, Walls, Mark>(n);
    shape<R, Walls, Mark>(n, team_, grid_, tile_);
    cap_ = std::size_t(grid_) * std::size_t(tile_);
    // The wide kernels pay where the cooperative grid, full, gives its threads more than one
    // particle each in iteration 0 (tile_ > kThreads): there the latency they hide is the
    // stage's time. Below that, a step is short and their three launches cost more than they
    // save (bench/README.md, "Session 19, calls 2 and 3": slower at 2^14, even at 2^16).
    wide_ = team_ == kGrid && tile_ > kThreads;
    // A run alone in the cluster of 16, without walls, whose particles fit one block's shared
    // memory: the tail there (shared_tail.cuh).
    tail_bytes_ = team_ == kClusterBlocks && !Walls && runs_sharing_gpu() <= 1 ? shared_tail_bytes<R, Mark>(n) : 0;
    // A small run alone, without walls or the touched field: one block or a cluster, dense
    // (dense_block.cuh).
    dense_ = !Walls && !Mark && runs_sharing_gpu() <= 1 ? dense_shape<R>(n) : DenseShape{};
    for (Scratch<u64>& sl : slots_) sl.reset();
    marks_.reset();  // fresh zeroed arrays even where the size did not change
    parity_ = 0;
    last_gathers_ = 0;
    unread_ = false;
    n_ = n;
    variant_ = variant;
    made_ = true;
  }

  Scratch<std::uint8_t> marks_;  // grid·tile bytes, one per particle: the next candidates
  Scratch<int> cand_;            // grid·tile: the candidates (Args)
  Scratch<int> seed_;            // grid·tile: the touched particles
  Scratch<double2> disp_;        // grid·tile: where the moved ones go
  Scratch<char2> crossed_;       // grid·tile: their box crossings
  Scratch<int> nb_;              // kCached x grid·tile: each particle's neighbours
  Scratch<std::uint8_t> degree_; // grid·tile: how many (kept across steps, with fan_)
  Scratch<int> fan_;             // kCached x grid·tile: each listed fan's half-edges (kept_fan)
  Scratch<std::uint8_t> state_;  // grid·tile: what a wide gather found, by particle
  Scratch<R> next_;              // 2 x grid·tile: the positions after an iteration's moves (not wide)
  Scratch<u64> slots_[2];        // kSlotWords + the claims count, per launch parity
  HostScratch<u64> result_;      // pinned: the kernel writes its counters there (no copy after it)
  std::size_t n_ = 0, cap_ = 0;
  int grid_ = 0, tile_ = 0;
  int team_ = kGrid;  // who runs the iterations (team_for): kGrid, kClusterBlocks or kSharedClusterBlocks
  bool wide_ = false;  // the grid's first iterations in the wide kernels (prepare)
  std::size_t tail_bytes_ = 0;  // the shared-memory tail's dynamic shared memory, 0 without it (prepare)
  DenseShape dense_;  // the dense block's or cluster's shape, no blocks when it does not run (prepare)
  int parity_ = 0;  // which slots the next launch uses (zero); it zeroes the other
  int last_gathers_ = 0;   // how many gathers the last launch ran (the slots it used)
  bool unread_ = false;    // the last launch was never read back (finish)
  bool mark_ = false;      // the last launch counted first touches
  const MemoryOps* ops_;
  void* done_;  // recorded after each launch (finish waits for it)
  int variant_ = -1;  // the kernel prepared for: 2·walls + mark (its occupancy sets the grid)
  bool made_ = false;
};

}  // namespace

template <class R>
std::unique_ptr<OverlapCorrectLoops<R>> overlap_correct_loops(CudaExec exec) {
  return std::make_unique<DeviceLoops<R>>(exec);
}
template std::unique_ptr<OverlapCorrectLoops<float>> overlap_correct_loops<float>(CudaExec);
template std::unique_ptr<OverlapCorrectLoops<double>> overlap_correct_loops<double>(CudaExec);

}  // namespace ff::overlap
