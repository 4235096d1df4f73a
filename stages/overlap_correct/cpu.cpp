// CPU loop of overlap_correct (oneTBB): edge passes while many particles move, work lists of
// flagged particles after that.
//
// The particles are cut into tiles of kTile consecutive indices; a tile is one oneTBB task, and
// its edges [3·t0, 3·t1) are its share of an edge pass. An iteration is one of two kinds:
//   - edge pass (iteration 0, and each iteration after one that moved at least n / kEdgeMode
//     particles): stream over the 3N edge records, each pair once; an overlapping edge counts
//     its pair and hands its term (kernel.h, pair_term: +t on one end, −t on the other) to its
//     ends: directly to an end in the tile's own particles, through a list to any other (one
//     thread hands those out afterwards, in tile order; no atomics: a locked add per term cost
//     more than the edge test). Each tile lists its touched particles once, with their first
//     kKnownTerms terms, and finishes them (Mesh::gather_known: with one or two terms their sum
//     does not depend on the order; with more it walks the fan as a gather does). Iteration
//     0's pass also checks the mesh (indices in range, no loops, next pointers a permutation).
//   - work list (otherwise): gather only the flagged particles of each tile (in index order,
//     the flags cleared as they are read), flagged for iteration k + 1 by iteration k:
//       - each particle that had an overlapping edge but did not move (d = 0);
//       - after the apply, both ends of each edge of a moved particle that overlaps at the new
//         positions (tested with r² < σ²·(1 + 1e-9), so rounding can only add particles).
//     An edge that overlaps at k + 1 either has a moved end (then it is tested after the apply)
//     or had both ends fixed, so it overlapped at k already and both ends were flagged.
// Either way every particle left out would have gathered d = 0 and no pairs, and every one
// gathered gets the same bits as its walk: the same result as gathering every particle, for
// any thread count and as on the GPU. Which kind an iteration is depends only on counts, never
// on the threads. The apply touches only the moved particles.
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
// unevenly spread) balance over the threads, large enough that a full pass is ~100 µs a task.
constexpr std::size_t kTile = 2048;
// An iteration after one that moved at least n / kEdgeMode particles is an edge pass: one pass
// over the 3N edges costs about as much as the walks of n / 6 moved particles (the check after
// the apply) and their gathers (measured, hard disks at η = 0.5, 2^16).
constexpr std::size_t kEdgeMode = 8;

// A term for a particle of another tile, from an edge pass.
struct Remote {
  int v;
  double tx, ty;
};

// A particle touched in an edge pass: its overlapping edges and their first kKnownTerms terms.
struct Touched {
  int v;
  unsigned count;
  double t[2 * kKnownTerms];
};

struct Tile {
  std::size_t t0 = 0, t1 = 0;    // its particles; its edges in an edge pass are [3·t0, 3·t1)
  std::vector<int> cand;         // this iteration's flagged particles, in index order
  std::vector<int> moved;        // particles with d != 0
  std::vector<double> disp;      // their displacements, 2 per moved particle
  std::size_t nmoved = 0;
  std::vector<Touched> touched;  // an edge pass's touched particles of this tile
  std::size_t ntouched = 0;
  std::vector<Remote> remote;    // an edge pass's terms for other tiles' particles (6·kTile)
  std::size_t nremote = 0;
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
};

void* host_create(std::size_t n) {
  auto* w = new HostWorkspace;
  w->n = n;
  w->next_hash = mix_sum(6 * std::uint64_t(n));
  const std::size_t padded = (n + 7) / 8 * 8;
  for (auto& f : w->flags) f.assign(padded, 0);
  w->slot.assign(n, -1);
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
    tl.touched.resize(m);
    tl.remote.resize(6 * m);
  }
  return w;
}
void host_destroy(void* p) { delete static_cast<HostWorkspace*>(p); }

inline void flag(std::uint8_t* f, int v) { __atomic_store_n(f + v, std::uint8_t(1), __ATOMIC_RELAXED); }

