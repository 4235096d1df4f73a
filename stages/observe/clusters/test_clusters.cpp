// observe.clusters: hand-built configurations with known answers (lattice pieces, two species,
// chains that wrap the box, 3D), an O(N²) union-find on random states, labels for 1 and 4
// threads, the three pair sources on one hard-disk state (triangulation from delaunay.build,
// list from neighbors.verlet), the refusals, and the reference program's numbers
// (shared/specs/seed-gaps-code/tran_aggregation_bd.cpp, its RSA start at φ = 0.15). The CSV
// files: test_clusters_files.cpp.
#include <oneapi/tbb/global_control.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numeric>
#include <random>
#include <sstream>

#include "core/base/error.h"
#include "stages/observe/clusters/test_support.h"

using namespace ff;
using namespace ff::test::clusters_test;
using ff::test::ParamSettings;

namespace {

std::vector<std::int32_t> brute_force_labels(const State& s, double bond) {
  const std::size_t n = s.n();
  const int dim = s.dim();
  const double* x = s.field(fields::position).host<double>();
  const double* d = s.field(fields::diameter).host<double>();
  std::vector<std::int32_t> label(n);
  std::iota(label.begin(), label.end(), 0);
  // Relabel to the minimum until nothing changes (slow, obviously right).
  for (bool changed = true; changed;) {
    changed = false;
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = i + 1; j < n; ++j) {
        double r2 = 0;
        for (int k = 0; k < dim; ++k) {
          double dd = x[j * dim + k] - x[i * dim + k];
          dd -= s.box.L[k] * std::rint(dd / s.box.L[k]);
          r2 += dd * dd;
        }
        const double sij = 0.5 * (d[i] + d[j]);
        if (r2 < bond * bond * sij * sij && label[i] != label[j]) {
          label[i] = label[j] = std::min(label[i], label[j]);
          changed = true;
        }
      }
  }
  return label;
}

// Random sequential addition of n disks/spheres of diameter 1 (no two closer than 1).
std::vector<Particle> rsa(int dim, std::size_t n, const double* L, std::uint64_t seed) {
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Particle> ps;
  while (ps.size() < n) {
    Particle p{u(g) * L[0], u(g) * L[1], dim == 3 ? u(g) * L[2] : 0.0, 0};
    bool ok = true;
    for (auto& q : ps) {
      const double c[3] = {p.x - q.x, p.y - q.y, p.z - q.z};
      double r2 = 0;
      for (int k = 0; k < dim; ++k) {
        const double dd = c[k] - L[k] * std::rint(c[k] / L[k]);
        r2 += dd * dd;
      }
      if (r2 < 1.0) {
        ok = false;
        break;
      }
    }
    if (ok) ps.push_back(p);
  }
  return ps;
}

}  // namespace

