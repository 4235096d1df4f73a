// The delaunay stage tests' helpers: their registry (the delaunay stage library alone), stages
// made and driven as every stage test drives them (tests/support/stage_driver.h), and meshes:
// hand-made 2D states, positions and topology read back on the host, checks against CGAL, point
// sets and a perturbed lattice to move particles across edges in.
#pragma once
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/physics/rng.h"
#include "core/stage/registry.h"
#include "core/stage/stage.h"
#include "core/stage/state.h"
#include "stages/delaunay/common/fields.h"
#include "stages/delaunay/common/mesh_check.h"
#include "support/backends.h"
#include "support/fields.h"
#include "support/stage_driver.h"
#include "support/test_plugins.h"

namespace ff::test::dl {

namespace dfields = ff::delaunay::fields;

inline const Registry& registry() {
  static const std::unique_ptr<Registry> r = registry_of({"delaunay"});
  return *r;
}

inline std::unique_ptr<Stage> make_stage(const std::string& name, Backend b, Precision p = Precision::f64,
                                         const ParamSettings& set = {}) {
  return test::make_stage(registry(), name, b, p, 2, set);
}

// Runs stages on one State: a StageDriver (stage_driver.h) bound to it.
class Runner : public StageDriver {
 public:
  Runner(State& s, Backend b) : StageDriver(b, s.precision(), 2), s_(s) {}
  Outcome run(Stage& st, std::uint64_t step = 0, double dt = 0.01) { return StageDriver::run(st, s_, step, dt); }

 private:
  State& s_;
};

inline std::unique_ptr<State> make_state(const std::vector<double>& xy, double Lx, double Ly,
                                         Precision p = Precision::f64) {
  auto s = std::make_unique<State>(2, p, xy.size() / 2);
  s->box.L[0] = Lx;
  s->box.L[1] = Ly;
  Field& f = s->field(fields::position);
  for (std::size_t i = 0; i < xy.size(); ++i) {
    const double L = i % 2 ? Ly : Lx;
    const double x = xy[i] - L * std::floor(xy[i] / L);
    if (p == Precision::f64)
      f.host<double>()[i] = x;
    else
      f.host<float>()[i] = float(x);
  }
  return s;
}

using ff::test::positions;

inline void set_positions(State& s, const std::vector<double>& xy) {
  Field& f = s.field(fields::position);
  f.acquire(Where::host, Mode::write);
  for (std::size_t i = 0; i < xy.size(); ++i) {
    const double L = s.box.L[i % 2];
    double x = xy[i] - L * std::floor(xy[i] / L);
    if (x >= L) x -= L;
    if (s.precision() == Precision::f64)
      f.host<double>()[i] = x;
    else
      f.host<float>()[i] = float(x);
  }
}

struct Topo {
  std::vector<std::int32_t> he, vedge, opp;
};

inline Topo topology(State& s) {
  Field& he = s.field(dfields::halfedge);
  Field& ve = s.field(dfields::vertex_edge);
  Field& op = s.field(dfields::opposite);
  he.acquire(Where::host, Mode::read);
  ve.acquire(Where::host, Mode::read);
  op.acquire(Where::host, Mode::read);
  return {std::vector<std::int32_t>(he.host<std::int32_t>(), he.host<std::int32_t>() + he.size()),
          std::vector<std::int32_t>(ve.host<std::int32_t>(), ve.host<std::int32_t>() + ve.size()),
          std::vector<std::int32_t>(op.host<std::int32_t>(), op.host<std::int32_t>() + op.size())};
}

// Structure valid, every triangle positive and closed, 3N edges.
inline void require_valid(State& s) {
  const Topo t = topology(s);
  REQUIRE(t.he.size() == 2 * 6 * s.n());
  REQUIRE(ff::delaunay::check_structure(t.he.data(), t.vedge.data(), s.n()) == "");
  REQUIRE(ff::delaunay::check_opposite(t.he.data(), t.opp.data(), s.n()) == "");
  const auto xy = positions(s);
  REQUIRE(ff::delaunay::count_bad_triangles(t.he.data(), s.n(), xy.data(), s.box.L[0], s.box.L[1]) == 0);
}

// Edges of `t` that are not in `ref` and are not co-circular ties (|incircle|/perm > 1e-9).
inline std::size_t real_differences(const Topo& t, const Topo& ref, State& s) {
  const auto xy = positions(s);
  const auto e1 = ff::delaunay::edge_set(t.he.data(), s.n());
  const auto e2 = ff::delaunay::edge_set(ref.he.data(), s.n());
  std::vector<std::pair<int, int>> only;
  std::set_difference(e1.begin(), e1.end(), e2.begin(), e2.end(), std::back_inserter(only));
  std::size_t real = 0;
  for (auto& e : only)
    if (ff::delaunay::cocircularity(t.he.data(), s.n(), xy.data(), s.box.L[0], s.box.L[1], e.first, e.second) > 1e-9)
      ++real;
  return real;
}

// A fresh CGAL triangulation of the state's current positions (delaunay.build on a copy).
inline Topo cgal_reference(State& s) {
  auto copy = make_state(positions(s), s.box.L[0], s.box.L[1], Precision::f64);
  auto build = make_stage("delaunay.build", Backend::cpu);
  build->configure(*copy);
  Runner r(*copy, Backend::cpu);
  REQUIRE_FALSE(r.run(*build).rollback);
  return topology(*copy);
}

// Uniform random points (Philox, seeded).
inline std::vector<double> random_points(std::size_t n, double Lx, double Ly, std::uint64_t seed) {
  const RngKey key = make_rng_key(seed, "delaunay-test");
  std::vector<double> xy(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    xy[2 * i] = Lx * (1.0 - uniform01(key, std::uint32_t(i), 0, 0, 0));
    xy[2 * i + 1] = Ly * (1.0 - uniform01(key, std::uint32_t(i), 0, 0, 1));
  }
  return xy;
}

// nx x ny square lattice with spacing a (box nx*a x ny*a), optionally shifted.
inline std::vector<double> square_lattice(int nx, int ny, double a, double shift = 0.25) {
  std::vector<double> xy;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      xy.push_back((i + shift) * a);
      xy.push_back((j + shift) * a);
    }
  return xy;
}

