// CPU loop of overlap_correct (oneTBB): edge passes while many particles move, work lists of
// flagged particles after that.
//
// The particles are cut into tiles of kTile consecutive indices; a tile is one oneTBB task, and
// its edges [3·t0, 3·t1) are its share of an edge pass. An iteration is one of two kinds:
//   - edge pass (iteration 0, and each iteration after one that moved at least n / kEdgeMode
//     particles): stream over the 3N edge records, each pair once; an overlapping edge counts
//     its pair and adds its push (kernel.h, fixed point: +q on one end, −q on the other) to
//     both ends: directly to an end in the tile's own particles, else through a list: for the
//     tile before or after (taken by that tile when it finishes), or for any other (one thread
//     adds those; ~7 % of them). No atomics: a locked add per push cost more than the edge test.
//     With AVX2 the pass settles four edges at a time where the lanes find them apart (nearly
//     all), lists the others without a branch and takes them one by one after (edge_pass).
//     Each tile lists its touched particles once, with their sums. When the counts say to go
//     on, each tile finishes its touched particles (Overlaps::from_sum) and moves them at once
//     (nothing reads positions then). Iteration 0's pass also checks the mesh (indices in
//     range, no loops, next pointers a permutation). With walls each tile also adds the wall
//     terms of its own particles (a pass over them, after its edges).
//   - work list (otherwise): gather only the flagged particles of each tile (in index order,
//     the flags cleared as they are read), flagged for iteration k + 1 by iteration k:
//       - each particle that had an overlapping edge but did not move (d = 0);
//       - after the apply, both ends of each edge of a moved particle that overlaps at the new
//         positions (tested with r² < σ²·(1 + 1e-9), so rounding can only add particles), and
//         a moved particle that overlaps a wall.
//     An edge that overlaps at k + 1 either has a moved end (then it is tested after the apply)
//     or had both ends fixed, so it overlapped at k already and both ends were flagged.
// Either way every particle left out would have gathered d = 0 and no pairs, and the sums are
// exact integers: the same result as gathering every particle, for any thread count and as on
// the GPU. Which kind an iteration is depends only on counts, never on the threads. The apply
// touches only the moved particles.
//
// Counters: each tile sums its own (plain integers), the host adds the tiles up; integer sums
// do not depend on the order. No allocation after the workspace is made (once, and again when N
// changes).
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/partitioner.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <type_traits>
#include <vector>
#if defined(__AVX2__)
#include <immintrin.h>
#endif

#include "core/backend/exec_cpu.h"
#include "stages/overlap_correct/stage.h"