TEST_CASE("observe.clusters: pieces of a square lattice", "[clusters]") {
  // test_support.h's lattice_pieces: a 3x3 block, a line of 4, a dimer, three monomers.
  std::vector<std::size_t> perm;
  const std::vector<Particle> scrambled = lattice_pieces(&perm);
  const double L[3] = {20, 20, 0};
  auto s = make_state(2, scrambled, L);
  const Measured r = measure(*s);
  CHECK(r.m.at("clusters") == 6);
  CHECK(r.m.at("aggregates") == 3);
  CHECK(r.m.at("monomers") == 3);
  CHECK(r.m.at("largest") == 9);
  CHECK(r.m.at("largest_fraction") == 0.5);
  CHECK(r.m.at("mean_aggregate_size") == 5.0);        // (9 + 4 + 2) / 3
  CHECK(r.m.at("coordination") == Approx(32.0 / 15)); // (24 + 6 + 2) / 15
  CHECK(r.m.at("bonds") == 16);
  CHECK(r.m.at("bonds_A_A") == 16);
  CHECK(r.m.at("unlike_fraction") == 0);
  CHECK(r.m.at("percolating") == 0);
  // Labels: the smallest index of each piece (original piece k -> positions of its members).
  auto piece_of = [](std::size_t orig) { return orig < 9 ? 0 : orig < 13 ? 1 : orig < 15 ? 2 : int(orig); };
  std::map<int, std::int32_t> smallest;
  for (std::size_t i = 0; i < perm.size(); ++i) {
    const int p = piece_of(perm[i]);
    if (!smallest.count(p)) smallest[p] = std::int32_t(i);
  }
  for (std::size_t i = 0; i < perm.size(); ++i) CHECK(r.label[i] == smallest[piece_of(perm[i])]);
  // min_size 3 drops the dimer: 2 aggregates of 13 particles; coordination over those 13.
  const Measured r3 = measure(*make_state(2, scrambled, L), {{"min_size", std::int64_t(3)}});
  CHECK(r3.m.at("aggregates") == 2);
  CHECK(r3.m.at("mean_aggregate_size") == 6.5);
  CHECK(r3.m.at("coordination") == Approx(30.0 / 13));
  // A coordination radius of 1.5 counts the diagonals too (block: 8 inside, 5 on edges, 3 at
  // corners: Σ 40), bonds unchanged.
  const Measured rn = measure(*make_state(2, scrambled, L), {{"neighbor_radius", 1.5}});
  CHECK(rn.m.at("bonds") == 16);
  CHECK(rn.m.at("coordination") == Approx(48.0 / 15));
}

TEST_CASE("observe.clusters: the bond test is strict, and σ_ij is the mean diameter", "[clusters]") {
  const double L[3] = {10, 10, 0};
  // Exactly bond·σ apart (1.5 is exact in binary): not bonded.
  auto s = make_state(2, {{0.5, 0.5, 0, 0}, {2.0, 0.5, 0, 0}}, L);
  CHECK(measure(*s, {{"bond", 1.5}}).m.at("bonds") == 0);
  auto s2 = make_state(2, {{0.5, 0.5, 0, 0}, {1.99, 0.5, 0, 0}}, L);
  CHECK(measure(*s2, {{"bond", 1.5}}).m.at("bonds") == 1);
  // σ_A = 1, σ_B = 1.4: an A–B pair at 1.3 is bonded (1.3 < 1.1·1.2), an A–A pair at 1.3 is not.
  auto s3 = make_state(2, {{1, 1, 0, 0}, {2.3, 1, 0, 1}, {1, 5, 0, 0}, {2.3, 5, 0, 0}}, L, {1.0, 1.4});
  const Measured r = measure(*s3);
  CHECK(r.m.at("bonds") == 1);
  CHECK(r.m.at("bonds_A_B") == 1);
  CHECK(r.m.at("bonds_A_A") == 0);
  CHECK(r.label == std::vector<std::int32_t>{0, 0, 2, 3});
}

TEST_CASE("observe.clusters: two species: bonds per type pair, unlike fraction, the types filter", "[clusters]") {
  // An alternating chain A B A B A B (5 unlike bonds), an A–A dimer, a B–B dimer.
  std::vector<Particle> ps;
  for (int i = 0; i < 6; ++i) ps.push_back({1.0 + i, 1.0, 0, i % 2});
  ps.push_back({1.0, 5.0, 0, 0});
  ps.push_back({2.0, 5.0, 0, 0});
  ps.push_back({1.0, 9.0, 0, 1});
  ps.push_back({2.0, 9.0, 0, 1});
  const double L[3] = {15, 15, 0};
  const Measured r = measure(*make_state(2, ps, L, {1.0, 1.0}));
  CHECK(r.m.at("bonds") == 7);
  CHECK(r.m.at("bonds_A_A") == 1);
  CHECK(r.m.at("bonds_A_B") == 5);
  CHECK(r.m.at("bonds_B_B") == 1);
  CHECK(r.m.at("unlike_fraction") == Approx(5.0 / 7));
  CHECK(r.m.at("aggregates") == 3);
  CHECK(r.m.at("largest") == 6);
  // Only A: the chain's A are 2 apart (monomers), the A–A dimer remains; B particles get -1.
  const Measured a = measure(*make_state(2, ps, L, {1.0, 1.0}), {{"types", std::vector<std::string>{"A"}}});
  CHECK(a.m.at("bonds") == 1);
  CHECK(a.m.at("aggregates") == 1);
  CHECK(a.m.at("monomers") == 3);
  CHECK(a.m.at("clusters") == 4);
  CHECK(a.m.at("largest_fraction") == Approx(2.0 / 5));
  CHECK(a.m.count("bonds_A_B") == 0);
  CHECK(a.label == std::vector<std::int32_t>{0, -1, 2, -1, 4, -1, 6, 6, -1, -1});
  CHECK_THROWS_WITH(measure(*make_state(2, ps, L, {1.0, 1.0}), {{"types", std::vector<std::string>{"C"}}}),
                    Catch::Contains("types: no species 'C'"));
}

