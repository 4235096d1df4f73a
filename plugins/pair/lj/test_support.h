// What the pair.lj tests share (test_lj.cpp, test_lj_lanes.cpp, test_lj_cpu_cuda.cpp in this
// folder): their registry, hand-made states (positions, types, diameters in a periodic box), the
// parameters of one neighbors.verlet + pair.lj step and that step, and a jittered lattice.
#pragma once
#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "support/backends.h"
#include "support/stage_driver.h"
#include "support/test_plugins.h"

namespace ff::lj_test {

inline const Registry& registry() {
  static const auto r = test::registry_with({"pair"});
  return *r;
}

// n particles in a cubic (square) box of side L: positions x (n x dim), types t (empty: all 0),
// diameters d (empty: all 1); `types` names system.types.
inline std::unique_ptr<State> state(int dim, Precision p, double L, const std::vector<double>& x,
                                    const std::vector<int>& t = {}, const std::vector<double>& d = {},
                                    std::vector<std::string> types = {}) {
  const std::size_t n = x.size() / dim;
  auto s = std::make_unique<State>(dim, p, n);
  for (int c = 0; c < dim; ++c) s->box.L[c] = L;
  s->species = std::move(types);
  Field& fx = s->field(fields::position);
  Field& fd = s->field(fields::diameter);
  Field& ft = s->field(fields::type);
  for (Field* f : {&fx, &fd, &ft}) f->acquire(Where::host, Mode::write);
  auto put = [p](Field& f, std::size_t i, double v) {
    if (p == Precision::f64) f.host<double>()[i] = v;
    else f.host<float>()[i] = float(v);
  };
  for (std::size_t i = 0; i < x.size(); ++i) put(fx, i, x[i]);
  for (std::size_t i = 0; i < n; ++i) {
    put(fd, i, d.empty() ? 1.0 : d[i]);
    ft.host<std::int32_t>()[i] = t.empty() ? 0 : t[i];
  }
  return s;
}

struct LJ {
  double epsilon = 1;
  std::vector<double> eps_list, sigma;  // per type / matrix (empty: `epsilon`, diameters)
  std::string mixing = "lorentz-berthelot";
  std::int64_t n = 18;
  double r_cut = 1.5;
  bool shift = false;
  double cutoff = 1.5, skin = 0.3;  // neighbors.verlet
};

// neighbors.verlet then pair.lj once (energy: `energy`).
inline void run(State& s, Backend b, const LJ& q, bool energy = true) {
  ParamValues verlet_p, lj_p;
  verlet_p.set("cutoff", q.cutoff);
  verlet_p.set("skin", q.skin);
  lj_p.set("epsilon", q.eps_list.empty() ? std::vector<double>{q.epsilon} : q.eps_list);
  lj_p.set("sigma", q.sigma);
  lj_p.set("mixing", q.mixing);
  lj_p.set("n", q.n);
  lj_p.set("r_cut", q.r_cut);
  lj_p.set("shift", q.shift);
  lj_p.set("energy", energy);
  test::StageDriver verlet(registry(), "neighbors.verlet", b, s.precision(), s.dim(), verlet_p, 1);
  test::StageDriver lj(registry(), "pair.lj", b, s.precision(), s.dim(), lj_p, 1);
  verlet.stage->configure(s);
  lj.stage->configure(s);
  verlet.step(s, 0, 0.01);
  lj.step(s, 0, 0.01);
}

// A jittered lattice of spacing 1.1 (nearest pairs at 1.0…1.2 σ), periodic, in a box of side L.
inline std::unique_ptr<State> lattice(int dim, Precision p, std::vector<int> types = {}) {
  const int m = dim == 2 ? 20 : 8;
  const double a = 1.1, L = m * a;
  std::mt19937_64 gen(11);
  std::uniform_real_distribution<double> jitter(-0.05, 0.05);
  std::vector<double> x;
  const int cells = dim == 2 ? m * m : m * m * m;
  for (int k = 0; k < cells; ++k) {
    int idx[3] = {k % m, (k / m) % m, k / (m * m)};
    for (int c = 0; c < dim; ++c) x.push_back((idx[c] + 0.5) * a + jitter(gen));
  }
  if (types.empty()) return state(dim, p, L, x);
  std::vector<int> t(cells);
  for (int k = 0; k < cells; ++k) t[k] = types[k % types.size()];
  return state(dim, p, L, x, t, {}, {"A", "B"});
}

}  // namespace ff::lj_test
