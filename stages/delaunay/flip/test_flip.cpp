// delaunay.flip alone: repairs marked inversions (Carter et al. 2017 figs. 5–6) by parallel,
// conflict-free flips; conflicting repairs on one triangle take two rounds; with detection in
// front, random large moves either end in a valid triangulation or in a rollback, never in an
// inverted triangle; with `on_unrepairable: substep`, vertices across two edges (fig. 6) end at
// the integrator's targets, alone and inside a running pipeline; a pair passing each other closer
// than its step's move rolls back, unless `passing: substep` (then it ends at its targets too,
// while a collision still rolls back). decide_next's table: test_tries.cpp.
#include <algorithm>
#include <map>
#include <random>

#include "core/base/error.h"
#include "core/run/simulation.h"
#include "stages/delaunay/test_support.h"
#include "support/spec.h"

using namespace ff;
using namespace ff::test::dl;

namespace {
void mark_by_hand(State& s, const std::vector<int>& edges) {
  Field& f = s.field(ff::delaunay::fields::flip_mark);
  f.acquire(Where::host, Mode::write);
  std::fill(f.host<std::uint8_t>(), f.host<std::uint8_t>() + f.size(), std::uint8_t(0));
  for (int e : edges) f.host<std::uint8_t>()[e] = 1;
  status_of(s)[ff::delaunay::kPending] = int(edges.size());
}
}  // namespace

TEST_CASE("flip: one vertex across one edge is repaired by one flip (fig. 5)", "[delaunay][flip]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  Scene sc(p);
  const auto f = sc.fan(45);
  sc.cross_one_edge(f);
  mark_by_hand(*sc.s, {f.pq});
  auto st = make_stage("delaunay.flip", b, p);
  st->configure(*sc.s);
  Runner r(*sc.s, b);
  const Outcome o = r.run(*st);
  INFO(o.reason);
  REQUIRE_FALSE(o.rollback);
  CHECK(r.metric("flips") == 1);
  CHECK(r.metric("flip_rounds") == 1);
  CHECK(status_of(*sc.s)[ff::delaunay::kPending] == 0);
  require_valid(*sc.s);
  // The crossed edge (p, q) became (v, w).
  const Topo t = topology(*sc.s);
  const auto e = ff::delaunay::edge_set(t.he.data(), sc.n());
  CHECK(std::binary_search(e.begin(), e.end(), std::make_pair(std::min(f.v, f.w), std::max(f.v, f.w))));
  CHECK_FALSE(std::binary_search(e.begin(), e.end(), std::make_pair(std::min(f.p, f.q), std::max(f.p, f.q))));
}

TEST_CASE("flip: independent repairs run in one round", "[delaunay][flip]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  Scene sc(Precision::f64, 20, 20);
  std::vector<int> edges;
  for (int v : {21, 66, 111, 156, 201, 246, 291, 336}) {
    const auto f = sc.fan(v);
    sc.cross_one_edge(f);
    edges.push_back(f.pq);
  }
  auto detect = make_stage("delaunay.detect_inversion", b);
  auto st = make_stage("delaunay.flip", b);
  detect->configure(*sc.s);
  st->configure(*sc.s);
  Runner r(*sc.s, b);
  REQUIRE_FALSE(r.run(*detect).rollback);
  CHECK(r.metric("inversions") == 8);
  REQUIRE_FALSE(r.run(*st).rollback);
  CHECK(r.metric("flips") == 8);
  CHECK(r.metric("flip_rounds") == 1);
  require_valid(*sc.s);
}

TEST_CASE("flip: two repairs on one triangle: the lower edge id goes first", "[delaunay][flip]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  Scene sc;
  // Triangle T = (q, p, w) beyond v's edge (p, q). v crosses (p, q) into T near that edge; u, the
  // vertex beyond (q, w), crosses (q, w) into T near that edge. Both edges are marked and share T.
  const auto f = sc.fan(45);
  const int u = f.z;
  sc.move(f.v, sc.lerp(sc.mid(f.v, f.p, f.q), sc.near(f.v, f.w), 0.12));
  sc.move(u, sc.lerp(sc.mid(u, f.q, f.w), sc.near(u, f.p), 0.12));
  auto detect = make_stage("delaunay.detect_inversion", b);
  auto st = make_stage("delaunay.flip", b);
  detect->configure(*sc.s);
  st->configure(*sc.s);
  Runner r(*sc.s, b);
  const Outcome od = r.run(*detect);
  INFO(od.reason);
  REQUIRE_FALSE(od.rollback);
  CHECK(r.metric("inversions") == 2);
  CHECK(r.metric("repairable") == 2);
  const Outcome o = r.run(*st);
  INFO(o.reason);
  REQUIRE_FALSE(o.rollback);
  CHECK(r.metric("flips") == 2);
  CHECK(r.metric("flip_rounds") == 2);
  require_valid(*sc.s);
}