TEST_CASE("observe.clusters: percolation along the axis a chain wraps, and only there", "[clusters]") {
  const double L[3] = {10, 12, 0};
  // 10 particles at spacing 1 around x: the chain closes on itself through the boundary.
  std::vector<Particle> ring;
  for (int i = 0; i < 10; ++i) ring.push_back({0.5 + i, 3.0 + 0.05 * (i % 2), 0, 0});
  const Measured r = measure(*make_state(2, ring, L));
  CHECK(r.m.at("clusters") == 1);
  CHECK(r.m.at("bonds") == 10);
  CHECK(r.m.at("percolating") == 1);
  CHECK(r.m.at("percolating_x") == 1);
  CHECK(r.m.at("percolating_y") == 0);
  // Cut once: still one aggregate (it crosses the boundary), no longer wrapping.
  ring.erase(ring.begin() + 4);
  const Measured c = measure(*make_state(2, ring, L));
  CHECK(c.m.at("aggregates") == 1);
  CHECK(c.m.at("largest") == 9);
  CHECK(c.m.at("percolating") == 0);
  // A chain of 5 across the y boundary: 1 aggregate of 5, no percolation.
  std::vector<Particle> across;
  for (int i = 0; i < 5; ++i) across.push_back({5.0, 10.0 + i, 0, 0});
  const Measured a = measure(*make_state(2, across, L));
  CHECK(a.m.at("aggregates") == 1);
  CHECK(a.m.at("largest") == 5);
  CHECK(a.m.at("percolating") == 0);
}

TEST_CASE("observe.clusters: 3D with cells: a cube, a column wrapping z", "[clusters][3d]") {
  const double L[3] = {8, 9, 6};
  std::vector<Particle> ps;
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) ps.push_back({1.0 + i, 1.0 + j, 1.0 + k, 0});  // 12 bonds, 3 each
  for (int k = 0; k < 6; ++k) ps.push_back({5.0, 5.0, 0.5 + k, 0});            // ring around z
  ps.push_back({5.0, 1.0, 3.0, 0});
  const Measured r = measure(*make_state(3, ps, L));
  CHECK(r.m.at("clusters") == 3);
  CHECK(r.m.at("aggregates") == 2);
  CHECK(r.m.at("bonds") == 18);
  CHECK(r.m.at("coordination") == Approx((8 * 3 + 6 * 2) / 14.0));
  CHECK(r.m.at("percolating") == 1);
  CHECK(r.m.at("percolating_x") == 0);
  CHECK(r.m.at("percolating_y") == 0);
  CHECK(r.m.at("percolating_z") == 1);
  CHECK(r.label[8] == 8);
  CHECK(r.label[13] == 8);
  CHECK(r.label[14] == 14);
}

