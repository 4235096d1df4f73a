// The project's rule that a run gives the same bits for any number of CPU threads, checked on
// whole shipped pipelines for the stages no test of their own runs at several thread counts
// (delaunay.detect_inversion, delaunay.flip and its sub-steps, voronoi.geometry,
// neighbors.delaunay, abp.integrate, the boids stages): each pipeline runs at 1, 2, 3 and 4
// threads (more threads than this machine has cores split the work otherwise again), and every
// field, Δt and metric must equal the one-thread run's bit for bit at every step.
#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/task_arena.h>

#include <catch2/catch.hpp>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "core/run/simulation.h"
#include "support/cli.h"
#include "support/fields.h"
#include "support/pipeline.h"
#include "support/spec.h"

using namespace ff;

namespace {

struct Trace {
  std::vector<std::map<std::string, double>> metrics;  // per step
  std::vector<double> dt;                              // per step
  std::map<std::string, std::vector<unsigned char>> fields;  // at the end
};

Trace run_with_threads(const test::LoadedPipeline& l, int threads) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
  tbb::task_arena arena(threads);
  Trace t;
  arena.execute([&] {
    Simulation sim(l.spec, *l.registry, test::dry());
    for (std::uint64_t k = 0; k < l.spec.run.steps; ++k) {
      sim.advance();
      t.metrics.push_back(sim.stats().metrics);
      t.dt.push_back(sim.stats().dt);
    }
    State& s = sim.state();
    for (const std::string& name : s.field_names()) t.fields[name] = test::bytes_of(s, name);
  });
  return t;
}

// Scratch fields hold thread-order leftovers between steps (Simulation::scratch_fields): they
// are left out, as checkpoints leave them out.
void check_same(const Trace& one, const Trace& other, const std::vector<std::string>& scratch) {
  REQUIRE(one.dt.size() == other.dt.size());
  for (std::size_t k = 0; k < one.dt.size(); ++k) {
    INFO("step " << k);
    CHECK(std::memcmp(&one.dt[k], &other.dt[k], sizeof(double)) == 0);
    CHECK(one.metrics[k] == other.metrics[k]);
  }
  for (const auto& [name, bytes] : one.fields) {
    bool skip = false;
    for (const auto& s : scratch) skip = skip || s == name;
    if (skip) continue;
    INFO("field " << name);
    REQUIRE(other.fields.count(name) == 1);
    CHECK(bytes == other.fields.at(name));
  }
}

}  // namespace

TEST_CASE("whole pipelines give the same bits at 1, 2, 3 and 4 CPU threads", "[determinism][threads]") {
  struct Case {
    const char* file;
    std::vector<std::string> overrides;
    std::vector<std::string> busy;  // metrics whose sum over the steps must be > 0: the stages did work
  };
  // voronoi-hard-disks: sort, brownian, detect_inversion, flip, lawson, overlap_correct, lawson
  // again, voronoi.geometry; abp: abp.integrate among them; bench-boids-delaunay: delaunay.build,
  // neighbors.delaunay, the boids stages and flip's sub-steps.
  const Case cases[] = {
      {"pipelines/voronoi-hard-disks.yaml",
       {"system.N=4096", "run.steps=40"},
       {"delaunay.lawson/lawson_flips", "overlap_correct/pairs", "voronoi.geometry/area_variance"}},
      {"pipelines/abp.yaml", {"system.N=4096", "run.steps=40"}, {"delaunay.lawson/lawson_flips", "overlap_correct/pairs"}},
      {"pipelines/bench-boids-delaunay.yaml",
       {"system.N=4096", "run.steps=40"},
       {"delaunay.flip/flips", "delaunay.flip/substeps", "delaunay.lawson/lawson_flips", "neighbors.delaunay/capacity"}},
  };
  for (const Case& c : cases) {
    INFO(c.file);
    const auto l = test::load_compute_steps(test::repo_file(c.file).string(), c.overrides);
    std::vector<std::string> scratch;
    {
      Simulation probe(l.spec, *l.registry, test::dry());
      scratch = probe.scratch_fields();
    }
    const Trace one = run_with_threads(l, 1);
    REQUIRE(one.fields.count("position") == 1);
    for (const std::string& m : c.busy) {
      double sum = 0;
      for (const auto& step : one.metrics) sum += step.count(m) ? step.at(m) : 0.0;
      INFO(m);
      CHECK(sum > 0);
    }
    for (int threads : {2, 3, 4}) {
      INFO(threads << " threads");
      check_same(one, run_with_threads(l, threads), scratch);
    }
  }
}
