// The generalized Lennard-Jones 2n–n pair force, per particle i (Tran et al. 2015, Annex 1,
// eq. 8, where n = 18, ε = 14 k_BT and σ = d_A):
//
//   U(r) = 4 ε_ij [ (σ_ij/r)^{2n} − (σ_ij/r)^n ]   for r < r_cut σ_ij,  0 beyond,
//   F_i  = Σ_j (4 n ε_ij / r²) [ 2 (σ_ij/r)^{2n} − (σ_ij/r)^n ] d_ij,
//
// d_ij = minimum image of x_i − x_j, r = |d_ij|: F_i = −∇_i U summed over the row of i in
// the Verlet list. The prefactor 4 makes the minimum −ε_ij at r_m = 2^{1/n} σ_ij for every n
// (there (σ/r)^n = 1/2), as in eq. 8; n = 6 is the usual 12–6 potential. With `shift` the
// energy is U(r) − U(r_cut σ_ij), where U(r_cut σ_ij) = 4 ε_ij (r_cut^{−2n} − r_cut^{−n}) does
// not depend on σ_ij; the force is unchanged.
//
// Powers: s = σ²/r², (σ/r)^n = s^{n/2} by squaring and multiplying (times √s for odd n), never
// pow(), so the two backends do the same operations. s is capped at kMaxS = 4 (r < σ_ij/2):
// below that the force magnitude falls linearly to 0 at r = 0 instead of overflowing (a float
// q² overflows near r = 0.1 σ for n = 18, and ∞·0 would give NaN). No usable Δt brings two
// particles there (U(σ/2) = 3.8·10¹² k_BT at Tran's n and ε); with max_step, overdamped.integrate
// turns a step that tries into a rollback.
//
// Each particle sums its own row in list order (ascending j, stages/neighbors/list.h), writing
// only its own entries: no atomics, and CPU and CUDA add the same terms in the same order.
// 1/r² is one division; the cap on s below computes it again from the capped s (rare). The
// products feeding a sum are math::mul_rn (never fused into an fma), so the bits agree.
// Optional observables (energy: true): ½ Σ_j U_ij and ½ Σ_j r_ij·F_ij per particle. nvcc-clean.
#pragma once
#include <cmath>
#include <cstdint>

#include "core/base/hd.h"
#include "core/physics/box.h"
#include "core/physics/math.h"

namespace ff::pair {

inline constexpr int kMaxTypes = 8;  // per-type-pair tables travel in the functor (kernel argument)
inline constexpr double kMaxS = 4;   // cap on σ²/r² (r ≥ σ_ij/2), see above

// Per type pair (a, b) at [a * kMaxTypes + b], symmetric; with one type only entry 0 is used.
template <class R>
struct LJTable {
  R epsilon[kMaxTypes * kMaxTypes];  // ε_ab (k_BT)
  R sigma2[kMaxTypes * kMaxTypes];   // σ_ab² (σ²); unused when σ comes from the diameters
};

// x^k for k ≥ 0 by squaring and multiplying: the same products, in the same order, everywhere.
// R is a real or the CPU loop's vector of lanes (cpu.cpp), whose mul_rn and sqrt ADL finds.
template <class R>
FF_HD R power(R x, int k) {
  using math::mul_rn;
  R result = R(1);
  while (k > 0) {
    if (k & 1) result = mul_rn(result, x);
    x = mul_rn(x, x);
    k >>= 1;
  }
  return result;
}

// The radial terms of one pair inside the cutoff, from s = σ²/r² (capped) and 1/r²: q = (σ/r)^n,
// q² and the force magnitude 4 n ε (2q² − q) / r² (F_i = magnitude · d_ij). Written once for the
// scalar functor below (both backends) and for the CPU loop's lanes (cpu.cpp: one particle per
// lane, the same operations in the same order, so the same bits).
template <class R>
struct LJTerms {
  R q, q2, magnitude;
};
template <class R>
FF_HD LJTerms<R> lj_terms(R s, R inv_r2, R eps, int n) {
  using math::mul_rn;
  using std::sqrt;
  const R q = n & 1 ? mul_rn(power(s, n / 2), sqrt(s)) : power(s, n / 2);  // (σ/r)^n
  const R q2 = mul_rn(q, q);                                                // (σ/r)^{2n}
  return {q, q2, mul_rn(mul_rn(R(4 * n) * eps, (R(2) * q2 - q)), inv_r2)};
}
// The pair's energy U_ij − ε_ij·shift (shift = U(r_cut σ_ij)/ε_ij or 0) and its virial r²·magnitude.
template <class R>
FF_HD R lj_energy(const LJTerms<R>& t, R eps, R shift) {
  using math::mul_rn;
  return mul_rn(R(4) * eps, t.q2 - t.q) - mul_rn(eps, shift);
}

template <class R, int D>
struct LJForce {
  const R* position;             // N x D
  const std::int32_t* type;      // N, or null: every pair uses table entry 0
  const R* diameter;             // N, or null: σ_ij from the table
  R* force;                      // N x D (written)
  R* energy;                     // N, or null: ½ Σ_j U_ij (written)
  R* virial;                     // N, or null: ½ Σ_j r_ij·F_ij (written)
  const std::uint32_t* list;     // N x capacity: row i = neighbours of i, ascending
  const std::uint32_t* count;    // N: entries set in row i
  std::uint32_t capacity;
  PeriodicBox<R> box;
  LJTable<R> table;
  int n;                         // the exponent n of the 2n–n form
  bool geometric;                // σ_ij from diameters: √(d_i d_j) instead of (d_i + d_j)/2
  R r_cut2;                      // (r_cut)², r_cut in units of σ_ij
  R shift;                       // U(r_cut σ_ij)/ε_ij, or 0 without `shift`

