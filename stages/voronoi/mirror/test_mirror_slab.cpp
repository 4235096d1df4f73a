// voronoi.mirror (spec D2 W2): in the shipped slab pipeline (hard disks between hard walls,
// pipelines/hard-disks-slab-voronoi.yaml, fewer disks; the stage every step, or its observer
// form every 50 steps), every disk's cell equals CGAL's
// non-periodic Voronoi cell clipped at the walls (mirror/clipped_cells.h) to 1e-10 — area,
// perimeter with the wall segments, centroid — and the cells tile the slab (Σ V_i = L_x L_y) at
// every step checked; the stage's own triangulation is maintained by Lawson flips (no rebuild
// after the first step); driven alone: rebuilt after moves that invert its triangles, walls
// along x, and refusals; CPU == CUDA bit for bit (skipped without a GPU). And why the stage
// keeps its own triangulation: the torus cells clipped at the walls differ and leave gaps.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/run/simulation.h"
#include "stages/delaunay/test_support.h"
#include "stages/voronoi/geometry/fields.h"
#include "stages/voronoi/mirror/build.h"
#include "stages/voronoi/mirror/clipped_cells.h"
#include "support/backends.h"
#include "support/cli.h"
#include "support/fields.h"
#include "support/pipeline.h"
#include "support/spec.h"
#include "support/stage_driver.h"

namespace {

using namespace ff;
using ff::test::positions;
using ff::test::values;
namespace vf = ff::voronoi::fields;
namespace dl = ff::test::dl;

double min_image(double d, double L) { return d - L * std::rint(d / L); }

// The shipped slab pipeline with N disks in a box of the same packing fraction (η = 0.3 and
// aspect 64:42), compute stages only (the file's voronoi.mirror_observer is an observer), and
// `stage` appended (every `every` steps).
test::LoadedPipeline slab(std::size_t n, double& Lx, double& Ly, const std::string& stage, std::uint64_t every = 1) {
  Lx = std::sqrt(double(n) * M_PI / 4 / 0.299 * 64.0 / 42.0);
  Ly = Lx * 42.0 / 64.0;
  auto l = test::load_compute_steps(test::repo_file("pipelines/hard-disks-slab-voronoi.yaml").string(),
                                    {"system.N=" + std::to_string(n),
                                     "system.box=[" + std::to_string(Lx) + ", " + std::to_string(Ly) + "]"});
  for (auto& e : l.spec.step) REQUIRE(e.stage.rfind("voronoi.", 0) != 0);
  test::EntryOptions o;
  o.every = every;
  l.spec.step.push_back(test::entry(*l.registry, stage, {{"walls", std::string("y")}}, o));
  return l;
}

std::vector<std::int32_t> ints(State& s, const char* name) {
  Field& f = s.field(name);
  f.acquire(Where::host, Mode::read);
  return std::vector<std::int32_t>(f.host<std::int32_t>(), f.host<std::int32_t>() + f.size());
}

double metric(const Simulation& sim, const std::string& name) {
  auto it = sim.stats().metrics.find("voronoi.mirror/" + name);
  if (it == sim.stats().metrics.end()) it = sim.stats().metrics.find("voronoi.mirror_observer/" + name);
  REQUIRE(it != sim.stats().metrics.end());
  return it->second;
}

// Every cell of the state against the reference for positions x (walls ⟂ `axis`: the
// reference is computed on the transposed points for axis 0).
void require_clipped_cells(State& s, const std::vector<double>& x, int axis = 1) {
  const std::size_t n = s.n();
  const double Lw = s.box.L[axis], Lp = s.box.L[1 - axis];
  std::vector<double> xy(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    xy[2 * i] = x[2 * i + 1 - axis];
    xy[2 * i + 1] = x[2 * i + axis];
  }
  const auto ref = test::slab::clipped_cells(xy, Lp, Lw);
  const auto area = values(s, vf::area), per = values(s, vf::perimeter), c = values(s, vf::centroid);
  double total = 0, worst = 0;
  for (std::size_t i = 0; i < n; ++i) {
    INFO("particle " << i << " at (" << x[2 * i] << ", " << x[2 * i + 1] << ")");
    const double cp = min_image(c[2 * i + 1 - axis] - xy[2 * i], Lp), cw = c[2 * i + axis] - xy[2 * i + 1];
    const double err = std::max({std::fabs(area[i] - ref[i].area), std::fabs(per[i] - ref[i].perimeter),
                                 std::fabs(cp - ref[i].cx), std::fabs(cw - ref[i].cy)});
    REQUIRE(err < 1e-10);
    worst = std::max(worst, err);
    total += area[i];
  }
  INFO("largest difference " << worst);
  CHECK(std::fabs(total / (Lw * Lp) - 1) < 1e-12);
}

}  // namespace