// A term for particle v of tile tl (only tl's own task, or the one thread handing out the
// remote terms, writes there): lists v when it is new, keeps the first kKnownTerms terms,
// counts them all.
inline void deposit(std::int32_t* slot, Tile& tl, int v, double tx, double ty) {
  std::int32_t& i = slot[std::size_t(v)];
  if (i < 0) {
    i = std::int32_t(tl.ntouched++);
    tl.touched[std::size_t(i)].v = v;
    tl.touched[std::size_t(i)].count = 0;
  }
  Touched& p = tl.touched[std::size_t(i)];
  if (p.count < kKnownTerms) {
    p.t[2 * p.count] = tx;
    p.t[2 * p.count + 1] = ty;
  }
  ++p.count;
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

// One tile's share of an edge pass (Check: iteration 0, with the mesh checks): hands the terms
// of its overlapping edges to its own particles and lists the others', counts pairs into tl.c.
template <bool Check, class R>
void edge_pass(const Mesh<R>& mesh, Tile& tl, std::int32_t* slot) {
  const Mesh<R> m = mesh;  // a local copy: the stores below cannot alias its fields
  std::uint64_t pairs = 0, bad = 0, broken = 0, hash = 0;
  const unsigned t0 = unsigned(tl.t0), size = unsigned(tl.t1 - tl.t0);
  tl.ntouched = 0;
  std::size_t nremote = 0;
  auto hand = [&](int v, double tx, double ty) {
    if (unsigned(v) - t0 < size)
      deposit(slot, tl, v, tx, ty);
    else
      tl.remote[nremote++] = Remote{v, tx, ty};
  };
  for (std::size_t e = 3 * tl.t0, e1 = 3 * tl.t1; e < e1; ++e) {
    int a, b;
    double tx, ty, o;
    const int r = m.template edge<Check>(e, a, b, tx, ty, o, hash);
    if (r == kEdgeApart) continue;
    if (r == kEdgeCorrupt) {
      ++broken;
      continue;
    }
    if (o > 0) {
      ++pairs;
      if (o > m.tol) ++bad;
    }
    hand(a, tx, ty);
    hand(b, -tx, -ty);
  }
  tl.nremote = nremote;
  tl.c[kBad] = bad;
  tl.c[kPairs] = pairs;
  tl.c[kCorrection] = 0;
  tl.c[kBroken] = broken;
  tl.next_hash = hash;
}

template <class R>
void host_iterate(void* ws, const Problem<R>& p, std::int64_t k0, std::int64_t max_iterations, Batch& out,
                  CUstream_st*) {
  auto* w = static_cast<HostWorkspace*>(ws);
  const Mesh<R>& mesh = p.mesh;
  const std::size_t nt = w->tiles.size();
  // A step starts from clean flags (cheap; also covers a step that ended in an error).
  if (k0 == 0) {
    for (auto& f : w->flags) std::memset(f.data(), 0, f.size());
    w->edge_pass = true;
  }
  out.gathers = 0;
  for (int j = 0; j < kBatch; ++j) {
    const std::int64_t k = k0 + j;
    std::uint8_t* cur = w->flags[k & 1].data();
    std::uint8_t* next = w->flags[(k + 1) & 1].data();
    const bool edge = w->edge_pass;

    // The particles to gather: each tile's touched particles with their terms after an edge
    // pass, else its flagged particles.
    if (edge) {
      for_each_tile(nt, [&](std::size_t t) {
        if (k == 0)
          edge_pass<true>(mesh, w->tiles[t], w->slot.data());
        else
          edge_pass<false>(mesh, w->tiles[t], w->slot.data());
      });
      std::uint64_t broken = 0, hash = 0;
      for (const Tile& tl : w->tiles) {
        broken += tl.c[kBroken];
        hash += tl.next_hash;
      }
      if (k == 0 && (broken || hash != w->next_hash)) {  // corrupt: stop before anything walks it
        std::uint64_t* c = out.counters[0];
        std::memset(c, 0, kCounters * sizeof(std::uint64_t));
        c[kBroken] = broken + (hash != w->next_hash);
        out.gathers = 1;
        return;
      }
      for (const Tile& tl : w->tiles)
        for (std::size_t i = 0; i < tl.nremote; ++i) {
          const Remote& r = tl.remote[i];
          deposit(w->slot.data(), w->tiles[std::size_t(r.v) / kTile], r.v, r.tx, r.ty);
        }
      std::memset(cur, 0, w->flags[0].size());  // an edge pass finds every candidate itself
    }

    for_each_tile(nt, [&](std::size_t t) {
      Tile& tl = w->tiles[t];
      std::uint64_t c[kCounters] = {0, 0, 0, 0};
      std::size_t count;
      if (edge) {
        std::memcpy(c, tl.c, sizeof c);  // this tile's edge pass counted the pairs
        count = tl.ntouched;
      } else {
        count = compact(cur, tl.t0, tl.t1, tl.cand.data());
      }
      std::size_t nm = 0;
      for (std::size_t i = 0; i < count; ++i) {
        int v;
        VertexPush q;
        if (edge) {
          const Touched& p = tl.touched[i];
          v = p.v;
          q = mesh.gather_known(v, p.count, p.t);
          w->slot[std::size_t(v)] = -1;
        } else {
          v = tl.cand[i];
          q = mesh.gather(v);
        }
        c[kBad] += q.bad;
        c[kPairs] += q.pairs;
        c[kBroken] += q.broken;
        if (!q.touched) continue;  // d = 0, len = 0
        c[kCorrection] += mesh.fixed_len(q.len);
        if (q.dx != 0 || q.dy != 0) {
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
    std::size_t moved = 0;
    for (const Tile& tl : w->tiles) {
      for (int q = 0; q < kCounters; ++q) c[q] += tl.c[q];
      moved += tl.nmoved;
    }
    out.gathers = j + 1;
    if (!keeps_going(c, k, max_iterations)) return;

    for_each_tile(nt, [&](std::size_t t) {
      const Tile& tl = w->tiles[t];
      for (std::size_t i = 0, nm = tl.nmoved; i < nm; ++i)
        apply_one(p.pos, p.image, p.box, std::size_t(tl.moved[i]), tl.disp[2 * i], tl.disp[2 * i + 1]);
    });
    w->edge_pass = moved >= w->n / kEdgeMode;
    if (w->edge_pass) continue;  // it finds every overlapping edge itself
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
          const double rx = mesh.min_image(xu - xv, 0);
          const double ry = mesh.min_image(yu - yv, 1);
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
