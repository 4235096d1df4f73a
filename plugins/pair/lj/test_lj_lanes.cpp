// pair.lj's CPU loop (plugins/pair/lj/cpu.cpp) puts particles into vector lanes (AVX2, or
// AVX-512 where the CPU has it): on random polydisperse states with two types, a coincident pair
// and a capped one, its forces, energies and virials have the bits of kernel.h's scalar functor
// run particle by particle, in 2D and 3D, float and double, for 1 and 2 threads. CTest runs it
// again as test_pair_lj_avx2 with FLIPFLOW_NO_AVX512 set (tests/CMakeLists.txt).
#include <catch2/catch.hpp>
#include <oneapi/tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <utility>
#include <vector>

#include "core/backend/cpu_isa.h"
#include "plugins/pair/lj/kernel.h"
#include "plugins/pair/lj/test_support.h"
#include "stages/neighbors/list.h"
#include "support/fields.h"

using namespace ff;
using namespace ff::lj_test;
using test::values;

namespace {

// The scalar functor of kernel.h, particle by particle on this thread, over the list that
// neighbors.verlet left in s: the reference for the CPU stage's vector lanes (plugins/pair/lj/
// cpu.cpp). ε and σ: one type from `q` (σ_ij from the diameters, by q.mixing) or, with q.sigma
// set, the T×T matrices q.eps_list and q.sigma.
struct Fields { std::vector<double> force, energy, virial; };
template <class R, int D>
Fields scalar_functor(State& s, const LJ& q, bool energy) {
  const std::size_t n = s.n();
  std::vector<R> force(n * D), u(n), w(n);
  pair::LJForce<R, D> f{};
  for (const char* name : {fields::position, fields::diameter, fields::type, neighbors::kList, neighbors::kCount})
    s.field(name).acquire(Where::host, Mode::read);
  f.position = s.field(fields::position).host<R>();
  f.force = force.data();
  f.energy = energy ? u.data() : nullptr;
  f.virial = energy ? w.data() : nullptr;
  f.list = s.field(neighbors::kList).host<std::uint32_t>();
  f.count = s.field(neighbors::kCount).host<std::uint32_t>();
  f.capacity = neighbors::list_capacity(s);
  f.box = PeriodicBox<R>::make(s.box.L);
  const int T = q.sigma.empty() ? 1 : int(std::lround(std::sqrt(double(q.sigma.size()))));
  for (int a = 0; a < T; ++a)
    for (int b = 0; b < T; ++b) {
      f.table.epsilon[a * pair::kMaxTypes + b] = R(T == 1 ? q.epsilon : q.eps_list[a * T + b]);
      f.table.sigma2[a * pair::kMaxTypes + b] = R(T == 1 ? 1.0 : q.sigma[a * T + b] * q.sigma[a * T + b]);
    }
  f.type = T > 1 ? s.field(fields::type).host<std::int32_t>() : nullptr;
  f.diameter = T == 1 ? s.field(fields::diameter).host<R>() : nullptr;
  f.n = int(q.n);
  f.geometric = q.mixing == "geometric";
  f.r_cut2 = R(q.r_cut * q.r_cut);
  const double s1 = 1 / (q.r_cut * q.r_cut);
  const int k = int(q.n);
  const double qc = k & 1 ? pair::power(s1, k / 2) * std::sqrt(s1) : pair::power(s1, k / 2);
  f.shift = q.shift ? R(4 * (qc * qc - qc)) : R(0);
  for (std::size_t i = 0; i < n; ++i) f(i);
  return {{force.begin(), force.end()}, {u.begin(), u.end()}, {w.begin(), w.end()}};
}

// n random particles (not a multiple of any lane count) at volume fraction ~0.3 with random
// diameters in [0.8, 1.2] σ, two types, one coincident pair and one pair at 0.3 σ (s capped).
std::unique_ptr<State> random_state(int dim, Precision p, std::size_t n) {
  std::mt19937_64 gen(5 + dim);
  std::uniform_real_distribution<double> u01(0, 1);
  const double L = dim == 2 ? std::sqrt(n * 0.785 / 0.5) : std::cbrt(n * 0.524 / 0.3);
  std::vector<double> x(n * dim), d(n);
  std::vector<int> t(n);
  for (auto& v : x) v = L * u01(gen);
  for (std::size_t i = 0; i < n; ++i) {
    d[i] = 0.8 + 0.4 * u01(gen);
    t[i] = int(i % 3 == 0);
  }
  for (int c = 0; c < dim; ++c) {
    x[5 * dim + c] = x[1 * dim + c];
    x[9 * dim + c] = x[2 * dim + c] + (c == 0 ? 0.3 : 0.0);
  }
  return state(dim, p, L, x, t, d, {"A", "B"});
}

template <class R, int D>
void lanes_match_functor(Precision p) {
  LJ diam, geo, matrix;
  diam.epsilon = 14;
  diam.cutoff = 1.9;  // r_cut · the largest σ_ij = 1.8
  geo = diam;
  geo.mixing = "geometric";
  geo.n = 7;  // odd: the √s factor
  geo.shift = true;
  matrix.eps_list = {14, 7, 7, 3};
  matrix.sigma = {1, 0.95, 0.95, 0.9};
  matrix.n = 6;
  matrix.shift = true;
  for (const LJ* q : {&diam, &geo, &matrix})
    for (bool energy : {true, false})
      for (int threads : {1, 2}) {
        INFO(D << "D, " << to_string(p) << ", σ " << (q->sigma.empty() ? q->mixing : "matrix") << ", energy " << energy << ", " << threads
               << " threads");
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        auto s = random_state(D, p, D == 2 ? 4099 : 3001);
        run(*s, Backend::cpu, *q, energy);
        const Fields want = scalar_functor<R, D>(*s, *q, energy);
        const auto got = values(*s, "force");
        REQUIRE(got.size() == want.force.size());
        CHECK(std::memcmp(got.data(), want.force.data(), got.size() * sizeof(double)) == 0);
        if (energy)
          for (const auto& [name, v] : {std::pair{"pair.energy", &want.energy}, std::pair{"pair.virial", &want.virial}}) {
            const auto field = values(*s, name);
            INFO(name);
            REQUIRE(field.size() == v->size());
            CHECK(std::memcmp(field.data(), v->data(), field.size() * sizeof(double)) == 0);
          }
        // The state reaches the cap and the cutoff: a test that would catch their blends.
        CHECK(*std::max_element(got.begin(), got.end()) > 1e3);
      }
}

}  // namespace

// On a CPU with AVX-512 the stage takes its x86-64-v4 lanes (8 doubles, 16 floats), else (or with
// FLIPFLOW_NO_AVX512 set: CTest's test_pair_lj_avx2) the AVX2 lanes; each must give these bits.
TEST_CASE("pair.lj: the CPU loop's vector lanes give the scalar functor's bits, any thread count", "[pair]") {
  INFO("lanes: " << (cpu_has_x86_64_v4() ? "AVX-512 (x86-64-v4)" : "AVX2"));
  lanes_match_functor<double, 3>(Precision::f64);
  lanes_match_functor<double, 2>(Precision::f64);
  lanes_match_functor<float, 3>(Precision::f32);
  lanes_match_functor<float, 2>(Precision::f32);
}