TEST_CASE("flip: nothing pending, nothing done", "[delaunay][flip]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  Scene sc;
  const Topo before = topology(*sc.s);
  auto st = make_stage("delaunay.flip", b);
  st->configure(*sc.s);
  Runner r(*sc.s, b);
  REQUIRE_FALSE(r.run(*st).rollback);
  CHECK(r.metric("flips") == 0);
  CHECK(topology(*sc.s).he == before.he);
}

TEST_CASE("flip: random large moves end valid or rolled back, never inverted", "[delaunay][flip]") {
  const Backend b = GENERATE(from_range(ff::test::backends()));
  int repaired = 0, rolled_back = 0, untouched = 0;
  for (std::uint32_t trial = 0; trial < 80; ++trial) {
    Scene sc;
    const RngKey key = make_rng_key(trial, "moves");
    auto xy = sc.xy;
    // Even trials: every particle moves (std 0.12 .. 0.44 of the spacing); odd trials:
    // a few particles jump far (std 0.55).
    const bool all = trial % 2 == 0;
    const double amp = all ? 0.12 + 0.004 * trial : 0.55;
    for (std::size_t i = 0; i < sc.n(); ++i) {
      if (!all && uniform01(key, std::uint32_t(i), trial, 1, 0) > 0.06) continue;
      double z[2];
      gaussians(key, std::uint32_t(i), trial, 0, 0, 2, z);
      xy[2 * i] += amp * z[0];
      xy[2 * i + 1] += amp * z[1];
    }
    set_positions(*sc.s, xy);
    auto detect = make_stage("delaunay.detect_inversion", b);
    auto st = make_stage("delaunay.flip", b);
    detect->configure(*sc.s);
    st->configure(*sc.s);
    Runner r(*sc.s, b);
    if (r.run(*detect).rollback) {
      ++rolled_back;
      continue;
    }
    const double inv = r.metric("inversions");
    if (r.run(*st).rollback) {
      ++rolled_back;
      continue;
    }
    inv > 0 ? ++repaired : ++untouched;
    require_valid(*sc.s);
  }
  INFO("repaired " << repaired << ", rolled back " << rolled_back << ", untouched " << untouched);
  CHECK(repaired > 0);
  CHECK(rolled_back > 0);
}

// --- on_unrepairable: substep (Porro et al. §3; spec seed-gaps P3) --------------------------

