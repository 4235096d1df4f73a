// The Verlet list as other stages see it: plain State fields, so both backends, the rollback
// snapshot and any stage (forces, observers) use the same data. Written by neighbors.verlet.
//
//   neighbors.list    u32, N x capacity (components 1, count N·capacity): row i holds the
//                     neighbours of i in ascending index order; only the first count[i] are set
//   neighbors.count   u32, N: how many entries of row i are set (≤ capacity)
//   neighbors.cutoff  real, 1 value: every pair closer than this is in the list (the stage's
//                     `cutoff`; pairs up to cutoff + skin may be there too, so test distances)
//   neighbors.build_params  f64, 2 values: the stage's `cutoff` and `skin` as given, in every
//                     precision. The list is complete for pairs closer than the cutoff while no
//                     particle has moved skin/2 since the build; a stage that moves particles
//                     after the build checks that and rebuilds the same list (verlet/build.h)
//   neighbors.moved   u64, 2 values, on the host: the rebuild test answered ahead by the stage
//                     that moved the particles last (overdamped.integrate with max_step: in its
//                     loop and its counters' read-back, so neighbors.verlet needs no pass over
//                     the positions, and on CUDA no kernel and no wait of its own): [0] the position field's Field::version()
//                     right after that write (0: nothing published), [1] 1 when some particle is
//                     then farther than skin/2 (minimum image) from its position at build, else
//                     0. neighbors.verlet takes [1] as its test while the positions' version is
//                     still [0] (no stage wrote them since; the build positions change only with
//                     the list, whose builders write the positions too or run before the test)
//
// Because each row is sorted by particle index, a stage that sums over a row in list order,
// skipping pairs beyond its cutoff, adds the same terms in the same order whenever the list was
// built: results do not depend on when rebuilds happen (restarts, Δt changes, rollbacks).
// nvcc-clean.
#pragma once
#include <cstdint>

#include "core/stage/state.h"

namespace ff::neighbors {

inline constexpr const char* kList = "neighbors.list";
inline constexpr const char* kCount = "neighbors.count";
inline constexpr const char* kCutoff = "neighbors.cutoff";
inline constexpr const char* kBuildParams = "neighbors.build_params";
inline constexpr const char* kPositionAtBuild = "neighbors.position_at_build";  // real x dim
inline constexpr const char* kOrder = "neighbors.order";            // u32: particles sorted by cell
inline constexpr const char* kCell = "neighbors.cell";              // u32: cell of each particle at build
inline constexpr const char* kCellStart = "neighbors.cell_start";   // u32 per cell: first slot in order
inline constexpr const char* kCellEnd = "neighbors.cell_end";       // u32 per cell: one past the last
inline constexpr const char* kMoved = "neighbors.moved";            // u64 x 2, host: the test answered ahead

// Row length of the list (0 before the first build).
inline std::uint32_t list_capacity(const State& s) {
  return s.n() ? std::uint32_t(s.field(kList).count() / s.n()) : 0;
}

// What a pair loop needs, for either side (host or device pointers).
struct ListView {
  const std::uint32_t* list;
  const std::uint32_t* count;
  std::uint32_t capacity;
};

}  // namespace ff::neighbors
