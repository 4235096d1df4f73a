// What the boids tests share: a state of boids at given positions and headings in a periodic
// square box, a neighbour list written directly into the fields of stages/neighbors/list.h (every
// other boid, ascending: what any list source must give when everyone is in range), and a driver
// for boids.forces + boids.integrate (optionally after neighbors.verlet).
#pragma once
#include <cmath>
#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/stage/stage_registration.h"
#include "plugins/boids/heading.h"
#include "stages/neighbors/list.h"
#include "support/fields.h"
#include "support/stage_driver.h"
#include "support/test_plugins.h"

namespace ff::boids_test {
using namespace ff::boids;

inline const Registry& registry() {
  static const auto r = ff::test::registry_with({"boids"});
  return *r;
}

template <class T>
void set_field(State& s, const char* name, const std::vector<double>& v) {
  Field& f = s.field(name);
  f.acquire(Where::host, Mode::write);
  for (std::size_t i = 0; i < v.size(); ++i) f.host<T>()[i] = T(v[i]);
}
inline void set_real(State& s, const char* name, const std::vector<double>& v) {
  if (s.precision() == Precision::f64) set_field<double>(s, name, v);
  else set_field<float>(s, name, v);
}

// Boids at x (n x 2) with headings u (n x 2) in a periodic box of side L.
inline std::unique_ptr<State> boids(Precision p, double L, const std::vector<double>& x, const std::vector<double>& u) {
  auto s = std::make_unique<State>(2, p, x.size() / 2);
  s->box.L[0] = s->box.L[1] = L;
  set_real(*s, fields::position, x);
  s->add_particle_field(kHeading, s->real(), 2);
  set_real(*s, kHeading, u);
  return s;
}

// n boids uniformly at random in [0, L)², headings uniformly random (std::mt19937_64 of `seed`).
inline std::unique_ptr<State> random_boids(Precision p, std::size_t n, double L, unsigned seed) {
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> u01(0, 1);
  std::vector<double> x(2 * n), u(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    x[2 * i] = L * u01(g);
    x[2 * i + 1] = L * u01(g);
    const double a = 2 * kPi * u01(g);
    u[2 * i] = std::cos(a);
    u[2 * i + 1] = std::sin(a);
  }
  return boids(p, L, x, u);
}

// The neighbour list "every other boid", rows ascending, with cutoff `cutoff`.
inline void full_list(State& s, double cutoff) {
  const std::size_t n = s.n(), cap = n > 1 ? n - 1 : 1;
  Field& list = s.add_field(neighbors::kList, DType::u32, 1, n * cap);
  Field& count = s.add_particle_field(neighbors::kCount, DType::u32, 1);
  list.acquire(Where::host, Mode::write);
  count.acquire(Where::host, Mode::write);
  for (std::size_t i = 0; i < n; ++i) {
    std::uint32_t k = 0;
    for (std::size_t j = 0; j < n; ++j)
      if (j != i) list.host<std::uint32_t>()[i * cap + k++] = std::uint32_t(j);
    count.host<std::uint32_t>()[i] = k;
  }
  s.add_field(neighbors::kCutoff, s.real(), 1, 1);
  set_real(s, neighbors::kCutoff, {cutoff});
}

// boids.forces then boids.integrate (after neighbors.verlet when `verlet_cutoff` > 0), stepped
// with Δt = dt; run.dt = dt.
struct Flock {
  Flock(State& s, Backend b, const ff::test::ParamSettings& forces, const ff::test::ParamSettings& integrate, double dt,
        double verlet_cutoff = 0)
      : state(s), dt(dt), forces_(b, s.precision(), 2), integrate_(b, s.precision(), 2),
        verlet_(b, s.precision(), 2) {
    if (verlet_cutoff > 0) {
      verlet_.stage = make(b, "neighbors.verlet", {{"cutoff", verlet_cutoff}, {"skin", 0.5}});
      verlet_.stage->configure(s);
    }
    forces_.stage = make(b, "boids.forces", forces);
    integrate_.stage = make(b, "boids.integrate", integrate);
    forces_.stage->configure(s);
    integrate_.stage->configure(s);
  }
  void step() {
    if (verlet_.stage) verlet_.step(state, k, dt);
    forces_.step(state, k, dt);
    integrate_.step(state, k, dt);
    ++k;
  }
  // Φ = |Σ u_i| / N of the current headings.
  double phi() const {
    const auto u = ff::test::values(state, kHeading);
    double px = 0, py = 0;
    for (std::size_t i = 0; i < state.n(); ++i) {
      px += u[2 * i];
      py += u[2 * i + 1];
    }
    return std::sqrt(px * px + py * py) / double(state.n());
  }

  State& state;
  double dt;
  std::uint64_t k = 0;

 private:
  std::unique_ptr<Stage> make(Backend b, const std::string& name, const ff::test::ParamSettings& set) {
    ParamValues v = ParamValues::defaults(registry().get(name).decl.params);
    for (auto& kv : set) v.set(kv.first, kv.second);
    RunInfo info;
    info.dim = 2;
    info.precision = state.precision();
    info.backend = b;
    info.seed = 1;
    info.dt = dt;
    info.stage_id = name;
    return registry().create(name, b, v, info);
  }
  ff::test::StageDriver forces_, integrate_, verlet_;
};

}  // namespace ff::boids_test
