// Conflict-free parallel flips, shared by delaunay.flip and delaunay.lawson.
//
// A round has three passes over the edges: mark (stage-specific: which edges want a flip),
// decide (below), apply. Two flips conflict when their edges share a triangle, i.e. when one
// edge is among the four edges around the other. The rule "an edge flips when no marked edge
// around it has a lower id" lets the lowest id win both triangles; it depends only on the marks,
// so the result is the same for any thread count, launch order or backend, and the lowest
// marked edge always flips, so every round makes progress. FF_HD; nvcc-clean.
#pragma once
#include <cstdint>

#include "core/backend/atomics.h"
#include "stages/delaunay/common/mesh.h"

namespace ff::delaunay {

// Counter slot of DecideFlips in a stage's counter block.
struct DecideFlips {
  Mesh mesh;
  const std::uint8_t* mark;  // per edge
  std::uint8_t* go;          // per edge: 1 = flip in this round
  unsigned* counters;
  int flips_slot;

  FF_HD void operator()(std::size_t i) const {
    const int e = int(i);
    if (!mark[e]) {
      go[e] = 0;
      return;
    }
    const int h0n = mesh.next(2 * e), h1n = mesh.next(2 * e + 1);
    const int around[4] = {h0n >> 1, mesh.next(h0n) >> 1, h1n >> 1, mesh.next(h1n) >> 1};
    bool win = true;
    for (int k = 0; k < 4; ++k) win = win && !(around[k] < e && mark[around[k]]);
    go[e] = win ? 1 : 0;
    if (win) count_one(counters + flips_slot);
  }
};

struct ApplyFlips {
  Mesh mesh;
  const std::uint8_t* go;

  FF_HD void operator()(std::size_t i) const {
    if (go[i]) flip_edge(mesh, int(i));
  }
};

}  // namespace ff::delaunay
