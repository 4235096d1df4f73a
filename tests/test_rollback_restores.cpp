// Every rollback restores everything: in every shipped pipeline, a test stage requests
// rollbacks right after each stage that may request one, and at the end of the step, on steps
// 1, 2 and 7, three attempts in a row each; with RunOptions::check_rollbacks the core compares
// the whole state after each restore with a copy taken before the step (every field, not only
// those it planned to snapshot) and stops on any difference. The runs must then complete.
// Fields declared step_local (left as the failed attempt wrote them) are checked separately:
// filling them with garbage between steps must not change the trajectory.
#include <catch2/catch.hpp>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/input/pipeline_loader.h"
#include "core/run/simulation.h"
#include "support/backends.h"
#include "support/cli.h"
#include "support/fields.h"
#include "support/pipeline.h"
#include "support/spec.h"
#include "support/test_plugins.h"

using namespace ff;

namespace {

std::vector<std::string> shipped_pipelines() {
  std::vector<std::string> out;
  for (auto& e : std::filesystem::directory_iterator(test::repo_file("pipelines")))
    if (e.path().extension() == ".yaml") out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

// The pipeline at a test size (N = 512, 10 steps), compute stages only.
using Loaded = test::LoadedPipeline;
Loaded load_small(const std::string& file) {
  return test::load_compute_steps(file, {"system.N=512", "run.steps=10"}, {"testing"});
}

// Indices of the step entries that may request a rollback.
std::vector<std::size_t> requesters(const Loaded& l, Backend b) {
  Simulation probe(l.spec, *l.registry, test::dry(b));
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < probe.slots().size(); ++i)
    if (probe.slots()[i].stage->scheduling().may_request_rollback) out.push_back(i);
  return out;
}

}  // namespace

TEST_CASE("every rollback restores the whole state, in every shipped pipeline, after every requester",
          "[rollback][pipeline]") {
  const Backend b = GENERATE(from_range(test::backends()));
  for (const std::string& file : shipped_pipelines()) {
    const Loaded l = load_small(file);
    std::vector<std::size_t> after = requesters(l, b);
    after.push_back(l.spec.step.size() - 1);  // the end of the step
    for (std::size_t p : after) {
      INFO(file << " on " << to_string(b) << ": rollbacks requested after step entry " << p << " ('"
                << l.spec.step[p].id << "')");
      PipelineSpec s = l.spec;
      s.step.insert(s.step.begin() + std::ptrdiff_t(p) + 1,
                    test::entry(*l.registry, "testing.rollback",
                                {{"steps", std::vector<double>{1, 2, 7}},
                                 {"fail_attempts", std::int64_t(3)},
                                 {"device_requests", false}},
                                {"inject"}));
      RunOptions o = test::dry(b);
      o.check_rollbacks = true;
      Simulation sim(s, *l.registry, o);
      for (std::uint64_t k = 0; k < s.run.steps; ++k) REQUIRE_NOTHROW(sim.advance());
      CHECK(sim.state().step == s.run.steps);
      CHECK(sim.stats().rollbacks >= 9);
    }
  }
}

TEST_CASE("step-local fields carry nothing: garbage in them between steps leaves the trajectory unchanged",
          "[rollback][pipeline]") {
  const Backend b = GENERATE(from_range(test::backends()));
  for (const char* name : {"pipelines/abp.yaml", "pipelines/hard-disks.yaml", "pipelines/phoretic-c2-short.yaml"}) {
    INFO(name << " on " << to_string(b));
    Loaded l = load_small(test::repo_file(name).string());
    l.spec.run.steps = 30;
    Simulation plain(l.spec, *l.registry, test::dry(b));
    Simulation scrambled(l.spec, *l.registry, test::dry(b));
    const auto local = scrambled.step_local_fields();
    CHECK_FALSE(local.empty());
    for (std::uint64_t k = 0; k < l.spec.run.steps; ++k) {
      plain.advance();
      for (const std::string& f : local) {
        Field& field = scrambled.state().field(f);
        field.acquire(Where::host, Mode::write);
        std::memset(field.host_raw(), 0xA5, field.bytes());
      }
      scrambled.advance();
    }
    for (const char* f : {fields::position, fields::image})
      CHECK(test::bytes_of(plain.state(), f) == test::bytes_of(scrambled.state(), f));
  }
}

TEST_CASE("check_rollbacks names a field that a stage writes without declaring it", "[rollback]") {
  // The check itself can fail: testing.rollback with scramble_undeclared writes `type`, which it
  // does not declare, so the snapshot does not hold it and the restore leaves it changed.
  auto r = test::registry_with({"brownian"}, {"testing"});
  auto s = test::spec(2, 64, 0.2, 3, 0.01,
                      {test::entry(*r, "brownian.integrate", {{"D", 1.0}}),
                       test::entry(*r, "testing.rollback",
                                   {{"steps", std::vector<double>{1}}, {"scramble_undeclared", true}})});
  RunOptions o = test::dry();
  o.check_rollbacks = true;
  Simulation sim(s, *r, o);
  sim.advance();
  try {
    sim.advance();
    FAIL("the undeclared write was not caught");
  } catch (const RunError& e) {
    const std::string m = e.what();
    CHECK(m.find("field 'type' differs") != std::string::npos);
    CHECK(m.find("testing.rollback") != std::string::npos);
  }
}
