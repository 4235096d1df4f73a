// neighbors.verlet: cell list + Verlet list with Tran's dynamic rebuild test, 2D and 3D, periodic.
// Every step it checks whether some particle moved more than skin/2 since the last build and
// rebuilds only then (metric `rebuilds`, 0 or 1). Row capacity grows (reallocate + rebuild)
// whenever a particle has more neighbours than fit (metric `max_neighbors`).
#pragma once
#include <algorithm>
#include <cmath>
#include <string>

#include "core/base/error.h"
#include "core/backend/exec.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/neighbors/list.h"
#include "stages/neighbors/verlet/kernel.h"

namespace ff::neighbors {

struct VerletParams {
  double cutoff = 2.5;  // pairs closer than this must be in the list
  double skin = 0.5;    // extra radius: the list stays complete until a particle moves skin/2

  template <class P>
  void describe(P& p) {
    p(cutoff, "cutoff", "interaction cutoff r_c (σ): every pair closer is listed").above(0);
    p(skin, "skin",
      "Verlet skin (σ): lists hold pairs within r_c + skin and are rebuilt when a particle has moved more than "
      "skin/2")
        .above(0);
  }
};

// Max over i of f(i), computed by the backend (deterministic: max is order-independent).
template <class F>
using MaxLoop = std::uint32_t (*)(std::size_t n, const F& f, CUstream_st* stream);

// Stable sort of particles by cell: order[] (particle indices, cell-major) and, per cell,
// [cell_start, cell_end) in order[] (empty cells: start == end).
using CellSort = void (*)(std::size_t n, std::uint32_t ncells, const std::uint32_t* cell, std::uint32_t* order,
                          std::uint32_t* cell_start, std::uint32_t* cell_end, CUstream_st* stream);

template <class R, int D>
struct VerletLoopsD {
  ElementLoop<AssignCell<R, D>> assign;
  ElementLoop<BuildList<R, D>> build;
  MaxLoop<MovedTooFar<R, D>> moved;
};

template <class R>
struct VerletLoops {
  VerletLoopsD<R, 2> d2;
  VerletLoopsD<R, 3> d3;
  MaxLoop<CountOf> max_count;
  CellSort sort;
};

// The loops of each backend (cpu.cpp, cuda.cu).
template <class R>
VerletLoops<R> verlet_loops(CpuExec);
template <class R>
VerletLoops<R> verlet_loops(CudaExec);

template <class R>
class Verlet final : public Stage {
 public:
  static StageDecl declaration() {
    return {"neighbors.verlet",
            "cell list + Verlet list (fields neighbors.list/count), rebuilt when a particle moved > skin/2",
            schema_of<VerletParams>(), {2, 3}, false};
  }

  template <class Exec>
  Verlet(const ParamValues& v, const RunInfo&, Exec)
      : p_(params_from<VerletParams>(v)), where_(Exec::where), loops_(verlet_loops<R>(Exec{})) {}

  std::vector<Access> accesses() const override {
    std::vector<Access> a{{fields::position, where_, Mode::read}};
    for (const char* f : {kList, kCount, kPositionAtBuild, kOrder, kCell, kCellStart, kCellEnd})
      a.push_back({f, where_, Mode::readwrite});
    return a;
  }

  void configure(State& s) override {
    const double rl = p_.cutoff + p_.skin;
    double lmin = s.box.L[0];
    for (int k = 0; k < s.dim(); ++k) {
      if (!(s.box.L[k] > 0)) throw InputError("neighbors.verlet: the box has no size along axis " + std::to_string(k));
      lmin = std::min(lmin, s.box.L[k]);
    }
    if (2 * rl > lmin)
      throw InputError("neighbors.verlet: cutoff + skin = " + std::to_string(rl) +
                       " is more than half the smallest box edge (" + std::to_string(lmin) +
                       "); the minimum image would miss pairs: use a larger box or a smaller cutoff/skin");
    // Cells of edge >= r_list; at most ~4 cells per particle so empty cells cost little.
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
    const std::size_t ncells = std::size_t(grid_nc_[0]) * grid_nc_[1] * grid_nc_[2];

    const std::size_t n = s.n();
    if (s.has_field(kList)) throw InputError("neighbors.verlet: only one neighbors.verlet stage may run per pipeline");
    s.add_field(kList, DType::u32, 1, n * initial_capacity(s, rl));
    s.add_particle_field(kCount, DType::u32, 1);
    s.add_particle_field(kPositionAtBuild, s.real(), s.dim());
    s.add_particle_field(kOrder, DType::u32, 1);
    s.add_particle_field(kCell, DType::u32, 1);
    s.add_field(kCellStart, DType::u32, 1, ncells);
    s.add_field(kCellEnd, DType::u32, 1, ncells);
    Field& cut = s.add_field(kCutoff, s.real(), 1, 1);
    cut.acquire(Where::host, Mode::write);
    cut.host<R>()[0] = R(p_.cutoff);
  }

