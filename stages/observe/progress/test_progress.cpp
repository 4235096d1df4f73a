// observe.progress alone: its line's format, and a line per call in a log without a rate limit.
#include <catch2/catch.hpp>
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "core/stage/state.h"
#include "stages/observe/progress/stage.h"
#include "support/stage_driver.h"

using namespace ff;

namespace {
// The lines written to `out` (a tmpfile), which it closes.
std::vector<std::string> lines_of(std::FILE* out) {
  std::rewind(out);
  std::vector<std::string> lines;
  char buf[512];
  while (std::fgets(buf, sizeof buf, out)) lines.emplace_back(buf);
  std::fclose(out);
  return lines;
}
}  // namespace

TEST_CASE("observe.progress: a line per interval in logs", "[observe][progress]") {
  observe::ProgressLine l;
  l.step = 20;
  l.steps = 100;
  l.time = 0.2;
  l.dt = 0.01;
  l.rate = 50;
  l.rollbacks = 3;
  CHECK(observe::format_progress(l) == "step 20/100 (20.0%)  t 0.2  Δt 0.01  50 steps/s  ETA 0:00:02  rollbacks 3");
  CHECK(observe::format_duration(3725) == "1:02:05");
  CHECK(observe::format_duration(-1) == "--:--");

  auto lines_for = [](double interval) {
    std::FILE* out = std::tmpfile();
    RunInfo info;
    info.steps = 100;
    observe::Progress progress(observe::ProgressParams{interval}, info, out);
    State s(2, Precision::f64, 1);
    test::StageDriver driver(Backend::cpu, Precision::f64, 2);
    driver.stats.dt = 0.01;
    for (int k = 1; k <= 3; ++k) {
      driver.stats.rollbacks = std::uint64_t(k);
      driver.run(progress, s, std::uint64_t(10 * k), 0.01);  // time 0.1 k
    }
    progress.finish(s, true);
    return lines_of(out);
  };
  const auto every = lines_for(0.0);  // not a terminal, no rate limit: a line per call
  REQUIRE(every.size() == 3);
  CHECK(every[0].rfind("step 10/100 (10.0%)  t 0.1  Δt 0.01  0 steps/s  ETA --:--  rollbacks 1\n", 0) == 0);
  CHECK(every[2].rfind("step 30/100 (30.0%)  t 0.3  Δt 0.01  ", 0) == 0);
  CHECK(every[2].find("rollbacks 3\n") != std::string::npos);
  CHECK(lines_for(3600.0).empty());  // a log: nothing before `interval` seconds have passed
}

TEST_CASE("observe.progress: the rate leaves out the first interval, which holds the first step's set-up",
          "[observe][progress]") {
  // Before: the rate was the mean since the first report, so a first step that built a
  // triangulation of 10^6 particles (~20 s) put the ETA at 29 hours for a 10-minute run.
  std::FILE* out = std::tmpfile();
  RunInfo info;
  info.steps = 1000;
  observe::Progress progress(observe::ProgressParams{0.0}, info, out);
  State s(2, Precision::f64, 1);
  test::StageDriver driver(Backend::cpu, Precision::f64, 2);
  driver.stats.dt = 0.01;
  driver.run(progress, s, 0, 0.01);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the first step's one-off work
  for (std::uint64_t k = 1; k <= 11; ++k) driver.run(progress, s, k, 0.01);
  progress.finish(s, true);
  const std::vector<std::string> lines = lines_of(out);
  REQUIRE(lines.size() == 12);
  // The report that closes the first interval gives no rate rather than one the sleep drags down.
  CHECK_THAT(lines[1], Catch::Contains("step 1/1000") && Catch::Contains(" 0 steps/s  ETA --:--"));
  const std::string last = lines.back();
  // Ten steps after the interval with the sleep, taking microseconds: far above the 11 / 0.3 =
  // 37 steps/s of a mean that includes the sleep.
  const std::size_t at = last.find(" steps/s");
  REQUIRE(at != std::string::npos);
  const double rate = std::stod(last.substr(last.rfind("  ", at - 1) + 2));
  INFO(last);
  CHECK(rate > 1000.0);
}
