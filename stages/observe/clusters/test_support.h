// What observe.clusters' tests share (test_clusters.cpp: the analysis; test_clusters_files.cpp:
// the CSV files): the registry, states of hand-placed particles, the stage made with some
// parameters, and one call's metrics and labels.
#pragma once
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "stages/observe/clusters/stage.h"
#include "support/stage_driver.h"
#include "support/test_plugins.h"

namespace ff::test::clusters_test {

inline const Registry& registry() {
  static const std::unique_ptr<Registry> r = test::registry_of({"observe", "delaunay", "neighbors"});
  return *r;
}

struct Particle {
  double x, y, z;
  int type;
};

// A state of the given particles (species A, B with diameters d).
inline std::unique_ptr<State> make_state(int dim, const std::vector<Particle>& ps, const double* L,
                                  std::vector<double> d = {1.0}) {
  auto s = std::make_unique<State>(dim, Precision::f64, ps.size());
  for (int k = 0; k < dim; ++k) s->box.L[k] = L[k];
  const char* names[] = {"A", "B", "C"};
  for (std::size_t t = 0; t < d.size(); ++t) s->species.push_back(names[t]);
  s->species_diameter = d;
  double* x = s->field(fields::position).host<double>();
  for (std::size_t i = 0; i < ps.size(); ++i) {
    const double c[3] = {ps[i].x, ps[i].y, ps[i].z};
    for (int k = 0; k < dim; ++k) x[i * dim + k] = c[k] - L[k] * std::floor(c[k] / L[k]);
    s->field(fields::type).host<std::int32_t>()[i] = ps[i].type;
    s->field(fields::diameter).host<double>()[i] = d[std::size_t(ps[i].type)];
  }
  return s;
}

inline std::unique_ptr<Stage> clusters(int dim, const ParamSettings& set, const std::string& out_dir = "") {
  ParamValues v = ParamValues::defaults(registry().get("observe.clusters").decl.params);
  for (auto& kv : set) v.set(kv.first, kv.second);
  RunInfo info;
  info.dim = dim;
  info.stage_id = "observe.clusters";
  info.out_dir = out_dir;
  return registry().create("observe.clusters", Backend::cpu, v, info);
}

// One call of observe.clusters on s (configured here); its metrics and labels.
struct Measured {
  std::map<std::string, double> m;
  std::vector<std::int32_t> label;
};

inline Measured measure(State& s, ParamSettings set = {}, std::uint64_t step = 1) {
  set.push_back({"label_field", true});
  auto st = clusters(s.dim(), set);
  st->configure(s);
  test::StageDriver drv(Backend::cpu, Precision::f64, s.dim());
  drv.run(*st, s, step);
  Measured r{drv.metrics.values(), {}};
  const std::int32_t* l = s.field(observe::cluster_label_field).host<std::int32_t>();
  r.label.assign(l, l + s.n());
  return r;
}

// Unit-spaced pieces of a square lattice (σ = 1, bond 1.1: nearest sites bond, diagonals do not):
// a 3x3 block (12 bonds; coordination 4 inside, 3 on edges, 2 at corners: Σ 24), a line of 4 (3
// bonds, Σ 6), a dimer (1 bond, Σ 2) and three monomers, sizes 9, 4, 2, 1, 1, 1, listed in a
// scrambled order: particle i is site perm[i] of that list (block, line, dimer, monomers).
inline std::vector<Particle> lattice_pieces(std::vector<std::size_t>* perm_out = nullptr) {
  std::vector<Particle> ps;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) ps.push_back({2.0 + i, 2.0 + j, 0, 0});
  for (int i = 0; i < 4; ++i) ps.push_back({8.0 + i, 2.0, 0, 0});
  ps.push_back({2.0, 8.0, 0, 0});
  ps.push_back({3.0, 8.0, 0, 0});
  for (int i = 0; i < 3; ++i) ps.push_back({14.0, 6.0 + 3 * i, 0, 0});
  std::vector<std::size_t> perm(ps.size());
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), std::mt19937_64(5));
  std::vector<Particle> scrambled;
  for (auto k : perm) scrambled.push_back(ps[k]);
  if (perm_out) *perm_out = perm;
  return scrambled;
}

}  // namespace ff::test::clusters_test