namespace {
// Carter fig. 6 on a random point set: v crosses (p, q) and then (q, w) of the triangle
// (q, p, w), ending a fraction `past` of the way from (q, w) toward z, while every edge of v keeps
// r0.r1 > 0 (the construction of test_detect_inversion.cpp, "a vertex across two edges").
struct TwoEdgeCase {
  std::uint64_t seed;
  int v;
  std::array<double, 2> to;
};
constexpr double kCaseSide = 14;
std::unique_ptr<State> case_state(std::uint64_t seed) {
  auto s = make_state(random_points(196, kCaseSide, kCaseSide, seed), kCaseSide, kCaseSide);
  auto build = make_stage("delaunay.build", Backend::cpu);
  build->configure(*s);
  Runner rb(*s, Backend::cpu);
  REQUIRE_FALSE(rb.run(*build).rollback);
  return s;
}
std::vector<TwoEdgeCase> two_edge_cases(int want, double past) {
  std::vector<TwoEdgeCase> out;
  for (std::uint64_t seed = 1; seed <= 20 && int(out.size()) < want; ++seed) {
    Scene sc(Precision::f64, 10, 10);
    sc.s = case_state(seed);
    sc.t = topology(*sc.s);
    sc.xy = positions(*sc.s);
    for (int v = 0; v < int(sc.n()) && int(out.size()) < want; ++v) {
      const auto f = sc.fan(v);
      const auto q = sc.near(f.v, f.q), w = sc.near(f.v, f.w), z = sc.near(f.v, f.z);
      const auto on = sc.lerp(q, w, 0.3);
      const std::array<double, 2> to{on[0] + past * (z[0] - on[0]), on[1] + past * (z[1] - on[1])};
      const auto from = sc.near(f.v, f.v);
      bool keeps_sign = true;
      for (int h = 0; h < int(6 * sc.n()); ++h) {
        if (sc.origin(h) != v) continue;
        const auto y = sc.near(f.v, sc.origin(h ^ 1));
        keeps_sign = keeps_sign && (y[0] - from[0]) * (y[0] - to[0]) + (y[1] - from[1]) * (y[1] - to[1]) > 0.05;
      }
      if (keeps_sign) out.push_back({seed, v, to});
    }
  }
  return out;
}

// detect_inversion → flip (→ lawson) on the case's state with v moved to `to`.
struct SubstepRun {
  std::unique_ptr<State> s;
  std::vector<double> targets;  // the positions after the move (the integrator's targets)
  Outcome detect, flip;
  double unrepairable = -1, flips = -1, substeps = -1;
};
SubstepRun run_case(const TwoEdgeCase& c, Backend b, const ff::test::ParamSettings& flip_set, bool lawson = true) {
  SubstepRun out;
  out.s = case_state(c.seed);
  auto xy = positions(*out.s);
  xy[2 * c.v] = c.to[0];
  xy[2 * c.v + 1] = c.to[1];
  set_positions(*out.s, xy);
  out.targets = positions(*out.s);
  auto detect = make_stage("delaunay.detect_inversion", b);
  auto flip = make_stage("delaunay.flip", b, Precision::f64, flip_set);
  auto law = make_stage("delaunay.lawson", b);
  detect->configure(*out.s);
  flip->configure(*out.s);
  law->configure(*out.s);
  Runner r(*out.s, b);
  out.detect = r.run(*detect);
  if (out.detect.rollback) return out;
  if (r.metrics.values().count("unrepairable")) out.unrepairable = r.metric("unrepairable");
  out.flip = r.run(*flip);
  out.flips = r.metric("flips");
  if (r.metrics.values().count("substeps")) out.substeps = r.metric("substeps");
  if (!out.flip.rollback && lawson) REQUIRE_FALSE(r.run(*law).rollback);
  return out;
}

const ff::test::ParamSettings kSubstepMode{{"on_unrepairable", ParamValue(std::string("substep"))}};
}  // namespace

TEST_CASE("flip substep: a vertex across two edges ends at the integrator's targets, Delaunay (fig. 6)",
          "[delaunay][flip][substep]") {
  const auto cases = two_edge_cases(3, 0.05);
  REQUIRE(cases.size() == 3);
  for (const auto& c : cases) {
    std::vector<std::int32_t> cpu_he;
    for (Backend b : ff::test::backends()) {
      INFO("seed " << c.seed << ", v = " << c.v << ", backend " << int(b));
      // The default rolls the step back.
      const SubstepRun dflt = run_case(c, b, {});
      REQUIRE(dflt.detect.rollback);
      CHECK_THAT(dflt.detect.reason, Catch::Contains("no single edge flip repairs it"));

      const SubstepRun run = run_case(c, b, kSubstepMode);
      INFO(run.detect.reason << " / " << run.flip.reason);
      REQUIRE_FALSE(run.detect.rollback);
      REQUIRE_FALSE(run.flip.rollback);
      CHECK(run.unrepairable >= 1);
      CHECK(run.substeps >= 1);
      CHECK(run.flips >= 2);  // at least one flip per crossed edge
      // Exactly the targets, bit for bit, and position_prev (the next step's r0) equal to them.
      CHECK(positions(*run.s) == run.targets);
      Field& prev = run.s->field(ff::delaunay::fields::position_prev);
      prev.acquire(Where::host, Mode::read);
      CHECK(std::vector<double>(prev.host<double>(), prev.host<double>() + prev.size()) == run.targets);
      CHECK(status_of(*run.s)[ff::delaunay::kPrevKept] == 0);
      CHECK(status_of(*run.s)[ff::delaunay::kPending] == 0);
      // Valid, and after Lawson the Delaunay triangulation of the targets (CGAL's, up to ties).
      require_valid(*run.s);
      CHECK(real_differences(topology(*run.s), cgal_reference(*run.s), *run.s) == 0);
      // The same triangulation on every backend.
      const auto he = topology(*run.s).he;
      if (cpu_he.empty()) cpu_he = he;
      CHECK(he == cpu_he);
    }
  }
}