namespace ff::overlap {

namespace {

// Particles per task: small enough that the flagged particles of later iterations (a few % of N,
// unevenly spread) balance over the threads, large enough that a task's share of a full pass
// outweighs the cost of scheduling it.
constexpr std::size_t kTile = 2048;
// An iteration after one that moved at least n / kEdgeMode particles is an edge pass: one pass
// over the 3N edges costs about as much as the walks of n / 6 moved particles (the check after
// the apply) and their gathers (measured, hard disks at η = 0.5, 2^16).
constexpr std::size_t kEdgeMode = 8;

// How many touched particles ahead an edge pass's finish prefetches.
constexpr std::size_t kFinishAhead = 8;

// A push for a particle of another tile, from an edge pass.
struct Remote {
  int v;
  std::int64_t qx, qy;
};

// A particle touched in an edge pass and the sum of its pushes.
struct Touched {
  int v;
  std::int64_t qx, qy;
};

struct Tile {
  std::size_t t0 = 0, t1 = 0;    // its particles; its edges in an edge pass are [3·t0, 3·t1)
  std::vector<int> cand;         // this iteration's flagged particles, in index order
  std::vector<int> moved;        // particles with d != 0
  std::vector<double> disp;      // their displacements, 2 per moved particle
  std::size_t nmoved = 0;
  std::vector<Touched> touched;  // an edge pass's touched particles of this tile
  std::size_t ntouched = 0;
  std::vector<Remote> remote[3]; // an edge pass's pushes for the tiles before, after, and others
  std::size_t nremote[3] = {0, 0, 0};
  std::uint64_t c[kCounters];    // this gather's counters
  std::uint64_t next_hash = 0;   // the edge pass's share of the permutation check
};

struct HostWorkspace {
  std::size_t n = 0;
  std::uint64_t next_hash = 0;          // Σ mix(h) over the 6n half-edges (kernel.h)
  std::vector<std::uint8_t> flags[2];   // one byte per particle (+ padding to 8)
  std::vector<std::int32_t> slot;       // per particle: its index in its tile's `touched`, or −1
  std::vector<Tile> tiles;
  bool edge_pass = true;                // the next iteration is an edge pass
  std::size_t last_moved = 0;           // particles the last iteration moved
};

// The workspace for n particles (from scratch).
void prepare(HostWorkspace& w, std::size_t n) {
  w = HostWorkspace{};
  w.n = n;
  w.next_hash = mix_sum(6 * std::uint64_t(n));
  const std::size_t padded = (n + 7) / 8 * 8;
  for (auto& f : w.flags) f.assign(padded, 0);
  w.slot.assign(n, -1);
  const std::size_t nt = (n + kTile - 1) / kTile;
  w.tiles.resize(nt);
  for (std::size_t t = 0; t < nt; ++t) {
    Tile& tl = w.tiles[t];
    tl.t0 = t * kTile;
    tl.t1 = std::min(n, tl.t0 + kTile);
    const std::size_t m = tl.t1 - tl.t0;
    tl.cand.resize(m);
    tl.moved.resize(m);
    tl.disp.resize(2 * m);
    tl.touched.resize(m);
    for (auto& r : tl.remote) r.resize(6 * m);
  }
}

inline void flag(std::uint8_t* f, int v) { __atomic_store_n(f + v, std::uint8_t(1), __ATOMIC_RELAXED); }

// A push for particle v of tile tl (only tl's own task, or the one thread adding the remote
// pushes, writes there): lists v when it is new, adds the push to its sum.
inline void deposit(std::int32_t* slot, Tile& tl, int v, std::int64_t qx, std::int64_t qy) {
  std::int32_t& i = slot[std::size_t(v)];
  if (i < 0) {
    i = std::int32_t(tl.ntouched++);
    tl.touched[std::size_t(i)] = Touched{v, 0, 0};
  }
  Touched& p = tl.touched[std::size_t(i)];
  p.qx += qx;
  p.qy += qy;
}

// The flagged particles of [t0, t1) into cand, in index order; clears those flags. Returns the
// count. t0 is a multiple of 8 and the flag array is padded to 8 (padding is never set).
std::size_t compact(std::uint8_t* flags, std::size_t t0, std::size_t t1, int* cand) {
  std::size_t count = 0;
  for (std::size_t b = t0; b < t1; b += 8) {
    std::uint64_t word;
    std::memcpy(&word, flags + b, 8);
    if (!word) continue;
    std::memset(flags + b, 0, 8);
    while (word) {
      const int bit = __builtin_ctzll(word);
      cand[count++] = int(b + std::size_t(bit >> 3));
      word &= word - 1;  // bytes are 0 or 1: one set bit per flagged byte
    }
  }
  return count;
}

// Marks v as touched in this step (the touched field); returns 1 when it was not yet.
inline std::uint64_t touch(std::uint8_t* touched, int v) {
  if (touched[v]) return 0;
  touched[v] = 1;
  return 1;
}

// Below this many particles moved in the iteration before, the work of a work-list iteration
// is a few hundred walks: one thread does it, sparing the threads' start-up, which costs more
// than that work (three loops per iteration, iterations 3+ at η = 0.5).
constexpr std::size_t kSerial = 2048;

template <class F>
void for_each_tile(std::size_t nt, const F& f, bool serial = false) {
  if (nt == 1 || serial) {
    for (std::size_t t = 0; t < nt; ++t) f(t);
    return;
  }
  if (nt == 1) {
    f(std::size_t(0));
    return;
  }
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, nt, 1),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t t = r.begin(); t != r.end(); ++t) f(t);
      },
      tbb::simple_partitioner());
}