TEST_CASE("observe.clusters: random states equal an O(N²) union-find, for 1, 2 and 8 threads", "[clusters]") {
  for (int dim : {2, 3}) {
    INFO(dim << "D");
    const std::size_t n = 2000;
    const double phi = 0.3;
    const double pi = 3.14159265358979323846;
    const double side = dim == 2 ? std::sqrt(n * pi / 4 / phi) : std::cbrt(n * pi / 6 / phi);
    const double L[3] = {side, side * 1.1, side * 0.9};
    std::mt19937_64 g(11 + dim);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<Particle> ps(n);
    for (auto& p : ps) p = {u(g) * L[0], u(g) * L[1], u(g) * L[2], int(u(g) * 2)};
    auto s = make_state(dim, ps, L, {1.0, 0.8});
    const auto expected = brute_force_labels(*s, 1.1);
    Measured one;
    {
      tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
      one = measure(*s);
    }
    CHECK(one.label == expected);
    for (int threads : {2, 8}) {
      tbb::global_control c(tbb::global_control::max_allowed_parallelism, threads);
      const Measured many = measure(*s);
      CHECK(many.label == expected);
      CHECK(many.m == one.m);
    }
    std::map<std::int32_t, int> size;
    for (auto l : expected) ++size[l];
    int largest = 0, monomers = 0;
    for (auto& kv : size) {
      largest = std::max(largest, kv.second);
      monomers += kv.second == 1;
    }
    CHECK(one.m.at("clusters") == double(size.size()));
    CHECK(one.m.at("largest") == largest);
    CHECK(one.m.at("monomers") == monomers);
  }
}

namespace {

// n = nx·ny disks on a triangular lattice at packing fraction phi, each moved by a uniform random
// displacement within (a − 1)/2 of its site (a the lattice spacing): no two closer than 1.
std::vector<Particle> perturbed_lattice(std::size_t nx, std::size_t ny, double phi, double* L, std::uint64_t seed) {
  const double a = std::sqrt(3.14159265358979323846 / (2 * std::sqrt(3.0)) / phi);
  L[0] = double(nx) * a;
  L[1] = double(ny) * a * std::sqrt(3.0) / 2;
  L[2] = 0;
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Particle> ps;
  for (std::size_t r = 0; r < ny; ++r)
    for (std::size_t c = 0; c < nx; ++c) {
      const double rho = 0.5 * (a - 1) * std::sqrt(u(g)), t = 2 * 3.14159265358979323846 * u(g);
      ps.push_back({(double(c) + 0.5 * double(r % 2)) * a + rho * std::cos(t),
                    double(r) * a * std::sqrt(3.0) / 2 + rho * std::sin(t), 0.0, 0});
    }
  return ps;
}

}  // namespace

