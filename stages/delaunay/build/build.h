// Building the topology fields from the current positions (host, through CGAL: cgal.cpp).
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/stage/state.h"
#include "stages/delaunay/common/hilbert.h"

namespace ff::delaunay {

struct HalfEdges {
  std::vector<std::int32_t> he;     // 2 x 6N: origin, next
  std::vector<std::int32_t> vedge;  // N
};

// Half-edges from 2N CCW triangles of a periodic triangulation of n vertices. Edge ids follow
// the sorted (lower, higher) pairs of the endpoints' `rank` (a permutation of 0..n-1; the vertex
// ids themselves when null); half-edge 2e leaves the endpoint of lower rank.
// vedge[v] is the lowest half-edge leaving v. RunError if the triangles are not a triangulation
// of the torus.
HalfEdges assemble(const std::vector<std::array<int, 3>>& triangles, std::size_t n,
                   const std::vector<std::int32_t>* rank = nullptr);


// Triangulates the current positions and fills every topology field: halfedge, opposite, vertex_edge,
// position_prev (= position) and status (built, nothing pending). Host side; `stream` is used
// only to bring positions to the host. Returns how the triangles were obtained.
std::string build_topology(State& s, CUstream_st* stream);
// Same for the positions in `positions` (a field like `position`: real x 2, count N), which
// also become position_prev: detect_inversion rebuilds for the positions a step started from
// when the triangulation it inherited is not valid for them.
std::string build_topology(State& s, Field& positions, CUstream_st* stream);

}  // namespace ff::delaunay