  // σ_ij² from the diameters d_i, d_j of the pair, or from its table entry ab.
  FF_HD R sigma2(R di, R dj, int ab) const {
    if (!diameter) return table.sigma2[ab];
    const R s = geometric ? std::sqrt(math::mul_rn(di, dj)) : R(0.5) * (di + dj);
    return math::mul_rn(s, s);
  }

  // Adds the terms of the pair (i, j) to f (and u, w with energy): xi, xj their positions, di,
  // dj their diameters (read only when σ_ij comes from them), ab the table entry of their types.
  // operator() and the CUDA loops (cuda.cu) both sum through it, so they do the same operations.
  // N > 0: the exponent n as a constant (the CUDA loop's for n = 6 and 18: power() unrolled into
  // the same products).
  template <int N = 0>
  FF_HD void add_pair(const R* xi, const R* xj, R di, R dj, int ab, R f[D], R& u, R& w) const {
    R d[D], r2 = 0;
    for (int c = 0; c < D; ++c) {
      d[c] = box.min_image(xi[c] - xj[c], c);
      r2 += math::mul_rn(d[c], d[c]);
    }
    const R sig2 = sigma2(di, dj, ab);
    if (r2 >= math::mul_rn(r_cut2, sig2) || r2 == R(0)) return;  // beyond the cutoff (or coincident)
    R inv_r2 = R(1) / r2;
    R s = math::mul_rn(sig2, inv_r2);
    if (s > R(kMaxS)) {  // (the cap holds for 1/r² = s/σ² too)
      s = R(kMaxS);
      inv_r2 = s / sig2;
    }
    const R eps = table.epsilon[ab];
    const LJTerms<R> t = lj_terms(s, inv_r2, eps, N > 0 ? N : n);
    for (int c = 0; c < D; ++c) f[c] += math::mul_rn(t.magnitude, d[c]);
    if (energy) {
      u += lj_energy(t, eps, shift);
      w += math::mul_rn(t.magnitude, r2);
    }
  }

  FF_HD void operator()(std::size_t i) const {
    R f[D] = {};
    R u = 0, w = 0;
    const int ti = type ? type[i] : 0;
    const R di = diameter ? diameter[i] : R(0);
    for (std::uint32_t a = 0; a < count[i]; ++a) {
      const std::uint32_t j = list[i * capacity + a];
      add_pair(&position[i * D], &position[std::size_t(j) * D], di, diameter ? diameter[j] : R(0),
               type ? ti * kMaxTypes + type[j] : 0, f, u, w);
    }
    for (int c = 0; c < D; ++c) force[i * D + c] = f[c];
    if (energy) {
      energy[i] = R(0.5) * u;
      virial[i] = R(0.5) * w;
    }
  }
};

}  // namespace ff::pair