TEST_CASE("observe.clusters: cells, verlet and delaunay pairs agree on hard-disk states", "[clusters][sources]") {
  // 1200 disks: by random sequential addition (no overlaps) at φ ≈ 0.45, and on a perturbed
  // triangular lattice at φ = 0.7 (the dense case; neighbours at 1.00–1.28 σ, so the
  // bond threshold 1.1 σ cuts through the first shell).
  const std::size_t n = 1200;
  const bool dense = GENERATE(false, true);
  CAPTURE(dense);
  double L[3];
  std::vector<Particle> ps;
  if (dense) {
    ps = perturbed_lattice(30, 40, 0.7, L, 5);
  } else {
    const double side = std::sqrt(n * 3.14159265358979323846 / 4 / 0.45);
    L[0] = L[1] = side;
    L[2] = 0;
    ps = rsa(2, n, L, 3);
  }
  auto s = make_state(2, ps, L);
  test::StageDriver drv(Backend::cpu, Precision::f64, 2);
  auto verlet = test::make_stage(registry(), "neighbors.verlet", Backend::cpu, Precision::f64, 2,
                                 {{"cutoff", 1.5}, {"skin", 0.3}});
  verlet->configure(*s);
  drv.run(*verlet, *s, 1);
  auto build = test::make_stage(registry(), "delaunay.build", Backend::cpu, Precision::f64, 2);
  build->configure(*s);
  drv.run(*build, *s, 1);

  const auto dir = std::filesystem::temp_directory_path() / "flipflow_test_clusters_sources";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  std::map<std::string, Measured> got;
  for (std::string src : {"cells", "verlet", "delaunay"}) {
    auto st = clusters(2, {{"pairs", src}, {"label_field", true}, {"file", src + ".csv"}, {"sizes_file", src + "_sizes.csv"}},
                       dir.string());
    st->configure(*s);
    drv.run(*st, *s, 7);
    st->finish(*s, true);
    const std::int32_t* l = s->field(observe::cluster_label_field).host<std::int32_t>();
    got[src] = {drv.metrics.values(), std::vector<std::int32_t>(l, l + n)};
    // The file: one row, step 7, the pairs were used as asked (fallback 0).
    std::ifstream in(dir / (src + ".csv"));
    std::string comment, header, row;
    std::getline(in, comment);
    std::getline(in, header);
    std::getline(in, row);
    CHECK(header.rfind("step,time,clusters,aggregates,monomers,largest,", 0) == 0);
    CHECK(row.rfind("7,", 0) == 0);
    CHECK(row.substr(row.size() - 2) == ",0");
  }
  CHECK(got["cells"].m.at("bonds") > 100);  // the comparison has something to compare
  CHECK(got["verlet"].label == got["cells"].label);
  CHECK(got["delaunay"].label == got["cells"].label);
  CHECK(got["verlet"].m == got["cells"].m);
  CHECK(got["delaunay"].m == got["cells"].m);
  CHECK(got["cells"].label == brute_force_labels(*s, 1.1));

  // Particles moved since the list was built beyond what its cutoff covers: the stage uses its
  // own cells for that call (fallback 1) and still gives the bonds of the new positions.
  double* x = s->field(fields::position).host<double>();
  x[0] = std::fmod(x[0] + 0.25, L[0]);
  auto st = clusters(2, {{"pairs", std::string("verlet")}, {"label_field", true}}, dir.string());
  st->configure(*s);
  drv.run(*st, *s, 8);
  st->finish(*s, true);
  std::ifstream in(dir / "clusters.csv");
  std::string line, last;
  while (std::getline(in, line)) last = line;
  CHECK(last.substr(last.size() - 2) == ",1");
  const std::int32_t* l = s->field(observe::cluster_label_field).host<std::int32_t>();
  CHECK(std::vector<std::int32_t>(l, l + n) == brute_force_labels(*s, 1.1));
  std::ifstream sizes(dir / "cells_sizes.csv");
  std::getline(sizes, line);
  std::getline(sizes, line);
  CHECK(line.rfind("step,time,n1,n2,", 0) == 0);
  CHECK(line.substr(line.size() - 12) == ",n63,n64plus");
  std::filesystem::remove_all(dir);
}

