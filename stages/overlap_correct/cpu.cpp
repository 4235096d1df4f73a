// CPU loop of overlap_correct (oneTBB) with work lists, like the CUDA loop (cuda.cu) but with a
// tighter candidate set.
//
// The particles are cut into tiles of kTile consecutive indices; a tile is one oneTBB task.
// Iteration 0 gathers every particle. Iteration k + 1 gathers only the flagged particles of each
// tile (read in index order, the flags cleared as they are read), flagged in the array of k + 1
// by iteration k:
//   - in the gather, each particle that had an overlapping edge but did not move (d = 0);
//   - after the apply, both ends of each edge of a moved particle that overlaps at the new
//     positions (tested with r² < σ²·(1 + 1e-9), so rounding can only add particles).
// An edge that overlaps at k + 1 either has a moved end (then it is tested after the apply) or
// had both ends fixed, so it overlapped at k already and both ends were flagged in the gather.
// Every particle left out would have gathered d = 0 and no pairs: the same bits as gathering
// every particle, for any thread count and as on the GPU. (The CUDA loop flags every neighbour
// of a moved particle instead: ~75 % of N in iteration 1 at η = 0.5 against ~5 % here, for one
// extra pass over the moved particles' fans.) The apply touches only the moved particles.
//
// Counters: each tile sums its own (plain integers), the host adds the tiles up; integer sums
// do not depend on the order. No allocation after the workspace is made.
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/partitioner.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "stages/overlap_correct/cpu.h"

namespace ff::overlap {

namespace {

// Particles per task: small enough that the flagged particles of later iterations (a few % of N,
// unevenly spread) balance over the threads, large enough that a full gather is ~100 µs a task.
constexpr std::size_t kTile = 2048;

struct Tile {
  std::size_t t0 = 0, t1 = 0;
  std::vector<int> cand;       // this iteration's flagged particles, in index order
  std::vector<int> moved;      // particles with d != 0
  std::vector<double> disp;    // their displacements, 2 per moved particle
  std::size_t nmoved = 0;
  std::uint64_t c[kCounters];  // this gather's counters
};

struct HostWorkspace {
  std::size_t n = 0;
  std::vector<std::uint8_t> flags[2];  // one byte per particle (+ padding to 8)
  std::vector<Tile> tiles;
};

void* host_create(std::size_t n) {
  auto* w = new HostWorkspace;
  w->n = n;
  const std::size_t padded = (n + 7) / 8 * 8;
  for (auto& f : w->flags) f.assign(padded, 0);
  const std::size_t nt = (n + kTile - 1) / kTile;
  w->tiles.resize(nt);
  for (std::size_t t = 0; t < nt; ++t) {
    Tile& tl = w->tiles[t];
    tl.t0 = t * kTile;
    tl.t1 = std::min(n, tl.t0 + kTile);
    const std::size_t m = tl.t1 - tl.t0;
    tl.cand.resize(m);
    tl.moved.resize(m);
    tl.disp.resize(2 * m);
  }
  return w;
}
void host_destroy(void* p) { delete static_cast<HostWorkspace*>(p); }

inline void flag(std::uint8_t* f, int v) { __atomic_store_n(f + v, std::uint8_t(1), __ATOMIC_RELAXED); }

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

constexpr double kLoose = 1 + 1e-9;

template <class F>
void for_each_tile(std::size_t nt, const F& f) {
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

template <class R>
void host_iterate(void* ws, const Problem<R>& p, std::int64_t k0, std::int64_t max_iterations, Batch& out,
                  CUstream_st*) {
  auto* w = static_cast<HostWorkspace*>(ws);
  const Mesh<R>& mesh = p.mesh;
  const std::size_t nt = w->tiles.size();
  // A step starts from clean flags (cheap; also covers a previous step that ended in an error).
  if (k0 == 0)
    for (auto& f : w->flags) std::memset(f.data(), 0, f.size());
  out.gathers = 0;
  for (int j = 0; j < kBatch; ++j) {
    const std::int64_t k = k0 + j;
    std::uint8_t* cur = w->flags[k & 1].data();
    std::uint8_t* next = w->flags[(k + 1) & 1].data();

    for_each_tile(nt, [&](std::size_t t) {
      Tile& tl = w->tiles[t];
      const std::size_t count = k == 0 ? tl.t1 - tl.t0 : compact(cur, tl.t0, tl.t1, tl.cand.data());
      std::uint64_t c[kCounters] = {0, 0, 0, 0};
      std::size_t nm = 0;
      for (std::size_t i = 0; i < count; ++i) {
        const int v = k == 0 ? int(tl.t0 + i) : tl.cand[i];
        const VertexPush q = mesh.gather(v);
        c[kBad] += q.bad;
        c[kPairs] += q.pairs;
        c[kBroken] += q.broken;
        if (!q.touched) continue;  // d = 0, len = 0
        c[kCorrection] += mesh.fixed_len(q.len);
        if (q.dx != 0 || q.dy != 0) {  // its edges are checked after the apply
          tl.moved[nm] = v;
          tl.disp[2 * nm] = q.dx;
          tl.disp[2 * nm + 1] = q.dy;
          ++nm;
        } else {
          flag(next, v);  // overlapping, not moved
        }
      }
      std::memcpy(tl.c, c, sizeof c);
      tl.nmoved = nm;
    });

    std::uint64_t* c = out.counters[j];
    std::memset(c, 0, kCounters * sizeof(std::uint64_t));
    for (const Tile& tl : w->tiles)
      for (int q = 0; q < kCounters; ++q) c[q] += tl.c[q];
    out.gathers = j + 1;
    if (!keeps_going(c, k, max_iterations)) return;

    for_each_tile(nt, [&](std::size_t t) {
      const Tile& tl = w->tiles[t];
      for (std::size_t i = 0, nm = tl.nmoved; i < nm; ++i)
        apply_one(p.pos, p.image, p.box, std::size_t(tl.moved[i]), tl.disp[2 * i], tl.disp[2 * i + 1]);
    });
    // Flag both ends of each edge of a moved particle that overlaps now (a little beyond the
    // gather's own test r² < σ², so rounding can only add particles, never leave one out).
    for_each_tile(nt, [&](std::size_t t) {
      const Tile& tl = w->tiles[t];
      for (std::size_t i = 0, nm = tl.nmoved; i < nm; ++i) {
        const int v = tl.moved[i];
        double xv, yv;
        load_xy(mesh.pos, v, xv, yv);
        const double sv = double(mesh.diameter[v]);
        bool any = false;
        mesh.for_each_neighbour(v, [&](int u, int) {
          double xu, yu;
          load_xy(mesh.pos, u, xu, yu);
          const double rx = mesh.box.min_image(xu - xv, 0);
          const double ry = mesh.box.min_image(yu - yv, 1);
          const double s = 0.5 * (sv + double(mesh.diameter[u]));
          if (rx * rx + ry * ry < s * s * kLoose) {
            flag(next, u);
            any = true;
          }
        });
        if (any) flag(next, v);
      }
    });
  }
}

}  // namespace

template <class R>
Ops<R> cpu_ops() {
  return {&host_create, &host_destroy, &host_iterate<R>};
}
template Ops<float> cpu_ops<float>();
template Ops<double> cpu_ops<double>();

}  // namespace ff::overlap
