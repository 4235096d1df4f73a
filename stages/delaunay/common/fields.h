// The topology fields of the delaunay stages and the small status record they share.
// Everything is a State field, so snapshots (rollback), host/device copies and checkpoints
// treat the triangulation like particle data. nvcc-clean.
#pragma once
#include <cstddef>
#include <cstdint>

namespace ff::delaunay {

namespace fields {
// i32 x 2, count 6N (half-edges): {origin vertex, next half-edge CCW in the same triangle}.
// Half-edges 2e and 2e+1 are the two sides of edge e (twin(h) = h ^ 1).
inline constexpr const char* halfedge = "delaunay.halfedge";
// i32, count 6N (half-edges): the vertex opposite half-edge h in its triangle,
// origin(next(next(h))). Redundant with `halfedge` and kept by every flip (flip_edge), so the
// per-edge loops read an edge's quad a, b, c, d from records 2e and 2e+1 of both fields, in
// edge order, instead of chasing next pointers to scattered half-edges.
inline constexpr const char* opposite = "delaunay.opposite";
// i32 x 1, count N: one half-edge leaving each vertex (for walks around a vertex).
inline constexpr const char* vertex_edge = "delaunay.vertex_edge";
// real x 2, count N: the positions at which the triangulation was last known valid (written by
// delaunay.build and, at the end of an accepted detection, by delaunay.detect_inversion).
inline constexpr const char* position_prev = "delaunay.position_prev";
// u8, count 3N (edges): 1 = flipping this edge repairs an inverted triangle (detect -> flip).
inline constexpr const char* flip_mark = "delaunay.flip_mark";
// i32 x kStatusSize, count 1, host only: see Status below.
inline constexpr const char* status = "delaunay.status";
// i32, count candidate_capacity(N): edges that delaunay.detect_inversion found not locally
// Delaunay (in-circle > 0, flip keeps both triangles positive), a superset of what
// delaunay.lawson's first round would mark; valid while status kCandidates says so.
inline constexpr const char* lawson_candidates = "delaunay.lawson_candidates";
// i32, count 1: how many edges delaunay.lawson_candidates holds, written on the device by
// detect_inversion's kernel when it decides the attempt there (StepContext::gate) for
// delaunay.lawson's gated launch, which cannot wait for the host's status kCandidates (0 when
// the kernel closed the gate).
inline constexpr const char* lawson_candidate_count = "delaunay.lawson_candidate_count";
}  // namespace fields

// status kCandidates in a device-decided attempt: the list is valid when detect_inversion's
// kernel opened the gate, its length in lawson_candidate_count.
inline constexpr std::int32_t kCandidatesOnDevice = -1;

// Components of the `delaunay.status` field.
enum Status : int {
  kBuilt = 0,    // 1 once a triangulation exists (0: the first topology stage builds one)
  kPending = 1,  // repair flips marked by detect_inversion and not yet done by delaunay.flip
  // 1 + the number of edges in delaunay.lawson_candidates when that list holds every edge that
  // is not locally Delaunay for the current topology and for the positions detect_inversion
  // saw (of version kPositionVersion*); 0 when no such list exists. detect_inversion sets it,
  // anything else that changes the topology (flip, build) clears it, delaunay.lawson consumes it
  // (testing only those edges in its first round when the positions did not change since);
  // kCandidatesOnDevice in an attempt detect_inversion decides on the device.
  kCandidates = 2,
  // Field::version() of `position` when detect_inversion filled the candidates (low, high 32
  // bits): delaunay.lawson uses the list only if nothing has written the positions since.
  kPositionVersionLo = 3,
  kPositionVersionHi = 4,
  // 1 when delaunay.flip has `on_unrepairable: substep` (set by its configure): then
  // detect_inversion leaves triangles no single flip repairs to delaunay.flip instead of
  // requesting a rollback; 2 when it also has `passing: substep`: then particles that passed
  // each other (an edge vector reversed) are left to it too (else they still roll back).
  kSubstep = 5,
  // 1 when, in that mode, detect_inversion found inverted triangles this step and left
  // position_prev at the positions where the triangulation was valid (delaunay.flip's
  // reference for the intermediate positions); delaunay.flip writes it once the triangulation
  // is valid at the new positions.
  kPrevKept = 6,
  kStatusSize = 7
};

inline void set_position_version(std::int32_t* status, std::uint64_t v) {
  status[kPositionVersionLo] = std::int32_t(std::uint32_t(v));
  status[kPositionVersionHi] = std::int32_t(std::uint32_t(v >> 32));
}
inline std::uint64_t position_version(const std::int32_t* status) {
  return std::uint64_t(std::uint32_t(status[kPositionVersionLo])) |
         (std::uint64_t(std::uint32_t(status[kPositionVersionHi])) << 32);
}

// A periodic triangulation of N points on the torus has N vertices, 3N edges and 2N triangles.
inline std::size_t edge_count(std::size_t n) { return 3 * n; }
inline std::size_t halfedge_count(std::size_t n) { return 6 * n; }
// Room in delaunay.lawson_candidates: a step's non-Delaunay edges are a small fraction of all
// edges; more than this and Lawson's first round simply tests every edge.
inline std::size_t candidate_capacity(std::size_t n) { return edge_count(n) / 16 + 256; }

}  // namespace ff::delaunay