TEST_CASE("flip substep: a case deeper than max_substeps falls back to rollback", "[delaunay][flip][substep]") {
  // Each case needs k halvings with the default bound; with max_substeps = k - 1 it must roll
  // back (leaving the targets in place), with max_substeps = k it must not.
  int deep = 0;
  for (const auto& c : two_edge_cases(6, 0.05)) {
    const SubstepRun run = run_case(c, Backend::cpu, kSubstepMode, false);
    REQUIRE_FALSE(run.flip.rollback);
    const auto k = std::int64_t(run.substeps);
    if (k < 2) continue;
    ++deep;
    for (Backend b : ff::test::backends()) {
      INFO("seed " << c.seed << ", v = " << c.v << ", needs " << k << " halvings, backend " << int(b));
      ff::test::ParamSettings set = kSubstepMode;
      set.emplace_back("max_substeps", ParamValue(k - 1));
      const SubstepRun below = run_case(c, b, set, false);
      REQUIRE(below.flip.rollback);
      CHECK_THAT(below.flip.reason, Catch::Contains("(max_substeps)"));
      CHECK(below.substeps == double(k - 1));
      CHECK(positions(*below.s) == below.targets);
      set.back().second = ParamValue(k);
      const SubstepRun at = run_case(c, b, set, false);
      CHECK_FALSE(at.flip.rollback);
      CHECK(at.substeps == double(k));
    }
  }
  CHECK(deep >= 3);
}

// v and p both reach the step's targets; v's path runs past p at `miss` times their distance
// (0: straight through p).
void pass_by(Scene& sc, const Scene::Fan& f, double miss) {
  const auto v = sc.near(f.p, f.v), pp = sc.near(f.p, f.p);
  const double dx = pp[0] - v[0], dy = pp[1] - v[1];
  sc.move(f.v, {pp[0] + 0.3 * dx - miss * dy, pp[1] + 0.3 * dy + miss * dx});
}

TEST_CASE("flip substep: passing pairs roll back, or with passing: substep a near miss ends at its targets",
          "[delaunay][flip][substep]") {
  // v jumps past its neighbour p: the edge vector (v, p) reverses (r0.r1 < 0). By default, and
  // with on_unrepairable: substep alone (hard disks must not go through each other), that rolls
  // back. With passing: substep a path that misses p by 10^-3 of their distance is sub-stepped
  // until no sub-step reverses the edge, and ends at the targets; straight through p no
  // sub-step can separate them (each halving brings v closer to p on the line): max_substeps,
  // then a rollback.
  const Backend b = GENERATE(from_range(ff::test::backends()));
  for (const double miss : {0.0, 1e-3}) {
    INFO("miss " << miss << ", backend " << int(b));
    for (const int mode : {0, 1, 2}) {  // default; on_unrepairable: substep; and passing: substep
      INFO("mode " << mode);
      Scene sc;
      const auto f = sc.fan(45);
      pass_by(sc, f, miss);
      const auto targets = sc.xy;
      ff::test::ParamSettings set;
      if (mode >= 1) set = {kSubstepMode[0], {"max_substeps", ParamValue(std::int64_t(64))}};
      if (mode == 2) set.emplace_back("passing", ParamValue(std::string("substep")));
      const bool substep = mode == 2;
      auto detect = make_stage("delaunay.detect_inversion", b);
      auto flip = make_stage("delaunay.flip", b, Precision::f64, set);
      detect->configure(*sc.s);
      flip->configure(*sc.s);
      REQUIRE(status_of(*sc.s)[ff::delaunay::kSubstep] == mode);
      Runner r(*sc.s, b);
      const Outcome od = r.run(*detect);
      INFO(od.reason);
      if (!substep) {
        REQUIRE(od.rollback);
        CHECK_THAT(od.reason, Catch::Contains("passed through each other"));
        continue;
      }
      REQUIRE_FALSE(od.rollback);
      CHECK(status_of(*sc.s)[ff::delaunay::kPrevKept] == 1);
      const Outcome o = r.run(*flip);
      INFO(o.reason);
      CHECK(positions(*sc.s) == targets);  // the targets, whether accepted or left for the rollback
      if (miss == 0) {
        REQUIRE(o.rollback);
        CHECK_THAT(o.reason, Catch::Contains("passed through each other") && Catch::Contains("(max_substeps)"));
        CHECK(r.metric("substeps") == 64);
        const auto named = [&](int i) { return std::count(o.particles.begin(), o.particles.end(), std::uint64_t(i)) > 0; };
        CHECK(named(f.v));
        CHECK(named(f.p));
      } else {
        REQUIRE_FALSE(o.rollback);
        CHECK(r.metric("substeps") >= 2);
        CHECK(status_of(*sc.s)[ff::delaunay::kPrevKept] == 0);
        require_valid(*sc.s);
      }
    }
  }
}

