// pair.lj: the generalized Lennard-Jones 2n–n potential (kernel.h) between the pairs of the
// Verlet list of a neighbors.verlet stage before it, per type pair ε_ij and σ_ij, cut at
// r_cut σ_ij, into the `force` field that overdamped.integrate reads (x += μ_t F Δt + noise).
// With energy: true also `pair.energy` and `pair.virial` (per particle) for observers. Each
// backend has its own loop over the same terms, both over packed records (position and diameter):
// the CPU's in vector lanes (cpu.cpp; records in double), CUDA's one thread a particle (cuda.cu).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "core/backend/exec.h"
#include "core/base/error.h"
#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "plugins/pair/lj/kernel.h"
#include "plugins/pair/lj/loops.h"
#include "stages/neighbors/list.h"

namespace ff::pair {

inline constexpr const char* kForce = "force";          // real x dim (k_BT per box length)
inline constexpr const char* kEnergy = "pair.energy";   // real: ½ Σ_j U_ij (k_BT)
inline constexpr const char* kVirial = "pair.virial";   // real: ½ Σ_j r_ij·F_ij (k_BT)

struct LJParams {
  PerType epsilon{{1.0}};
  PerType sigma{{}};
  std::string mixing = "lorentz-berthelot";
  std::int64_t n = 18;
  double r_cut = 1.5;
  bool shift = false;
  bool energy = false;

  template <class P>
  void describe(P& p) {
    p(epsilon, "epsilon",
      "well depth ε (k_BT; Tran: 14): one for every pair, one per type (mixed by `mixing`), or the T×T matrix "
      "ε_ab row by row (symmetric; T = the number of system.types)")
        .at_least(0);
    p(sigma, "sigma",
      "length σ (box units; Tran: the diameter d_A): [] (the default) takes σ_ij from the particle diameters, "
      "(d_i + d_j)/2 or √(d_i d_j) by `mixing`; else one for every pair, one per type (mixed), or the T×T matrix")
        .above(0);
    p(mixing, "mixing",
      "how per-type ε and σ combine: lorentz-berthelot (σ_ab = (σ_a + σ_b)/2, ε_ab = √(ε_a ε_b)) or geometric "
      "(σ_ab = √(σ_a σ_b), ε_ab = √(ε_a ε_b))")
        .one_of({"lorentz-berthelot", "geometric"});
    p(n, "n", "exponent n of U = 4ε[(σ/r)^{2n} − (σ/r)^n] (Tran: 18, the 36–18 potential; 6: the 12–6 one)")
        .at_least(1)
        .at_most(48);
    p(r_cut, "r_cut",
      "cutoff in units of σ_ij: U = 0 beyond r_cut σ_ij (Tran gives none; 1.5 leaves U = −0.0027 ε at n = 18); "
      "r_cut times the largest σ_ij must not exceed neighbors.verlet's cutoff")
        .above(0);
    p(shift, "shift", "shift the energy so that U(r_cut σ_ij) = 0 (the force is unchanged)");
    p(energy, "energy", "also write per-particle fields pair.energy (½ Σ_j U_ij) and pair.virial (½ Σ_j r_ij·F_ij)");
  }
};

template <class R>
class LJ final : public Stage {
 public:
  static StageDecl declaration() {
    return {"pair.lj",
            "generalized Lennard-Jones 2n–n, U = 4ε[(σ/r)^{2n} − (σ/r)^n] for r < r_cut σ, per type pair, from the "
            "Verlet list into `force`",
            schema_of<LJParams>(), {2, 3}, false};
  }

  template <class Exec>
  LJ(const ParamValues& v, const RunInfo&, Exec)
      : p_(params_from<LJParams>(v)), where_(Exec::where),
        loops_(lj_loops<R>(Exec{})), scratch_(Exec{}) {}

  std::vector<Access> accesses() const override {
    std::vector<Access> a{{fields::position, where_, Mode::read},
                          {neighbors::kList, where_, Mode::read},
                          {neighbors::kCount, where_, Mode::read},
                          Access::step_local_write(kForce, where_)};  // remade before it is read: no snapshot copy
    if (per_type_) a.push_back({fields::type, where_, Mode::read});
    if (from_diameter()) a.push_back({fields::diameter, where_, Mode::read});
    if (p_.energy) {
      a.push_back(Access::step_local_write(kEnergy, where_));
      a.push_back(Access::step_local_write(kVirial, where_));
    }
    return a;
  }