  Outcome run(StepContext& ctx) override {
    if (ctx.state.dim() == 2) return run_d<2>(ctx);
    return run_d<3>(ctx);
  }

 private:
  // Expected neighbours at the mean density, with room for clusters; grown when exceeded.
  static std::uint32_t initial_capacity(const State& s, double rl) {
    const double density = double(s.n()) / s.box.volume();
    constexpr double pi = 3.14159265358979323846;
    const double ball = s.dim() == 2 ? pi * rl * rl : 4.0 / 3.0 * pi * rl * rl * rl;
    const double expected = density * ball;
    return std::uint32_t(std::ceil(expected * 1.5)) + 8;
  }

  template <class T>
  T* ptr(Field& f) const { return where_ == Where::device ? f.device<T>() : f.host<T>(); }

  template <int D>
  const VerletLoopsD<R, D>& loops_d() const {
    if constexpr (D == 2) return loops_.d2;
    else return loops_.d3;
  }

  template <int D>
  Outcome run_d(StepContext& ctx) {
    State& s = ctx.state;
    const std::size_t n = s.n();
    const auto box = PeriodicBox<R>::make(s.box.L);
    const R* x = ptr<R>(s.field(fields::position));
    R* at_build = ptr<R>(s.field(kPositionAtBuild));
    const auto& L = loops_d<D>();

    bool rebuild = !built_;
    if (!rebuild) {
      const R half = R(0.5 * p_.skin);
      rebuild = L.moved(n, MovedTooFar<R, D>{x, at_build, box, half * half}, ctx.stream) != 0;
    }
    if (rebuild) build<D>(ctx, box, x, at_build);
    ctx.metrics.set("rebuilds", rebuild ? 1.0 : 0.0);
    ctx.metrics.set("max_neighbors", double(max_neighbors_));
    return Outcome::ok();
  }

  template <int D>
  void build(StepContext& ctx, const PeriodicBox<R>& box, const R* x, R* at_build) {
    State& s = ctx.state;
    const std::size_t n = s.n();
    const auto& L = loops_d<D>();
    Grid<R, D> grid{box, {grid_nc_[0], grid_nc_[1], grid_nc_[2]}};
    std::uint32_t* cell = ptr<std::uint32_t>(s.field(kCell));
    std::uint32_t* order = ptr<std::uint32_t>(s.field(kOrder));
    Field& start_f = s.field(kCellStart);
    std::uint32_t* start = ptr<std::uint32_t>(start_f);
    std::uint32_t* end = ptr<std::uint32_t>(s.field(kCellEnd));
    std::uint32_t* count = ptr<std::uint32_t>(s.field(kCount));
    L.assign(n, AssignCell<R, D>{x, cell, grid}, ctx.stream);
    loops_.sort(n, std::uint32_t(start_f.count()), cell, order, start, end, ctx.stream);

    Field& list = s.field(kList);
    for (;;) {
      const std::uint32_t cap = list_capacity(s);
      BuildList<R, D> f{x, order, start, end, grid, R((p_.cutoff + p_.skin) * (p_.cutoff + p_.skin)),
                        cap, ptr<std::uint32_t>(list), count, at_build};
      L.build(n, f, ctx.stream);
      max_neighbors_ = n ? loops_.max_count(n, CountOf{count}, ctx.stream) : 0;
      if (max_neighbors_ <= cap) break;
      // Grow with a margin so a slowly densifying system does not reallocate every build.
      const std::uint32_t grown = max_neighbors_ + max_neighbors_ / 4 + 8;
      list.resize(n * grown);
      list.acquire(where_, Mode::write, ctx.stream);
    }
    built_ = true;
  }

  VerletParams p_;
  Where where_;
  VerletLoops<R> loops_;
  int grid_nc_[3] = {1, 1, 1};
  bool built_ = false;
  std::uint32_t max_neighbors_ = 0;
};

}  // namespace ff::neighbors

FLIPFLOW_STAGE(ff::neighbors::Verlet)