// --- sub-steps in a running pipeline (the core's Simulation) -------------------------------


namespace {

// test.scripted_move: the "integrator" of a pipeline whose trajectory the test prescribes: at
// step k it writes positions frames[k] (frames[0] at step 0: the start, before the first
// triangulation). A host stage on either backend (the core copies the field).
class ScriptedMove final : public Stage {
 public:
  explicit ScriptedMove(const std::vector<std::vector<double>>* frames) : frames_(frames) {}
  std::vector<Access> accesses() const override { return {{fields::position, Where::host, Mode::write}}; }
  Outcome run(StepContext& ctx) override {
    const std::vector<double>& f = (*frames_)[std::min<std::size_t>(ctx.host_params.step, frames_->size() - 1)];
    std::copy(f.begin(), f.end(), ctx.state.field(fields::position).host<double>());
    return Outcome::ok();
  }

 private:
  const std::vector<std::vector<double>>* frames_;
};

std::unique_ptr<Registry> registry_with_script(const std::vector<std::vector<double>>* frames) {
  auto r = ff::test::registry_of({"delaunay"});
  r->declare({"test.scripted_move", "writes the test's positions (tests only)", {}, {2}, false});
  for (Backend b : {Backend::cpu, Backend::cuda})
    r->implement("test.scripted_move", b,
                 [frames](const ParamValues&, const RunInfo&) { return std::make_unique<ScriptedMove>(frames); });
  return r;
}

StepEntry step_entry(const Registry& r, const std::string& stage, const std::map<std::string, ParamValue>& params = {},
                     std::uint64_t every = 1) {
  StepEntry e;
  e.stage = e.id = stage;
  e.params = ParamValues::defaults(r.get(stage).decl.params);
  for (auto& kv : params) e.params.set(kv.first, kv.second);
  e.schedule.every = every;
  e.where = Location{"test", 1, 1};
  return e;
}

double wrap(double x, double L) { return x - L * std::floor(x / L); }

}  // namespace