// nx x ny triangular lattice (ny even), spacing a; box nx*a x ny*a*sqrt(3)/2.
inline std::vector<double> triangular_lattice(int nx, int ny, double a) {
  std::vector<double> xy;
  const double h = a * std::sqrt(3.0) / 2;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      xy.push_back((i + 0.5 * (j % 2) + 0.25) * a);
      xy.push_back((j + 0.25) * h);
    }
  return xy;
}

}  // namespace ff::test::dl

namespace ff::test::dl {

// A built triangulation of a slightly perturbed 10 x 10 triangular lattice, and geometric
// helpers to move particles across its edges (Carter et al. 2017, figs. 4–6).
struct Scene {
  std::unique_ptr<State> s;
  Topo t;
  std::vector<double> xy;

  explicit Scene(Precision p = Precision::f64, int nx = 10, int ny = 10) {
    auto pts = triangular_lattice(nx, ny, 1.0);
    const RngKey key = make_rng_key(3, "scene");
    for (std::size_t i = 0; i < pts.size(); ++i) pts[i] += 0.04 * (uniform01(key, std::uint32_t(i), 0, 0, 0) - 0.5);
    s = make_state(pts, nx, ny * std::sqrt(3.0) / 2, p);
    auto build = make_stage("delaunay.build", Backend::cpu, p);
    build->configure(*s);
    Runner r(*s, Backend::cpu);
    REQUIRE_FALSE(r.run(*build).rollback);
    t = topology(*s);
    xy = positions(*s);
  }
  std::size_t n() const { return s->n(); }
  int origin(int h) const { return t.he[2 * h]; }
  int next(int h) const { return t.he[2 * h + 1]; }
  int edge_of(int a, int b) const {
    for (int e = 0; e < int(3 * n()); ++e)
      if ((origin(2 * e) == a && origin(2 * e + 1) == b) || (origin(2 * e) == b && origin(2 * e + 1) == a)) return e;
    return -1;
  }
  // Position of j unwrapped next to i (minimum image).
  std::array<double, 2> near(int i, int j) const {
    double d[2];
    for (int k = 0; k < 2; ++k) {
      const double L = s->box.L[k];
      d[k] = xy[2 * j + k] - xy[2 * i + k];
      d[k] -= L * std::rint(d[k] / L);
    }
    return {xy[2 * i] + d[0], xy[2 * i + 1] + d[1]};
  }
  // The triangle left of v's first half-edge: (v, p, q), and w beyond edge (p, q).
  struct Fan {
    int v, p, q, w, z;  // z: beyond edge (q, w) of triangle (q, p, w)
    int pq, qw;         // edge ids
  };
  Fan fan(int v) const {
    const int h = t.vedge[v];
    const int hpq = next(h);
    const int hqp = hpq ^ 1;                 // q -> p, triangle (q, p, w)
    const int hwq = next(next(hqp));         // w -> q
    const int hqw = hwq ^ 1;                 // q -> w, triangle (q, w, z)
    return {v, origin(hpq), origin(next(hpq)), origin(next(next(hqp))), origin(next(next(hqw))), hpq >> 1, hqw >> 1};
  }
  // Move particle i to (x, y) (positions only; the topology is unchanged).
  void move(int i, std::array<double, 2> to) {
    xy[2 * i] = to[0];
    xy[2 * i + 1] = to[1];
    set_positions(*s, xy);
    xy = positions(*s);
  }
  // A point on segment from..to at fraction f, unwrapped relative to particle `ref`.
  std::array<double, 2> lerp(std::array<double, 2> a, std::array<double, 2> b, double f) const {
    return {a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])};
  }
  std::array<double, 2> mid(int ref, int a, int b) const { return lerp(near(ref, a), near(ref, b), 0.5); }
  // Carter fig. 5: v crosses edge (p, q) into triangle (q, p, w), just past the edge.
  void cross_one_edge(const Fan& f, double depth = 0.2) {
    move(f.v, lerp(mid(f.v, f.p, f.q), near(f.v, f.w), depth));
  }
  // Carter fig. 6: v crosses (p, q) and then (q, w), into triangle (q, w, z).
  void cross_two_edges(const Fan& f) {
    const auto q = near(f.v, f.q), w = near(f.v, f.w), z = near(f.v, f.z);
    move(f.v, {(q[0] + w[0] + z[0]) / 3, (q[1] + w[1] + z[1]) / 3});
  }
};