TEST_CASE("voronoi.mirror in the slab pipeline: every disk's cell is CGAL's Voronoi cell clipped at the walls",
          "[voronoi][walls]") {
  const Backend b = GENERATE(from_range(test::backends()));
  double Lx = 0, Ly = 0;
  const auto l = slab(400, Lx, Ly, "voronoi.mirror");
  Simulation sim(l.spec, *l.registry, test::dry(b));
  std::uint64_t rebuilt = 0;
  for (std::uint64_t k = 1; k <= 300; ++k) {
    sim.advance();
    const bool rb = metric(sim, "rebuilt") != 0;
    rebuilt += rb;
    // The triangulation of the first step is built; every later one is maintained.
    if (k > 1) CHECK_FALSE(rb);
    CHECK(std::fabs(metric(sim, "area_sum_error")) < 1e-12);
    if (k == 1 || k % 100 == 0) {
      INFO("step " << k);
      require_clipped_cells(sim.state(), positions(sim.state()));
    }
  }
  CHECK(rebuilt == 1);
  // Why the stage keeps its own triangulation: the cells of the torus (the pipeline's
  // triangulation) clipped at the walls are not these. Edges across the seam cut cells of disks
  // at one wall short by bisectors with disks at the other, so some cells differ and together
  // they no longer tile the slab.
  {
    const auto x = positions(sim.state());
    const auto walled = test::slab::clipped_cells(x, Lx, Ly), torus = test::slab::clipped_cells(x, Lx, Ly, true);
    std::size_t differ = 0;
    double total = 0;
    for (std::size_t i = 0; i < sim.state().n(); ++i) {
      differ += std::fabs(torus[i].area - walled[i].area) > 1e-10;
      total += torus[i].area;
    }
    INFO("the torus cells clipped at the walls: " << differ << " of " << sim.state().n()
         << " differ from the walled cells; they cover " << total / (Lx * Ly) << " of the slab");
    CHECK(differ > 0);
    CHECK(total < Lx * Ly * (1 - 1e-6));
  }
  // Walls at y = 0 and L_y cut cells: some cell touches each wall.
  const auto x = positions(sim.state());
  const auto area = values(sim.state(), vf::area);
  double near_bottom = HUGE_VAL, near_top = HUGE_VAL;
  for (std::size_t i = 0; i < sim.state().n(); ++i) {
    near_bottom = std::min(near_bottom, x[2 * i + 1]);
    near_top = std::min(near_top, Ly - x[2 * i + 1]);
    CHECK(area[i] > 0);
  }
  CHECK(near_bottom < 1.0);
  CHECK(near_top < 1.0);
}

TEST_CASE("voronoi.mirror_observer in the slab pipeline: the cells of the frame's positions, at its steps",
          "[voronoi][walls]") {
  const Backend b = GENERATE(from_range(test::backends()));
  double Lx = 0, Ly = 0;
  const auto l = slab(400, Lx, Ly, "voronoi.mirror_observer", 50);
  Simulation sim(l.spec, *l.registry, test::dry(b));
  for (std::uint64_t k = 1; k <= 150; ++k) {
    sim.advance();
    if (sim.state().step % 50 != 0) continue;
    INFO("step " << sim.state().step);
    // Rebuilt or maintained (50 steps of these disks move them ~0.2σ: usually still valid).
    CHECK(std::fabs(metric(sim, "area_sum_error")) < 1e-12);
    require_clipped_cells(sim.state(), positions(sim.state()));
  }
}