  void configure(State& s) override {
    if (!s.has_field(neighbors::kList) || !s.has_field(neighbors::kCutoff))
      throw InputError("pair.lj: needs a neighbors.verlet stage earlier in the step list (add "
                       "`- {stage: neighbors.verlet, cutoff: 1.5, skin: 0.3}` before it; cutoff ≥ r_cut·σ)");
    const std::size_t types = std::max<std::size_t>(1, s.species.size());
    per_type_ = p_.epsilon.values.size() > 1 || p_.sigma.values.size() > 1;
    if (per_type_) check_types(s, types);
    table_ = LJTable<R>{};
    const double largest_sigma = fill_table(s, types);
    const double needed = p_.r_cut * largest_sigma;
    Field& c = s.field(neighbors::kCutoff);
    c.acquire(Where::host, Mode::read);
    const double listed = double(c.host<R>()[0]);
    if (needed > listed * (1 + 1e-12))  // pairs between the two cutoffs would be missing from the list
      throw InputError("pair.lj: r_cut · (largest σ_ij) = " + num(p_.r_cut) + " · " + num(largest_sigma) + " = " + num(needed) +
                       " exceeds neighbors.verlet's cutoff " + num(listed) +
                       "; raise neighbors.verlet's `cutoff` to at least " + num(needed) + " or lower pair.lj's `r_cut`");
    s.add_particle_field(kForce, s.real(), s.dim());  // or the one another stage made, if the same shape
    if (p_.energy) {
      s.add_particle_field(kEnergy, s.real(), 1);
      s.add_particle_field(kVirial, s.real(), 1);
    }
  }

  Outcome run(StepContext& ctx) override {
    State& s = ctx.state;
    // The rows of the owned particles (all, alone); a decomposed team's ghosts appear in them.
    const std::size_t rows = s.n_owned();
    if (s.dim() == 2) loops_.d2(rows, s.n(), functor<2>(ctx), scratch_, ctx.stream);
    else loops_.d3(rows, s.n(), functor<3>(ctx), scratch_, ctx.stream);
    return Outcome::ok();
  }

  // In a decomposed team each owned particle sums its Verlet row, which names ghosts: rows sorted
  // by global id (neighbors.verlet), so the terms and their order are those of one rank alone.
  Scheduling scheduling() const override {
    Scheduling s;
    s.team = TeamWork::decomposed;
    s.reads_ghosts = true;
    return s;
  }

 private:
  bool from_diameter() const { return p_.sigma.values.empty(); }

  // Every particle's type must have an entry; at most kMaxTypes types.
  void check_types(State& s, std::size_t types) const {
    if (types > std::size_t(kMaxTypes))
      throw InputError("pair.lj: per-type epsilon/sigma handle at most " + std::to_string(kMaxTypes) +
                       " particle types; system.types has " + std::to_string(types));
    Field& t = s.field(fields::type);
    t.acquire(Where::host, Mode::read);
    for (std::size_t i = 0; i < s.n(); ++i)
      if (t.host<std::int32_t>()[i] < 0 || std::size_t(t.host<std::int32_t>()[i]) >= types)
        throw InputError("pair.lj: particle " + std::to_string(i) + " has type " +
                         std::to_string(t.host<std::int32_t>()[i]) + ", outside system.types (" +
                         std::to_string(types) + " types)");
  }

