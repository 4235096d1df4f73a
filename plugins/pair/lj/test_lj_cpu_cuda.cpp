// pair.lj on CPU and CUDA: the same bits of forces, energies and virials on a two-type jittered
// lattice with the shift, and at every step of a moving polydisperse system with list rebuilds
// (2D and 3D, float and double). Each skips without a CUDA device.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "plugins/pair/lj/test_support.h"
#include "support/backends.h"
#include "support/fields.h"

using namespace ff;
using namespace ff::lj_test;
using test::values;

TEST_CASE("pair.lj: CPU and CUDA give the same bits", "[pair][cuda]") {
  if (!test::have_cuda("pair.lj CPU vs CUDA")) return;
  const int dim = GENERATE(2, 3);
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  INFO(dim << "D, " << to_string(p));
  auto cpu = lattice(dim, p, {0, 1, 1}), cuda = lattice(dim, p, {0, 1, 1});
  LJ q;
  q.eps_list = {14, 7, 7, 3};
  q.sigma = {1, 0.95, 0.95, 0.9};
  q.shift = true;
  run(*cpu, Backend::cpu, q);
  run(*cuda, Backend::cuda, q);
  for (const char* f : {"force", "pair.energy", "pair.virial"}) {
    const auto a = values(*cpu, f), c = values(*cuda, f);
    INFO(f);
    CHECK(std::memcmp(a.data(), c.data(), a.size() * sizeof(double)) == 0);
  }
}

// The CUDA loop (cuda.cu) reads positions and diameters from a copy it makes each step and keeps
// between steps: a random polydisperse system (σ_ij from the diameters, many warps of rows of
// different lengths) moved between steps, with and without list rebuilds, gives the CPU's bits
// at every step.
TEST_CASE("pair.lj: CPU and CUDA give the same bits over moving steps with rebuilds", "[pair][cuda]") {
  if (!test::have_cuda("pair.lj CPU vs CUDA over steps")) return;
  const int dim = GENERATE(2, 3);
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  INFO(dim << "D, " << to_string(p));
  const std::size_t n = 3000;
  const double L = dim == 2 ? 60.0 : 16.0;  // ~0.83 (2D) and 0.73 (3D) particles per σ^D
  std::mt19937_64 gen(5);
  std::uniform_real_distribution<double> uni(0, L), size(0.8, 1.2), move(-0.12, 0.12);
  std::vector<double> x(n * dim), d(n);
  for (auto& v : x) v = uni(gen);
  for (auto& v : d) v = size(gen);
  auto cpu = state(dim, p, L, x, {}, d), cuda = state(dim, p, L, x, {}, d);
  ParamValues verlet_p, lj_p;
  verlet_p.set("cutoff", 1.8);
  verlet_p.set("skin", 0.3);
  lj_p.set("epsilon", std::vector<double>{3});
  lj_p.set("sigma", std::vector<double>{});
  lj_p.set("n", std::int64_t(6));
  lj_p.set("r_cut", 1.5);
  lj_p.set("energy", true);
  struct Side {
    State& s;
    test::StageDriver verlet, lj;
  };
  Side sides[2] = {{*cpu, {registry(), "neighbors.verlet", Backend::cpu, p, dim, verlet_p, 1},
                    {registry(), "pair.lj", Backend::cpu, p, dim, lj_p, 1}},
                   {*cuda, {registry(), "neighbors.verlet", Backend::cuda, p, dim, verlet_p, 1},
                    {registry(), "pair.lj", Backend::cuda, p, dim, lj_p, 1}}};
  for (auto& side : sides) {
    side.verlet.stage->configure(side.s);
    side.lj.stage->configure(side.s);
  }
  int rebuilds = 0;
  for (std::uint64_t k = 0; k < 6; ++k) {
    for (auto& side : sides) {
      side.verlet.step(side.s, k, 0.01);
      side.lj.step(side.s, k, 0.01);
    }
    rebuilds += int(sides[1].verlet.metric("rebuilds"));
    INFO("step " << k);
    CHECK(sides[0].verlet.metric("rebuilds") == sides[1].verlet.metric("rebuilds"));
    for (const char* f : {"force", "pair.energy", "pair.virial"}) {
      const auto a = values(*cpu, f), c = values(*cuda, f);
      INFO(f);
      CHECK(std::memcmp(a.data(), c.data(), a.size() * sizeof(double)) == 0);
    }
    // The same move on both sides (in place, within the box: the box wraps it back).
    for (std::size_t i = 0; i < n * std::size_t(dim); ++i) x[i] += (k % 2 ? 0.3 : 1.0) * move(gen);
    for (State* s : {cpu.get(), cuda.get()}) {
      Field& fx = s->field(fields::position);
      fx.acquire(Where::host, Mode::write);
      for (std::size_t i = 0; i < x.size(); ++i) {
        const double v = x[i] - L * std::floor(x[i] / L);
        if (p == Precision::f64) fx.host<double>()[i] = v;
        else fx.host<float>()[i] = float(v);
      }
    }
  }
  CHECK(rebuilds >= 3);  // the first build and some of the moves of up to 0.12·√D
}
