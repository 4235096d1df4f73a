// The Verlet list's build and its rebuild test, shared by neighbors.verlet (each step) and by a
// stage that moves particles after the list was built and must rebuild it within its own step
// (overlap_correct.verlet, stages/overlap_correct/verlet/stage.h). The loops are the backend's
// (verlet_loops: cpu.cpp, cuda.cu); a library that uses ListBuild compiles those files too.
// The fields it writes are the list's (list.h); neighbors.verlet adds them at configure.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/backend/exec.h"
#include "core/stage/stage.h"
#include "stages/neighbors/list.h"
#include "stages/neighbors/verlet/kernel.h"

namespace ff::neighbors {

// Every field a build writes (list.h).
inline constexpr const char* kListFields[] = {kList, kCount, kPositionAtBuild, kOrder, kCell, kCellStart, kCellEnd};

// The device's cell sort keeps its buffers across builds (none on the CPU).
struct CellSortScratch {
  template <class Exec>
  explicit CellSortScratch(Exec exec) : sorted_cell(exec), index(exec), temp(exec) {}
  Scratch<std::uint32_t> sorted_cell;  // the cells in sorted order
  Scratch<std::uint32_t> index;        // 0 .. n-1, sorted along into order[]
  Scratch<std::uint8_t> temp;          // the sort's own
};

// Stable sort of particles by cell: order[] (particle indices, cell-major) and, per cell,
// [cell_start, cell_end) in order[] (empty cells: start == end).
using CellSort = void (*)(std::size_t n, std::uint32_t ncells, const std::uint32_t* cell, std::uint32_t* order,
                          std::uint32_t* cell_start, std::uint32_t* cell_end, CellSortScratch& scratch,
                          CUstream_st* stream);

template <class R, int D>
struct VerletLoopsD {
  ElementLoop<AssignCell<R, D>> assign;
  ElementLoop<BuildList<R, D>> build;
  ReduceLoop<MovedTooFar<R, D>, std::uint32_t> moved;  // the backend object's max
};

template <class R>
struct VerletLoops {
  VerletLoopsD<R, 2> d2;
  VerletLoopsD<R, 3> d3;
  ReduceLoop<CountOf, std::uint32_t> max_count;
  CellSort sort;
};

// The loops of each backend (cpu.cpp, cuda.cu).
template <class R>
VerletLoops<R> verlet_loops(CpuExec);
template <class R>
VerletLoops<R> verlet_loops(CudaExec);

template <class R>
class ListBuild {
 public:
  template <class Exec>
  explicit ListBuild(Exec exec) : loops_(verlet_loops<R>(exec)), max_(exec), sort_scratch_(exec) {}

  // The cell grid for lists of radius rl = cutoff + skin: cells of edge ≥ rl, at most ~4 per
  // particle so empty cells cost little. A function of the box, N and rl alone, so every
  // ListBuild of a run agrees with the one that sized the cell fields. Returns the cell count.
  std::size_t set_grid(const State& s, double rl) {
    double nc[3] = {1, 1, 1}, total = 1;
    for (int k = 0; k < s.dim(); ++k) {
      nc[k] = std::max(1.0, std::floor(s.box.L[k] / rl));
      total *= nc[k];
    }
    const double limit = 4.0 * double(s.n()) + 64;
    if (total > limit) {
      const double shrink = std::pow(total / limit, 1.0 / s.dim());
      for (int k = 0; k < s.dim(); ++k) nc[k] = std::max(1.0, std::floor(nc[k] / shrink));
    }
    grid_nc_[0] = int(nc[0]);
    grid_nc_[1] = int(nc[1]);
    grid_nc_[2] = s.dim() == 3 ? int(nc[2]) : 1;
    return std::size_t(grid_nc_[0]) * grid_nc_[1] * grid_nc_[2];
  }

  // Whether some particle moved more than skin/2 (minimum image) since the last build.
  template <int D>
  bool moved_too_far(StepContext& ctx, double skin) {
    State& s = ctx.state;
    const R half = R(0.5 * skin);
    const MovedTooFar<R, D> f{s.field(fields::position).data<R>(ctx), s.field(kPositionAtBuild).data<R>(ctx),
                              PeriodicBox<R>::make(s.box.L), half * half};
    return loops_d<D>().moved(s.n(), f, max_, ctx.stream) != 0;
  }