  // The ε and σ matrices of `key`: one value (every pair), T (mixed) or T² (explicit, symmetric).
  std::vector<double> matrix(const char* key, const std::vector<double>& v, std::size_t types, bool is_sigma) const {
    const std::size_t T = per_type_ ? types : 1;
    std::vector<double> m(T * T);
    if (v.size() == 1) {
      std::fill(m.begin(), m.end(), v[0]);
    } else if (v.size() == T) {
      for (std::size_t a = 0; a < T; ++a)
        for (std::size_t b = 0; b < T; ++b)
          m[a * T + b] = is_sigma && p_.mixing == "lorentz-berthelot" ? 0.5 * (v[a] + v[b]) : std::sqrt(v[a] * v[b]);
    } else if (v.size() == T * T) {
      m = v;
      for (std::size_t a = 0; a < T; ++a)
        for (std::size_t b = 0; b < a; ++b)
          if (m[a * T + b] != m[b * T + a])
            throw InputError(std::string("pair.lj: the ") + key + " matrix is not symmetric: entry (" +
                             std::to_string(a) + ", " + std::to_string(b) + ") = " + num(m[a * T + b]) + " but (" +
                             std::to_string(b) + ", " + std::to_string(a) + ") = " + num(m[b * T + a]));
    } else if (T == 1) {
      throw InputError(std::string("pair.lj: ") + key + " has " + std::to_string(v.size()) +
                       " values but the system has one particle type (system.types names none or one): give one");
    } else {
      throw InputError(std::string("pair.lj: ") + key + " has " + std::to_string(v.size()) + " values; give one for "
                       "every pair, one per type (" + std::to_string(T) + ") or the " + std::to_string(T) + "×" +
                       std::to_string(T) + " matrix row by row (" + std::to_string(T * T) + ") for the " +
                       std::to_string(T) + " types of system.types");
    }
    return m;
  }

  // Fills table_; returns the largest σ_ij.
  double fill_table(State& s, std::size_t types) {
    const std::size_t T = per_type_ ? types : 1;
    const auto eps = matrix("epsilon", p_.epsilon.values, types, false);
    double largest = 0;
    if (from_diameter()) {
      Field& d = s.field(fields::diameter);
      d.acquire(Where::host, Mode::read);
      for (std::size_t i = 0; i < s.n(); ++i) largest = std::max(largest, double(d.host<R>()[i]));
    }
    const auto sig = from_diameter() ? std::vector<double>(T * T, 1.0) : matrix("sigma", p_.sigma.values, types, true);
    for (std::size_t a = 0; a < T; ++a)
      for (std::size_t b = 0; b < T; ++b) {
        table_.epsilon[a * kMaxTypes + b] = R(eps[a * T + b]);
        table_.sigma2[a * kMaxTypes + b] = R(sig[a * T + b] * sig[a * T + b]);
        if (!from_diameter()) largest = std::max(largest, sig[a * T + b]);
      }
    return largest;
  }

  template <int D>
  LJForce<R, D> functor(StepContext& ctx) const {
    State& s = ctx.state;
    const double rc = p_.r_cut;
    return {data<R>(ctx, fields::position),
            per_type_ ? data<std::int32_t>(ctx, fields::type) : nullptr,
            from_diameter() ? data<R>(ctx, fields::diameter) : nullptr,
            data<R>(ctx, kForce),
            p_.energy ? data<R>(ctx, kEnergy) : nullptr,
            p_.energy ? data<R>(ctx, kVirial) : nullptr,
            data<std::uint32_t>(ctx, neighbors::kList),
            data<std::uint32_t>(ctx, neighbors::kCount),
            neighbors::list_capacity(s),
            PeriodicBox<R>::make(s.box.L),
            table_,
            int(p_.n),
            p_.mixing == "geometric",
            R(rc * rc),
            R(shift_per_epsilon())};
  }
  template <class T>
  static T* data(StepContext& ctx, const char* name) { return ctx.state.field(name).data<T>(ctx); }
  // U(r_cut σ_ij)/ε_ij = 4 (q² − q), q = r_cut^{−n}, by the kernel's own powers; 0 without shift.
  double shift_per_epsilon() const {
    if (!p_.shift) return 0;
    const double s = 1 / (p_.r_cut * p_.r_cut);
    const int n = int(p_.n);
    const double q = n & 1 ? power(s, n / 2) * std::sqrt(s) : power(s, n / 2);
    return 4 * (q * q - q);
  }
  static std::string num(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%g", v);
    return b;
  }

  LJParams p_;
  Where where_;
  LJLoops<R> loops_;  // the CPU lanes (cpu.cpp) or the CUDA loops (cuda.cu); loops.h
  LJScratch<R> scratch_;
  LJTable<R> table_{};
  bool per_type_ = false;
};

}  // namespace ff::pair

FLIPFLOW_STAGE(ff::pair::LJ)