TEST_CASE("observe.clusters: refusals name the key", "[clusters][errors]") {
  const double L[3] = {10, 10, 0};
  auto s = make_state(2, {{1, 1, 0, 0}, {2, 1, 0, 0}, {5, 5, 0, 1}}, L, {1.0, 1.0});
  // No triangulation in the state.
  CHECK_THROWS_WITH(clusters(2, {{"pairs", std::string("delaunay")}})->configure(*s),
                    Catch::Contains("pairs: delaunay needs the maintained triangulation"));
  auto build = test::make_stage(registry(), "delaunay.build", Backend::cpu, Precision::f64, 2);
  build->configure(*s);
  // Equal diameters: bond ≤ √2 is allowed, 1.5 is not.
  CHECK_NOTHROW(clusters(2, {{"pairs", std::string("delaunay")}, {"bond", 1.414}})->configure(*s));
  CHECK_THROWS_WITH(clusters(2, {{"pairs", std::string("delaunay")}, {"bond", 1.5}})->configure(*s),
                    Catch::Contains("Gabriel bound"));
  CHECK_THROWS_WITH(clusters(2, {{"pairs", std::string("delaunay")}, {"neighbor_radius", 1.5}})->configure(*s),
                    Catch::Contains("Gabriel bound"));
  // Unequal diameters: two A (σ 1) with a small B (σ 0.2) between them: 1.21/(0.36 + 0.36) > 1.
  auto s2 = make_state(2, {{1, 1, 0, 0}, {2, 1, 0, 0}, {5, 5, 0, 1}}, L, {1.0, 0.2});
  build->configure(*s2);
  CHECK_THROWS_WITH(clusters(2, {{"pairs", std::string("delaunay")}})->configure(*s2), Catch::Contains("Gabriel bound"));
  // ... unless only A take part and no B exists... B exists here, so still refused; with B alone
  // taking part the bound holds (0.2²·1.21 / (2·0.6²) < 1).
  CHECK_NOTHROW(clusters(2, {{"pairs", std::string("delaunay")}, {"types", std::vector<std::string>{"B"}}})->configure(*s2));
  // 3D has no triangulation.
  const double L3[3] = {10, 10, 10};
  auto s3 = make_state(3, {{1, 1, 1, 0}, {2, 1, 1, 0}}, L3);
  CHECK_THROWS_WITH(clusters(3, {{"pairs", std::string("delaunay")}})->configure(*s3), Catch::Contains("2D"));
  // Verlet: no list; a cutoff shorter than the bond.
  CHECK_THROWS_WITH(clusters(2, {{"pairs", std::string("verlet")}})->configure(*s),
                    Catch::Contains("needs neighbors.verlet"));
  auto verlet = test::make_stage(registry(), "neighbors.verlet", Backend::cpu, Precision::f64, 2,
                                 {{"cutoff", 1.05}, {"skin", 0.3}});
  verlet->configure(*s);
  CHECK_THROWS_WITH(clusters(2, {{"pairs", std::string("verlet")}})->configure(*s),
                    Catch::Contains("Verlet cutoff 1.05"));
  CHECK_NOTHROW(clusters(2, {{"pairs", std::string("verlet")}, {"bond", 1.05}})->configure(*s));
  // A bond reaching half the box.
  CHECK_THROWS_WITH(clusters(2, {{"bond", 5.0}})->configure(*s), Catch::Contains("half the smallest box edge"));
}

TEST_CASE("observe.clusters: the reference program's RSA start (Tran φ = 0.15, N = 3000)", "[clusters][reference]") {
  // tran_aggregation_bd.cpp 3000 0.15 ... 1.1 (seed 1) prints at t = 0: 508 aggregates, 1672
  // monomers, largest 10, 2·bonds/N = 0.5573 (tran_a15.out, first row). Its start, redrawn here
  // with the same generator and draws: RSA with r ≥ 1 in L = (Nπ/(6φ))^{1/3}.
  const int N = 3000;
  const double phi = 0.15, L = std::cbrt(N * 3.14159265358979323846 / 6 / phi);
  std::mt19937_64 g(1);
  std::uniform_real_distribution<double> u(0, L);
  std::vector<double> x(3 * N);
  auto mi = [&](double d) { return d - L * std::round(d / L); };
  for (int i = 0; i < N; i++) {
    for (;;) {
      double p[3] = {u(g), u(g), u(g)};
      bool ok = true;
      for (int j = 0; j < i && ok; j++) {
        double r2 = 0;
        for (int k = 0; k < 3; k++) {
          const double d = mi(p[k] - x[3 * j + k]);
          r2 += d * d;
        }
        if (r2 < 1.0) ok = false;
      }
      if (ok) {
        for (int k = 0; k < 3; k++) x[3 * i + k] = p[k];
        break;
      }
    }
  }
  std::vector<Particle> ps(N);
  for (int i = 0; i < N; ++i) ps[i] = {x[3 * i], x[3 * i + 1], x[3 * i + 2], 0};
  const double box[3] = {L, L, L};
  const Measured r = measure(*make_state(3, ps, box));
  CHECK(r.m.at("aggregates") == 508);
  CHECK(r.m.at("monomers") == 1672);
  CHECK(r.m.at("largest") == 10);
  CHECK(r.m.at("bonds") == 836);  // 2·836/3000 = 0.55733
}