#if defined(__AVX2__)
// Four edges at a time (AVX2): nearly all edges of a pass are apart (at η = 0.5 about one in 18
// overlaps in iteration 0, one in 60 in iteration 1), and settling those four to a vector is
// cheaper than the scalar test's branch per edge. Only the outcome "apart" is decided here, by
// Overlaps::edge's own test with its operations in its order (no fma in this file): both
// components within a quarter box and !(r² < reach²); any other edge goes through edge().
//
// Edge e's record {a, na, b, nb} (kernel.h, load_edge), four of them in two vectors.
struct EdgeQuad {
  __m256i r01, r23;  // the records of edges e, e + 1 and e + 2, e + 3
};
inline EdgeQuad load_edge_quad(const std::int32_t* he, std::size_t e) {
  return {_mm256_loadu_si256(reinterpret_cast<const __m256i*>(he + 4 * e)),
          _mm256_loadu_si256(reinterpret_cast<const __m256i*>(he + 4 * e + 8))};
}

// Whether all four records pass edge()'s index checks: a, b < n and a != b, and with Check
// na, nb < 6n. lim holds {n − 1, 6n − 1 (or ~0 without Check), n − 1, 6n − 1} twice.
inline bool edge_quad_valid(const EdgeQuad& q, __m256i lim) {
  const __m256i ok01 = _mm256_cmpeq_epi32(_mm256_min_epu32(q.r01, lim), q.r01);
  const __m256i ok23 = _mm256_cmpeq_epi32(_mm256_min_epu32(q.r23, lim), q.r23);
  // a == b: the record with its 64-bit halves swapped compares equal in the a lane.
  const __m256i loop01 = _mm256_cmpeq_epi32(_mm256_shuffle_epi32(q.r01, _MM_SHUFFLE(1, 0, 3, 2)), q.r01);
  const __m256i loop23 = _mm256_cmpeq_epi32(_mm256_shuffle_epi32(q.r23, _MM_SHUFFLE(1, 0, 3, 2)), q.r23);
  const __m256i bad = _mm256_or_si256(_mm256_andnot_si256(ok01, _mm256_set1_epi32(-1)),
                                      _mm256_andnot_si256(ok23, _mm256_set1_epi32(-1)));
  // only the a lanes (0 and 4) of the loop tests count: the others compare na with nb
  const __m256i a_lanes = _mm256_setr_epi32(-1, 0, 0, 0, -1, 0, 0, 0);
  const __m256i loops = _mm256_and_si256(_mm256_or_si256(loop01, loop23), a_lanes);
  return _mm256_testz_si256(_mm256_or_si256(bad, loops), _mm256_or_si256(bad, loops)) != 0;
}

// Σ mix(na) + mix(nb) over the four records (the permutation check's terms, kernel.h's mix, in
// 64-bit lanes: x·C mod 2^64 = x·C_lo + (x·C_hi mod 2^32)·2^32 for 32-bit x), added to acc.
inline __m256i add_next_mix(const EdgeQuad& q, __m256i acc) {
  const __m256i c_lo = _mm256_set1_epi64x(0x7f4a7c15), c_hi = _mm256_set1_epi64x(0x9e3779b9);
  for (const __m256i r : {q.r01, q.r23}) {
    const __m256i x = _mm256_srli_epi64(r, 32);  // na, nb zero-extended
    const __m256i p = _mm256_add_epi64(_mm256_mul_epu32(x, c_lo), _mm256_slli_epi64(_mm256_mul_epu32(x, c_hi), 32));
    acc = _mm256_add_epi64(acc, _mm256_xor_si256(p, _mm256_srli_epi64(p, 29)));
  }
  return acc;
}