inline std::int32_t* status_of(State& s) {
  Field& f = s.field(ff::delaunay::fields::status);
  f.acquire(Where::host, Mode::readwrite);
  return f.host<std::int32_t>();
}

// What the core's rollback snapshot holds for the Delaunay maintenance stages (detect_inversion,
// flip, Lawson: their declared writes), taken and restored on the host as a test drives them.
struct TopologySnapshot {
  std::vector<std::vector<unsigned char>> data;
  const std::vector<std::string> names{fields::position,
                                       dfields::halfedge,
                                       dfields::opposite,
                                       dfields::vertex_edge,
                                       dfields::position_prev,
                                       dfields::flip_mark,
                                       dfields::status};
  void take(State& s) {
    data.clear();
    for (auto& n : names) {
      Field& f = s.field(n);
      f.acquire(Where::host, Mode::read);
      auto* p = static_cast<unsigned char*>(f.host_raw());
      data.emplace_back(p, p + f.bytes());
    }
  }
  void restore(State& s) {
    for (std::size_t k = 0; k < names.size(); ++k) {
      Field& f = s.field(names[k]);
      f.acquire(Where::host, Mode::write);
      std::copy(data[k].begin(), data[k].end(), static_cast<unsigned char*>(f.host_raw()));
    }
  }
};

}  // namespace ff::test::dl