TEST_CASE("voronoi.mirror driven alone: rebuilt after moves that invert its triangles, maintained after small ones; "
          "walls along x; square and rectangular doubled boxes",
          "[voronoi][walls]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const int axis = GENERATE(0, 1);
  // Along the wall axis 20 and across it 30 (a rectangular doubled box: CGAL on the points and
  // their 8 copies) or 40 (a square one: CGAL's periodic triangulation).
  const double across = GENERATE(30.0, 40.0);
  const std::size_t n = 600;
  const double L[2] = {axis == 1 ? across : 20.0, axis == 1 ? 20.0 : across};
  std::vector<double> x = dl::random_points(n, L[0], L[1], 7);
  for (std::size_t i = 0; i < n; ++i)
    if (x[2 * i + axis] == 0) x[2 * i + axis] = 0.5 * L[axis];
  auto s = dl::make_state(x, L[0], L[1]);
  const auto reg = test::registry_of({"delaunay", "voronoi"});
  auto st = test::make_stage(*reg, "voronoi.mirror", b, Precision::f64, 2, {{"walls", std::string(axis ? "y" : "x")}});
  st->configure(*s);
  test::StageDriver d(b, Precision::f64, 2);
  auto move = [&](double amplitude, std::uint64_t seed) {
    const auto dx = dl::random_points(n, 1.0, 1.0, seed);
    for (std::size_t i = 0; i < 2 * n; ++i) {
      double v = x[i] + amplitude * (dx[i] - 0.5);
      const double Lk = L[i % 2];
      if (int(i % 2) == axis) v = std::min(std::max(v, 1e-3), Lk - 1e-3);  // stay between the walls
      x[i] = v - Lk * std::floor(v / Lk);
    }
    dl::set_positions(*s, x);
  };
  REQUIRE_FALSE(d.run(*st, *s).rollback);
  CHECK(d.metric("rebuilt") == 1);
  require_clipped_cells(*s, x, axis);
  move(0.01, 11);  // small moves: the triangulation stays valid, Lawson repairs it
  REQUIRE_FALSE(d.run(*st, *s).rollback);
  CHECK(d.metric("rebuilt") == 0);
  require_clipped_cells(*s, x, axis);
  move(2.0, 12);  // moves past the neighbours: inverted triangles, rebuilt
  REQUIRE_FALSE(d.run(*st, *s).rollback);
  CHECK(d.metric("rebuilt") == 1);
  require_clipped_cells(*s, x, axis);
}

TEST_CASE("voronoi.mirror refuses 3D and a particle on a wall", "[voronoi][walls]") {
  const auto reg = test::registry_of({"delaunay", "voronoi"});
  {
    State s3(3, Precision::f64, 8);
    auto st = test::make_stage(*reg, "voronoi.mirror", Backend::cpu, Precision::f64, 3);
    CHECK_THROWS_AS(st->configure(s3), InputError);
  }
  std::vector<double> x = dl::random_points(64, 8, 8, 3);
  x[2 * 5 + 1] = 0;  // particle 5 on the wall y = 0: it coincides with its image
  auto s = dl::make_state(x, 8, 8);
  auto st = test::make_stage(*reg, "voronoi.mirror", Backend::cpu, Precision::f64, 2);
  st->configure(*s);
  test::StageDriver d(Backend::cpu, Precision::f64, 2);
  CHECK_THROWS_WITH(d.run(*st, *s), Catch::Contains("voronoi.mirror") && Catch::Contains("coincides with its image"));
}

// The stage driven alone on `x` (walls ⟂ y), then after small moves (maintained) and large ones
// (rebuilt): the bytes of its fields after each call, on backend b, at precision p.
std::vector<std::vector<unsigned char>> driven_bytes(Backend b, Precision p, std::vector<double> x, double Lx,
                                                     double Ly) {
  const std::size_t n = x.size() / 2;
  auto s = dl::make_state(x, Lx, Ly, p);
  const auto reg = test::registry_of({"delaunay", "voronoi"});
  auto st = test::make_stage(*reg, "voronoi.mirror", b, p, 2);
  st->configure(*s);
  test::StageDriver d(b, p, 2);
  std::vector<std::vector<unsigned char>> out;
  for (int call = 0; call < 4; ++call) {
    if (call > 0) {
      const auto dx = dl::random_points(n, 1.0, 1.0, 100 + call);
      const double amplitude = call == 3 ? 2.0 : 0.02;
      for (std::size_t i = 0; i < 2 * n; ++i) {
        const double L = i % 2 ? Ly : Lx;
        double v = x[i] + amplitude * (dx[i] - 0.5);
        if (i % 2) v = std::min(std::max(v, 1e-3), L - 1e-3);
        x[i] = v - L * std::floor(v / L);
      }
      dl::set_positions(*s, x);
    }
    REQUIRE_FALSE(d.run(*st, *s).rollback);
    for (const char* f : {vf::area, vf::perimeter, vf::centroid, vf::sides, voronoi::mirror_fields::halfedge,
                          voronoi::mirror_fields::position}) {
      Field& fld = s->field(f);
      fld.acquire(Where::host, Mode::read);
      const auto* q = static_cast<const unsigned char*>(fld.host_raw());
      out.emplace_back(q, q + fld.bytes());
    }
  }
  return out;
}