// Point i's (x, y) in double (exact for float positions, as load_xy converts them).
inline __m128d load_xy2(const double* p, int i) { return _mm_loadu_pd(p + 2 * i); }
inline __m128d load_xy2(const float* p, int i) {
  return _mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p + 2 * i))));
}

// Bit k set: edge e + k is apart, exactly as edge() would find (valid records assumed).
template <class R>
__attribute__((always_inline)) inline int apart4(const R* pos, const std::int32_t* he, std::size_t e, __m256d quarter_x, __m256d quarter_y,
                  __m256d reach2) {
  const std::int32_t* r = he + 4 * e;
  const __m256d a02 = _mm256_insertf128_pd(_mm256_castpd128_pd256(load_xy2(pos, r[0])), load_xy2(pos, r[8]), 1);
  const __m256d a13 = _mm256_insertf128_pd(_mm256_castpd128_pd256(load_xy2(pos, r[4])), load_xy2(pos, r[12]), 1);
  const __m256d b02 = _mm256_insertf128_pd(_mm256_castpd128_pd256(load_xy2(pos, r[2])), load_xy2(pos, r[10]), 1);
  const __m256d b13 = _mm256_insertf128_pd(_mm256_castpd128_pd256(load_xy2(pos, r[6])), load_xy2(pos, r[14]), 1);
  // lanes in edge order: unpacklo of (0, 2 | 1, 3) gives (x0, x1 | x2, x3)
  const __m256d rx = _mm256_sub_pd(_mm256_unpacklo_pd(b02, b13), _mm256_unpacklo_pd(a02, a13));
  const __m256d ry = _mm256_sub_pd(_mm256_unpackhi_pd(b02, b13), _mm256_unpackhi_pd(a02, a13));
  const __m256d sign = _mm256_set1_pd(-0.0);
  const __m256d near = _mm256_and_pd(_mm256_cmp_pd(_mm256_andnot_pd(sign, rx), quarter_x, _CMP_LE_OQ),
                                     _mm256_cmp_pd(_mm256_andnot_pd(sign, ry), quarter_y, _CMP_LE_OQ));
  const __m256d r2 = _mm256_add_pd(_mm256_mul_pd(rx, rx), _mm256_mul_pd(ry, ry));
  return _mm256_movemask_pd(_mm256_and_pd(near, _mm256_cmp_pd(r2, reach2, _CMP_NLT_UQ)));
}
#endif