  // Builds the list (list.h's fields) from the current positions: pairs within rl; rows grow
  // (reallocate and build again) when a particle has more neighbours than fit. `where`: the
  // side the list lives on (the stage's backend). Announces its writes first (StepContext::
  // will_write), so a stage may declare the list fields Access::on_demand_write.
  template <int D>
  void build(StepContext& ctx, double rl, Where where) {
    build_from<D>(ctx, rl, where, false);
  }

  // The list as it was last built, for particles numbered anew since (a decomposed team's
  // migration, core/run/domain.h): the same construction from the positions at that build
  // (position_at_build, a particle field that moved with the particles), which it leaves as
  // they are. Rows name the same particles in the same (id) order as before, provided every
  // particle within rl of a particle's position at build is still held.
  template <int D>
  void rebuild_rows(StepContext& ctx, double rl, Where where) {
    build_from<D>(ctx, rl, where, true);
  }

  // The longest row of the last build (set: restored from a checkpoint).
  std::uint32_t max_neighbors() const { return max_neighbors_; }
  void set_max_neighbors(std::uint32_t m) { max_neighbors_ = m; }

 private:
  template <int D>
  void build_from(StepContext& ctx, double rl, Where where, bool at_last_build) {
    for (const char* f : kListFields) ctx.will_write(f);
    State& s = ctx.state;
    const std::size_t n = s.n();
    const auto& L = loops_d<D>();
    R* at_build = s.field(kPositionAtBuild).data<R>(ctx);
    const R* x = at_last_build ? at_build : s.field(fields::position).data<R>(ctx);
    Grid<R, D> grid{PeriodicBox<R>::make(s.box.L), {grid_nc_[0], grid_nc_[1], grid_nc_[2]}};
    std::uint32_t* cell = s.field(kCell).data<std::uint32_t>(ctx);
    std::uint32_t* order = s.field(kOrder).data<std::uint32_t>(ctx);
    Field& start_f = s.field(kCellStart);
    std::uint32_t* start = start_f.data<std::uint32_t>(ctx);
    std::uint32_t* end = s.field(kCellEnd).data<std::uint32_t>(ctx);
    std::uint32_t* count = s.field(kCount).data<std::uint32_t>(ctx);
    const std::uint32_t* id =
        s.has_field(fields::particle_id) ? s.field(fields::particle_id).data<std::uint32_t>(ctx) : nullptr;
    L.assign(n, AssignCell<R, D>{x, cell, grid}, ctx.stream);
    loops_.sort(n, std::uint32_t(start_f.count()), cell, order, start, end, sort_scratch_, ctx.stream);

    Field& list = s.field(kList);
    for (;;) {
      const std::uint32_t cap = list_capacity(s);
      BuildList<R, D> f{x, order, start, end, grid, R(rl * rl), cap, list.data<std::uint32_t>(ctx),
                        count, at_last_build ? nullptr : at_build, id};
      L.build(n, f, ctx.stream);
      max_neighbors_ = n ? loops_.max_count(n, CountOf{count}, max_, ctx.stream) : 0;
      if (max_neighbors_ <= cap) break;
      // Grow with a margin so a slowly densifying system does not reallocate every build.
      const std::uint32_t grown = max_neighbors_ + max_neighbors_ / 4 + 8;
      list.resize(n * grown);
      list.acquire(where, Mode::write, ctx.stream);
    }
  }

  template <int D>
  const VerletLoopsD<R, D>& loops_d() const {
    if constexpr (D == 2) return loops_.d2;
    else return loops_.d3;
  }

  VerletLoops<R> loops_;
  Reduction<std::uint32_t> max_;  // the word of the backend's max-reductions
  CellSortScratch sort_scratch_;
  int grid_nc_[3] = {1, 1, 1};
  std::uint32_t max_neighbors_ = 0;
};

}  // namespace ff::neighbors