TEST_CASE("flip substep: in a running pipeline, two-edge crossings end at the integrator's targets every step",
          "[delaunay][flip][substep][pipeline]") {
  // Two vertices of one point set, far apart, each made to cross two edges (Carter fig. 6): the
  // first at step 1, the second at step 2; at step 3 every particle makes a small move. The
  // pipeline: the scripted integrator (step 0: the start, which delaunay.build triangulates),
  // detect_inversion, flip (substep), lawson, and delaunay.check every step (a RunError at the
  // first step not Delaunay for the positions).
  const auto cases = two_edge_cases(40, 0.05);
  const TwoEdgeCase* first = nullptr;
  const TwoEdgeCase* second = nullptr;
  for (std::size_t a = 0; a < cases.size() && !second; ++a)
    for (std::size_t b = a + 1; b < cases.size() && !second; ++b) {
      if (cases[a].seed != cases[b].seed) continue;
      const auto xy = positions(*case_state(cases[a].seed));
      const double dx = std::remainder(xy[2 * cases[a].v] - xy[2 * cases[b].v], kCaseSide);
      const double dy = std::remainder(xy[2 * cases[a].v + 1] - xy[2 * cases[b].v + 1], kCaseSide);
      if (std::hypot(dx, dy) > 5) {
        first = &cases[a];
        second = &cases[b];
      }
    }
  REQUIRE(second != nullptr);
  std::vector<std::vector<double>> frames{positions(*case_state(first->seed))};
  for (const TwoEdgeCase* c : {first, second}) {
    auto f = frames.back();
    f[2 * c->v] = wrap(c->to[0], kCaseSide);
    f[2 * c->v + 1] = wrap(c->to[1], kCaseSide);
    frames.push_back(f);
  }
  {
    auto f = frames.back();
    std::mt19937_64 g(3);
    std::uniform_real_distribution<double> u(-0.01, 0.01);
    for (double& x : f) x = wrap(x + u(g), kCaseSide);
    frames.push_back(f);
  }
  const std::uint64_t steps = frames.size();
  const auto reg = registry_with_script(&frames);
  auto pipeline = [&](const std::string& on_unrepairable) {
    std::vector<StepEntry> step{step_entry(*reg, "test.scripted_move"),
                                step_entry(*reg, "delaunay.build", {}, steps + 1),
                                step_entry(*reg, "delaunay.detect_inversion"),
                                step_entry(*reg, "delaunay.flip", {{"on_unrepairable", on_unrepairable}}),
                                step_entry(*reg, "delaunay.lawson"),
                                step_entry(*reg, "delaunay.check")};
    auto s = ff::test::spec(2, frames[0].size() / 2, 0.3, steps, 0.01, std::move(step), 1);
    s.system.box = {kCaseSide, kCaseSide};
    s.system.sigma = 0.1;  // only `init: random` sees a diameter, and the script moves them at once
    return s;
  };
  for (Backend b : ff::test::backends()) {
    INFO("seed " << first->seed << ", vertices " << first->v << " and " << second->v << ", backend " << int(b));
    Simulation sim(pipeline("substep"), *reg, ff::test::dry(b));
    for (std::uint64_t k = 0; k < steps; ++k) {
      INFO("step " << k);
      REQUIRE_NOTHROW(sim.advance());
      CHECK(positions(sim.state()) == frames[k]);  // the integrator's targets, bit for bit
      CHECK(sim.stats().rollbacks == 0);
      CHECK(sim.stats().dt == 0.01);
      const double substeps = sim.stats().metrics.at("delaunay.flip/substeps");
      const double unrepairable = sim.stats().metrics.at("delaunay.detect_inversion/unrepairable");
      if (k == 1 || k == 2) {
        CHECK(substeps >= 1);
        CHECK(unrepairable >= 1);
      } else {
        CHECK(substeps == 0);
      }
    }
    // The default mode cannot take step 1 at any Δt (the script moves the same way whatever Δt
    // is): it rolls back until Δt reaches dt_min and gives up, naming the crossing.
    Simulation rollback(pipeline("rollback"), *reg, ff::test::dry(b));
    REQUIRE_NOTHROW(rollback.advance());
    CHECK_THROWS_WITH(rollback.advance(), Catch::Contains("no single edge flip repairs it"));
  }
}

// --- detect_inversion's rollback path when the triangulation is not the step's own ----------

namespace {
// Registers `name`: a host stage writing positions frames[min(step, last)] (as test.scripted_move).
void add_script(Registry& r, const std::string& name, const std::vector<std::vector<double>>* frames) {
  r.declare({name, "writes the test's positions (tests only)", {}, {2}, false});
  for (Backend b : {Backend::cpu, Backend::cuda})
    r.implement(name, b, [frames](const ParamValues&, const RunInfo&) { return std::make_unique<ScriptedMove>(frames); });
}
}  // namespace

TEST_CASE("detect_inversion: a triangulation built earlier in the step is judged as built, not rebuilt at the "
          "step's start",
          "[delaunay][detect_inversion][rollback][pipeline]") {
  // One step: test.place puts the particles at a Delaunay point set (far from where init: random
  // put them), delaunay.build triangulates it, the scripted integrator moves one vertex across
  // two edges, detect_inversion (default mode) must ask for rollbacks ("no single edge flip
  // repairs it") until Δt reaches dt_min. It once took the step's start (the random positions)
  // for the triangulation's reference, rebuilt for those and stopped the run at once with
  // hundreds of triangles that "no longer close". check_rollbacks: every retry restores all.
  const auto cases = two_edge_cases(1, 0.05);
  REQUIRE(cases.size() == 1);
  const TwoEdgeCase& c = cases[0];
  const std::vector<std::vector<double>> place{positions(*case_state(c.seed))};
  std::vector<std::vector<double>> moved{place[0]};
  moved[0][2 * c.v] = wrap(c.to[0], kCaseSide);
  moved[0][2 * c.v + 1] = wrap(c.to[1], kCaseSide);
  auto reg = registry_with_script(&moved);
  add_script(*reg, "test.place", &place);
  for (Backend b : ff::test::backends()) {
    INFO("backend " << int(b));
    std::vector<StepEntry> step{step_entry(*reg, "test.place"), step_entry(*reg, "delaunay.build", {}, 5),
                                step_entry(*reg, "test.scripted_move"), step_entry(*reg, "delaunay.detect_inversion")};
    auto s = ff::test::spec(2, place[0].size() / 2, 0.3, 2, 0.01, std::move(step), 1);
    s.system.box = {kCaseSide, kCaseSide};
    s.system.sigma = 0.1;
    RunOptions o = ff::test::dry(b);
    o.check_rollbacks = true;
    Simulation sim(s, *reg, o);
    CHECK_THROWS_WITH(sim.advance(), Catch::Contains("no single edge flip repairs it") &&
                                         Catch::Contains("cannot be halved again"));
    CHECK(sim.stats().rollbacks == 11);  // Δt halved 10 times to dt_min = dt / 1024, then given up
  }
}