// One tile's share of an edge pass (Check: iteration 0, with the mesh checks): adds the pushes
// of its overlapping edges to its own particles and lists the others', counts pairs into tl.c.
template <bool Check, class R, bool Walls>
__attribute__((flatten)) void edge_pass(const Overlaps<R, Walls>& ov, Tile& tl, std::int32_t* slot) {
  const Overlaps<R, Walls> m = ov;  // a local copy: the stores below cannot alias its fields
  std::uint64_t pairs = 0, bad = 0, broken = 0, hash = 0;
  const unsigned t0 = unsigned(tl.t0), size = unsigned(tl.t1 - tl.t0);
  tl.ntouched = 0;
  std::size_t nremote[3] = {0, 0, 0};
  auto add = [&](int v, std::int64_t qx, std::int64_t qy) {
    if (unsigned(v) - t0 < size) {
      deposit(slot, tl, v, qx, qy);
    } else {
      const int side = unsigned(v) + kTile - t0 < kTile ? 0 : unsigned(v) - t0 - size < kTile ? 1 : 2;
      tl.remote[side][nremote[side]++] = Remote{v, qx, qy};
    }
  };
  // Edge e, settled by the scalar test (C: with the mesh checks).
  auto one = [&](std::size_t e, auto check) {
    int a, b;
    std::int64_t qx, qy;
    PairOverlap o;
    const int r = m.template edge<decltype(check)::value>(e, a, b, qx, qy, o, hash);
    if (r == kEdgeApart) return;
    if (r == kEdgeCorrupt) {
      ++broken;
      return;
    }
    if (counted(o)) {
      ++pairs;
      if (o == kBeyond) ++bad;
    }
    add(a, qx, qy);
    add(b, -qx, -qy);
  };
  std::size_t e = 3 * tl.t0;
  const std::size_t e1 = 3 * tl.t1;
#if defined(__AVX2__)
  {
    const unsigned n = unsigned(m.n);
    const int lim_next = Check ? int(6u * n - 1u) : -1;
    const __m256i lim = _mm256_setr_epi32(int(n - 1u), lim_next, int(n - 1u), lim_next, int(n - 1u), lim_next,
                                          int(n - 1u), lim_next);
    const __m256d quarter_x = _mm256_set1_pd(0.25 * m.box.L[0]), quarter_y = _mm256_set1_pd(0.25 * m.box.L[1]);
    const __m256d reach2 = _mm256_set1_pd(m.reach2);
    __m256i mixes = _mm256_setzero_si256();
    // The edges left over, listed without a branch on the outcome and then taken in a second loop
    // of mostly overlapping edges, so that neither loop mispredicts at every overlap.
    constexpr std::size_t kBuffer = 256;
    std::uint32_t left[kBuffer + 4];
    std::size_t nleft = 0;
    auto drain = [&] {
      for (std::size_t i = 0; i < nleft; ++i) one(left[i], std::false_type{});
      nleft = 0;
    };
    for (; e + 4 <= e1; e += 4) {
      const EdgeQuad q = load_edge_quad(m.he, e);
      if (!edge_quad_valid(q, lim)) {  // a corrupt record: every check on the scalar path
        drain();  // (edges in order, as the scalar loop takes them)
        for (std::size_t k = 0; k < 4; ++k) one(e + k, std::integral_constant<bool, Check>{});
        continue;
      }
      if (Check) mixes = add_next_mix(q, mixes);
      const unsigned rest = ~unsigned(apart4(m.pos, m.he, e, quarter_x, quarter_y, reach2));
      // valid records: edge() without the checks gives edge<Check>()'s answer
      for (unsigned k = 0; k < 4; ++k) {
        left[nleft] = std::uint32_t(e + k);
        nleft += rest >> k & 1u;
      }
      if (nleft >= kBuffer) drain();
    }
    drain();
    if (Check) {
      alignas(32) std::uint64_t lanes[4];
      _mm256_store_si256(reinterpret_cast<__m256i*>(lanes), mixes);
      hash += lanes[0] + lanes[1] + lanes[2] + lanes[3];
    }
  }
#endif
  for (; e < e1; ++e) one(e, std::integral_constant<bool, Check>{});
  if constexpr (Walls)  // the walls: a term per particle of the tile, deposited like an edge's
    for (std::size_t v = tl.t0; v < tl.t1; ++v) {
      double x, y;
      load_xy(m.pos, int(v), x, y);
      VertexPush w;
      std::int64_t qx = 0, qy = 0;
      m.gather_wall(int(v), x, y, m.diameter_of(int(v)), qx, qy, w);
      if (!w.touched) continue;
      pairs += w.pairs;
      bad += w.bad;
      deposit(slot, tl, int(v), qx, qy);
    }
  for (int q = 0; q < 3; ++q) tl.nremote[q] = nremote[q];
  tl.c[kBad] = bad;
  tl.c[kPairs] = pairs;
  tl.c[kCorrection] = 0;
  tl.c[kBroken] = broken;
  tl.c[kTouched] = 0;
  tl.next_hash = hash;
}