TEST_CASE("voronoi.mirror driven alone: CPU and CUDA give the same bits (built, maintained, rebuilt; double and float)",
          "[voronoi][walls][cuda]") {
  if (!test::have_cuda("voronoi.mirror driven alone, CPU == CUDA")) return;
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  const auto x = dl::random_points(700, 28.0, 25.0, 5);
  const auto cpu = driven_bytes(Backend::cpu, p, x, 28.0, 25.0), cuda = driven_bytes(Backend::cuda, p, x, 28.0, 25.0);
  REQUIRE(cpu.size() == cuda.size());
  for (std::size_t k = 0; k < cpu.size(); ++k) {
    INFO("call " << k / 6 << ", field " << k % 6);
    CHECK(cpu[k] == cuda[k]);
  }
}

TEST_CASE("voronoi.mirror in float: the cells of the float positions within float accuracy", "[voronoi][walls]") {
  const Backend b = GENERATE(from_range(test::backends()));
  const std::size_t n = 500;
  const double Lx = 25, Ly = 20;
  std::vector<double> x = dl::random_points(n, Lx, Ly, 9);
  for (double& v : x) v = double(float(v));
  auto s = dl::make_state(x, Lx, Ly, Precision::f32);
  const auto reg = test::registry_of({"delaunay", "voronoi"});
  auto st = test::make_stage(*reg, "voronoi.mirror", b, Precision::f32, 2);
  st->configure(*s);
  test::StageDriver d(b, Precision::f32, 2);
  REQUIRE_FALSE(d.run(*st, *s).rollback);
  const auto ref = test::slab::clipped_cells(x, Lx, Ly);
  const auto area = values(*s, vf::area);
  double total = 0;
  for (std::size_t i = 0; i < n; ++i) {
    INFO("particle " << i);
    CHECK(std::fabs(area[i] - ref[i].area) < 1e-4 * (1 + ref[i].area));
    total += area[i];
  }
  CHECK(std::fabs(total / (Lx * Ly) - 1) < 1e-5);
}

TEST_CASE("voronoi.mirror in the slab pipeline: CPU and CUDA give the same bits", "[voronoi][walls][cuda]") {
  if (!test::have_cuda("voronoi.mirror CPU == CUDA")) return;
  double Lx = 0, Ly = 0;
  const auto l = slab(400, Lx, Ly, "voronoi.mirror");
  auto bytes = [&](Backend b) {
    Simulation sim(l.spec, *l.registry, test::dry(b));
    for (int k = 0; k < 200; ++k) sim.advance();
    std::vector<std::vector<unsigned char>> out;
    // `position` first: if the pipeline's positions differ, the cells cannot agree (not this stage).
    for (const char* f : {fields::position, vf::area, vf::perimeter, vf::centroid, vf::sides,
                          voronoi::mirror_fields::halfedge, voronoi::mirror_fields::position}) {
      Field& fld = sim.state().field(f);
      fld.acquire(Where::host, Mode::read);
      const auto* p = static_cast<const unsigned char*>(fld.host_raw());
      out.emplace_back(p, p + fld.bytes());
    }
    return out;
  };
  const auto cpu = bytes(Backend::cpu), cuda = bytes(Backend::cuda);
  REQUIRE(cpu[0] == cuda[0]);  // the pipeline's positions
  for (std::size_t k = 1; k < cpu.size(); ++k) {
    INFO("field " << k);
    CHECK(cpu[k] == cuda[k]);
  }
}