TEST_CASE("detect_inversion: a rollback after rebuilding an inherited broken triangulation restores position_prev",
          "[delaunay][detect_inversion][rollback][pipeline]") {
  // Step 0: the particles at a Delaunay point set (the triangulation is built there), then a
  // stage after Lawson (as overlap_correct would) moves vertex v across two edges: step 1
  // inherits a triangulation that is not valid where it starts. At step 1 the integrator also
  // moves v through its nearest neighbour u, so detect_inversion rebuilds for the step's start
  // and still asks for a rollback (v and u passed through each other). The rebuild once wrote
  // position_prev without announcing it to the rollback snapshot: the retry started from
  // position_prev = the step's start instead of where the triangulation was valid
  // (check_rollbacks names it). In the default mode detect_inversion's own first look had
  // announced position_prev already; with `on_unrepairable: substep` nothing had.
  const auto cases = two_edge_cases(1, 0.05);
  REQUIRE(cases.size() == 1);
  const TwoEdgeCase& c = cases[0];
  const auto f0 = positions(*case_state(c.seed));
  std::vector<std::vector<double>> late{f0};
  late[0][2 * c.v] = wrap(c.to[0], kCaseSide);
  late[0][2 * c.v + 1] = wrap(c.to[1], kCaseSide);
  // u: v's nearest neighbour at the late positions (a Delaunay edge of them); v jumps over it.
  const auto& l0 = late[0];
  int u = -1;
  double best = 1e300;
  std::array<double, 2> du{};
  for (int i = 0; i < int(l0.size() / 2); ++i) {
    if (i == c.v) continue;
    const double dx = std::remainder(l0[2 * i] - l0[2 * c.v], kCaseSide);
    const double dy = std::remainder(l0[2 * i + 1] - l0[2 * c.v + 1], kCaseSide);
    if (dx * dx + dy * dy < best) best = dx * dx + dy * dy, u = i, du = {dx, dy};
  }
  REQUIRE(u >= 0);
  std::vector<std::vector<double>> frames{f0, l0};
  frames[1][2 * c.v] = wrap(l0[2 * c.v] + 1.3 * du[0], kCaseSide);
  frames[1][2 * c.v + 1] = wrap(l0[2 * c.v + 1] + 1.3 * du[1], kCaseSide);
  auto reg = registry_with_script(&frames);
  add_script(*reg, "test.late_move", &late);
  for (Backend b : ff::test::backends())
    for (const std::string substep : {"rollback", "substep"}) {
    INFO("seed " << c.seed << ", v = " << c.v << ", u = " << u << ", backend " << int(b) << ", on_unrepairable: " << substep);
    std::vector<StepEntry> step{step_entry(*reg, "test.scripted_move"), step_entry(*reg, "delaunay.detect_inversion"),
                                step_entry(*reg, "delaunay.flip", {{"on_unrepairable", substep}}),
                                step_entry(*reg, "delaunay.lawson"), step_entry(*reg, "test.late_move")};
    auto s = ff::test::spec(2, f0.size() / 2, 0.3, 3, 0.01, std::move(step), 1);
    s.system.box = {kCaseSide, kCaseSide};
    s.system.sigma = 0.1;
    RunOptions o = ff::test::dry(b);
    o.check_rollbacks = true;
    Simulation sim(s, *reg, o);
    REQUIRE_NOTHROW(sim.advance());
    CHECK(sim.stats().metrics.at("delaunay.detect_inversion/rebuilds") == 0);
    CHECK_THROWS_WITH(sim.advance(), Catch::Contains("passed through each other") &&
                                         Catch::Contains("cannot be halved again"));
    CHECK(sim.stats().rollbacks == 11);
  }
}