// Walls: the wall code compiled in (walls: x | y); Mark: the touched field written (mark: true).
template <bool Walls, bool Mark, class R>
void host_iterate(HostWorkspace* w, const Problem<R>& p, std::int64_t k0, std::int64_t max_iterations, Batch& out) {
  const Overlaps<R, Walls> ov = p.overlaps.template with_walls<Walls>();
  const std::size_t nt = w->tiles.size();
  // A step starts from clean flags (cheap; also covers a step that ended in an error).
  if (k0 == 0) {
    for (auto& f : w->flags) std::memset(f.data(), 0, f.size());
    if (Mark) std::memset(p.touched, 0, p.n);
    w->edge_pass = true;
    w->last_moved = w->n;
  }
  out.gathers = 0;
  for (int j = 0; j < kBatch; ++j) {
    const std::int64_t k = k0 + j;
    std::uint8_t* cur = w->flags[k & 1].data();
    std::uint8_t* next = w->flags[(k + 1) & 1].data();
    const bool edge = w->edge_pass;

    std::uint64_t* c = out.counters[j];
    std::memset(c, 0, kCounters * sizeof(std::uint64_t));
    out.gathers = j + 1;
    if (edge) {
      for_each_tile(nt, [&](std::size_t t) {
        if (k == 0)
          edge_pass<true>(ov, w->tiles[t], w->slot.data());
        else
          edge_pass<false>(ov, w->tiles[t], w->slot.data());
      });
      std::uint64_t hash = 0;
      for (const Tile& tl : w->tiles) {
        for (int q = 0; q < kCounters; ++q) c[q] += tl.c[q];
        hash += tl.next_hash;
      }
      if (k == 0 && hash != w->next_hash) ++c[kBroken];  // next is not a permutation
      for (const Tile& tl : w->tiles)  // pushes for tiles that are not neighbours: one thread
        for (std::size_t i = 0; i < tl.nremote[2]; ++i) {
          const Remote& r = tl.remote[2][i];
          deposit(w->slot.data(), w->tiles[std::size_t(r.v) / kTile], r.v, r.qx, r.qy);
        }
      const bool go = keeps_going(c, k, max_iterations);
      // Each tile takes its neighbours' pushes for it, then finishes its touched particles (and
      // moves them, when going on); clears their slots.
      for_each_tile(nt, [&](std::size_t t) {
        Tile& tl = w->tiles[t];
        for (int side = 0; side < 2; ++side) {
          const std::size_t from = side == 0 ? t + 1 : t - 1;  // tile t is its side 0 or 1
          if (from >= nt) continue;
          const Tile& o = w->tiles[from];
          for (std::size_t i = 0; i < o.nremote[side]; ++i)
            deposit(w->slot.data(), tl, o.remote[side][i].v, o.remote[side][i].qx, o.remote[side][i].qy);
        }
        std::uint64_t corr = 0, first = 0;
        std::size_t nm = 0;
        for (std::size_t i = 0; i < tl.ntouched; ++i) {
          const Touched& tp = tl.touched[i];
          // The tile's particles left the cache while the other tiles were passed: ask for the
          // position and image a few particles ahead of the apply.
          if (i + kFinishAhead < tl.ntouched) {
            const std::size_t u = std::size_t(tl.touched[i + kFinishAhead].v);
            __builtin_prefetch(p.pos + 2 * u, 1);
            __builtin_prefetch(p.image + 2 * u, 1);
          }
          w->slot[std::size_t(tp.v)] = -1;
          if constexpr (Mark) first += touch(p.touched, tp.v);
          if (!go) continue;
          const VertexPush q = ov.from_sum(tp.v, tp.qx, tp.qy);
          corr += ov.fixed_len(q.len);
          if (q.dx != 0 || q.dy != 0) {
            apply_one(p.pos, p.image, p.box, std::size_t(tp.v), q.dx, q.dy);
            tl.moved[nm++] = tp.v;
          } else {
            flag(next, tp.v);  // overlapping, not moved
          }
        }
        tl.c[kCorrection] = corr;
        tl.c[kTouched] = first;
        tl.nmoved = nm;
        std::memset(cur + tl.t0, 0, tl.t1 - tl.t0);  // an edge pass finds every candidate itself
      });
      for (const Tile& tl : w->tiles) c[kTouched] += tl.c[kTouched];
      if (!go) return;
      for (const Tile& tl : w->tiles) c[kCorrection] += tl.c[kCorrection];
    } else {
      const bool serial = w->last_moved < kSerial;
      for_each_tile(nt, [&](std::size_t t) {
        Tile& tl = w->tiles[t];
        std::uint64_t tc[kCounters] = {};
        std::size_t nm = 0;
        const std::size_t count = compact(cur, tl.t0, tl.t1, tl.cand.data());
        for (std::size_t i = 0; i < count; ++i) {
          const int v = tl.cand[i];
          const VertexPush q = ov.gather(v);
          tc[kBad] += q.bad;
          tc[kPairs] += q.pairs;
          tc[kBroken] += q.broken;
          if (!q.touched) continue;  // d = 0, len = 0
          if constexpr (Mark) tc[kTouched] += touch(p.touched, v);
          tc[kCorrection] += ov.fixed_len(q.len);
          if (q.dx != 0 || q.dy != 0) {
            tl.moved[nm] = v;
            tl.disp[2 * nm] = q.dx;
            tl.disp[2 * nm + 1] = q.dy;
            ++nm;
          } else {
            flag(next, v);  // overlapping, not moved
          }
        }
        std::memcpy(tl.c, tc, sizeof tc);
        tl.nmoved = nm;
      }, serial);
      for (const Tile& tl : w->tiles)
        for (int q = 0; q < kCounters; ++q) c[q] += tl.c[q];
      if (!keeps_going(c, k, max_iterations)) return;
      for_each_tile(nt, [&](std::size_t t) {
        const Tile& tl = w->tiles[t];
        for (std::size_t i = 0, nm = tl.nmoved; i < nm; ++i)
          apply_one(p.pos, p.image, p.box, std::size_t(tl.moved[i]), tl.disp[2 * i], tl.disp[2 * i + 1]);
      }, serial);
    }
    std::size_t moved = 0;
    for (const Tile& tl : w->tiles) moved += tl.nmoved;
    w->last_moved = moved;
    w->edge_pass = moved >= w->n / kEdgeMode;
    if (w->edge_pass) continue;  // it finds every overlapping edge itself
    // Flag both ends of each edge of a moved particle that overlaps now (a little beyond the
    // gather's own test r² < σ², so rounding can only add particles, never leave one out).
    const bool serial = moved < kSerial;
    for_each_tile(nt, [&](std::size_t t) {
      const Tile& tl = w->tiles[t];
      for (std::size_t i = 0, nm = tl.nmoved; i < nm; ++i) {
        const int v = tl.moved[i];
        if (ov.overlapping_neighbors(v, [&](int u) { flag(next, u); })) flag(next, v);
      }
    }, serial);
  }
}

template <class R>
class HostLoops final : public OverlapCorrectLoops<R> {
 public:
  // The host runs the gathers in start() (kBatch of them at most) and finish() has nothing to wait for.
  void start(const Problem<R>& p, std::int64_t k0, std::int64_t max_iterations, Batch& out, CUstream_st*) override {
    if (!made_ || ws_.n != p.n) {
      prepare(ws_, p.n);
      made_ = true;
    }
    const bool walls = p.overlaps.wall_axis >= 0, mark = p.touched != nullptr;
    if (walls && mark)
      host_iterate<true, true>(&ws_, p, k0, max_iterations, out);
    else if (walls)
      host_iterate<true, false>(&ws_, p, k0, max_iterations, out);
    else if (mark)
      host_iterate<false, true>(&ws_, p, k0, max_iterations, out);
    else
      host_iterate<false, false>(&ws_, p, k0, max_iterations, out);
  }
  void finish(Batch&) override {}
  int max_gathers() const override { return kBatch; }

 private:
  HostWorkspace ws_;
  bool made_ = false;
};

}  // namespace

template <class R>
std::unique_ptr<OverlapCorrectLoops<R>> overlap_correct_loops(CpuExec) {
  return std::make_unique<HostLoops<R>>();
}
template std::unique_ptr<OverlapCorrectLoops<float>> overlap_correct_loops<float>(CpuExec);
template std::unique_ptr<OverlapCorrectLoops<double>> overlap_correct_loops<double>(CpuExec);

}  // namespace ff::overlap
