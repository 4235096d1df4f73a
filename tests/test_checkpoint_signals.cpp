// Runs that end early, end to end (the `pipeline` command): SIGKILL at a random step, then
// --resume, gives the files of an uninterrupted run; SIGTERM finishes the step, writes a
// checkpoint and exits 3; SIGINT during set-up stops at step 0 with a checkpoint, a second stops
// at once, and a SIGTERM after it does not; a run killed outright leaves g(r) of a checkpoint
// beside it; a failed run names its newest checkpoint and the command that continues it.
//
// Runs on the CPU; FLIPFLOW_TEST_DEVICE=cuda runs the same on the GPU (skipped without one).
#include <catch2/catch.hpp>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "support/checkpoint_runs.h"
#include "support/cli.h"
#include "support/h5md_files.h"

namespace fs = std::filesystem;

using namespace ff::test;
using namespace ff::test::checkpoint_runs;

TEST_CASE("checkpoint: SIGKILL at a random step, then --resume: the same files", "[checkpoint]") {
  if (!device_available()) return;
  Case c = abp_case();
  c.sets.back() = "run.checkpoint={every: 10, keep: 2}";
  const std::uint64_t steps = 20000;  // seconds: the kill lands mid-run
  const fs::path ref = fresh_dir("kill_ref"), out = fresh_dir("kill");
  require_success(pipeline(run_args(c, ref, steps)));
  std::mt19937 rng(std::random_device{}());
  const int delay_ms = std::uniform_int_distribution<int>(0, 1500)(rng);
  const fs::path log = out / "log";
  const pid_t pid = spawn_pipeline(run_args(c, out, steps), log);
  const bool checkpointed = wait_for_checkpoint(out, pid, 120);
  std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
  ::kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  INFO(file_text(log));
  const bool killed = WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL;
  if (!killed || !checkpointed) WARN("the run ended before SIGKILL (" << delay_ms << " ms after its first checkpoint)");
  std::string resumed;  // its output names the checkpoint it resumed from
  if (killed) {
    REQUIRE(checkpointed);
    resumed = require_success(pipeline(run_args(c, out, steps) + " --resume")).out;
  }
  INFO("killed " << delay_ms << " ms after the first checkpoint; the resumed run said:\n" << resumed);
  require_same_h5md(ref / c.h5, out / c.h5);
  remove_unless_different(ref, out, c.h5);
}

TEST_CASE("checkpoint: SIGTERM finishes the step, writes a checkpoint, exits 3; --resume completes identically",
          "[checkpoint]") {
  if (!device_available()) return;
  Case c = abp_case();
  c.sets.back() = "run.checkpoint={every: 1000000}";  // no periodic checkpoint: the signal's is the only one
  const std::uint64_t steps = 20000;  // seconds: the signal lands mid-run
  const fs::path ref = fresh_dir("term_ref"), out = fresh_dir("term");
  require_success(pipeline(run_args(c, ref, steps)));
  const fs::path log = fresh_dir("term_log") / "log";
  const pid_t pid = spawn_pipeline(run_args(c, out, steps), log);
  // Once frames appear the run is stepping.
  for (int k = 0; k < 20000 && !fs::exists(out / (c.h5 + ".partial")); ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  std::mt19937 rng(std::random_device{}());
  std::this_thread::sleep_for(std::chrono::milliseconds(std::uniform_int_distribution<int>(50, 1500)(rng)));
  ::kill(pid, SIGTERM);
  int status = 0;
  waitpid(pid, &status, 0);
  const std::string text = file_text(log);
  INFO(text);
  REQUIRE(WIFEXITED(status));
  std::string resumed;  // its output names the checkpoint it resumed from
  if (WEXITSTATUS(status) == 0) {
    WARN("the run finished before SIGTERM arrived");
  } else {
    CHECK(WEXITSTATUS(status) == 3);
    CHECK_THAT(text, Catch::Contains("stopped by SIGTERM"));
    REQUIRE(checkpoints(out).size() == 1);
    CHECK(fs::exists(out / (c.h5 + ".partial")));
    // Continued with the command the run printed, as a user would paste it: it must carry the
    // run's --set arguments (N, the steps, ...), which a continuation needs.
    const std::string hint = "continue with: pipeline ";
    const std::size_t at = text.find(hint);
    REQUIRE(at != std::string::npos);
    const std::string command = text.substr(at + hint.size(), text.find('\n', at) - at - hint.size());
    CHECK_THAT(command, Catch::Contains("--set run.steps=" + std::to_string(steps)) && Catch::Contains("--resume"));
    // (pipeline() adds --device and --threads itself: the hint's own are left out.)
    std::string pasted = command;
    const std::size_t device = pasted.find(" --device "), resume = pasted.find(" --resume ");
    if (device != std::string::npos && device < resume) pasted.erase(device, resume - device);
    resumed = require_success(pipeline(pasted)).out;
  }
  INFO("the resumed run said:\n" << resumed);
  require_same_h5md(ref / c.h5, out / c.h5);
  remove_unless_different(ref, out, c.h5);
  fs::remove_all(log.parent_path());
}

TEST_CASE("checkpoint: SIGINT during set-up stops at step 0 with a checkpoint; a second stops at once",
          "[checkpoint]") {
  // Before: the handlers came with the first step, so Ctrl-C during a long set-up ended the run
  // with exit 130, no message, and the set-up's work lost.
  if (!device_available()) return;
  Case c = abp_case();
  c.sets.front() = "system.N=200000";  // from 10^5 particles the run says when set-up starts
  c.sets.back() = "run.checkpoint={every: 1000000}";
  auto interrupted = [&](const std::string& name, std::vector<int> signals) {
    const fs::path out = fresh_dir(name), log = fresh_dir(name + "_log") / "log";
    const pid_t pid = spawn_pipeline(run_args(c, out, 2), log);
    bool setting_up = false;
    for (int k = 0; k < 60000 && !setting_up; ++k) {
      setting_up = fs::exists(log) && file_text(log).find("setting up 200000 particles") != std::string::npos;
      if (!setting_up) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    for (std::size_t k = 0; k < signals.size(); ++k) {
      if (k) std::this_thread::sleep_for(std::chrono::milliseconds(20));
      ::kill(pid, signals[k]);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    const std::string text = file_text(log);
    INFO(text);
    REQUIRE(setting_up);
    REQUIRE(WIFEXITED(status));
    return std::make_tuple(out, WEXITSTATUS(status), text);
  };
  {
    auto [out, code, text] = interrupted("setup_int", {SIGINT});
    CHECK(code == 3);
    CHECK_THAT(text, Catch::Contains("interrupted during set-up: stops once set-up ends") &&
                         Catch::Contains("stopped by SIGINT after step 0"));
    const std::vector<fs::path> written = checkpoints(out);
    REQUIRE(written.size() == 1);
    CHECK(written[0].filename() == "checkpoint-000000000000.h5");
    // The set-up is kept: the run continues from it to its end.
    auto resumed = require_success(pipeline(run_args(c, out, 2) + " --resume"));
    CHECK_THAT(resumed.out, Catch::Contains("at step 0"));
    CHECK(fs::exists(out / c.h5));
    fs::remove_all(out);
  }
  {
    auto [out, code, text] = interrupted("setup_int2", {SIGINT, SIGINT});
    CHECK(code == 128 + SIGINT);
    CHECK_THAT(text, Catch::Contains("a second interrupt: stopped at once, without a checkpoint"));
    CHECK((!fs::exists(out) || checkpoints(out).empty()));
    fs::remove_all(out);
  }
  {
    // One request to stop that arrives twice, as a sweep's runs get Ctrl-C from the terminal and
    // SIGTERM from the sweep: a SIGTERM never stops at once (before: exit 143, no checkpoint, and
    // the sweep marked the run failed).
    auto [out, code, text] = interrupted("setup_int_term", {SIGINT, SIGTERM});
    CHECK(code == 3);
    CHECK_THAT(text, !Catch::Contains("a second interrupt"));
    CHECK(checkpoints(out).size() == 1);
    fs::remove_all(out);
  }
}

TEST_CASE("checkpoint: SIGKILL leaves g(r) as of a checkpoint beside it, not only inside it", "[checkpoint]") {
  // Before: observe.gr wrote its CSV only at the run's end, so a run killed outright left its
  // histogram only as bytes in the checkpoint. Each checkpoint now writes gr.csv.partial first.
  if (!device_available()) return;
  const std::uint64_t every = 50, steps = 200000;  // seconds: the kill lands mid-run
  Case c{repo_file("pipelines/hard-disks.yaml").string(),
         {"system.N=400", "step.observe.gr.from_step=0", "step.observe.gr.every=5", "step.observe.h5md.every=1000",
          "step.observe.progress.every=1000000", "run.checkpoint={every: " + std::to_string(every) + ", keep: 2}"},
         "trajectory.h5",
         {"gr.csv"}};
  const fs::path out = fresh_dir("kill_gr");
  const fs::path log = fresh_dir("kill_gr_log") / "log";
  const pid_t pid = spawn_pipeline(run_args(c, out, steps), log);
  const bool checkpointed = wait_for_checkpoint(out, pid, 120);
  if (checkpointed) CHECK(fs::exists(out / "gr.csv.partial"));  // written before the checkpoint's file
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ::kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  INFO(file_text(log));
  REQUIRE(checkpointed);
  REQUIRE((WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL));
  // Its frame count is that of a checkpoint's step (g(r) at steps 0, 5, ..., s: s / 5 + 1),
  // the newest one's or, killed between the CSV and the checkpoint's file, the next one's.
  const std::string text = file_text(out / "gr.csv.partial");
  const std::size_t at = text.find("frames = ");
  REQUIRE(at != std::string::npos);
  const std::uint64_t frames = std::stoull(text.substr(at + 9));
  const std::vector<fs::path> written = checkpoints(out);
  REQUIRE(!written.empty());
  const std::string name = written.back().stem().string();  // checkpoint-<step>
  const std::uint64_t newest = std::stoull(name.substr(name.find('-') + 1));
  INFO("newest checkpoint at step " << newest << ", gr.csv.partial has " << frames << " frames");
  CHECK((frames == newest / 5 + 1 || frames == (newest + every) / 5 + 1));
  CHECK(text.find("r_lo,r_hi,r,g,pairs") != std::string::npos);
  fs::remove_all(out);
  fs::remove_all(log.parent_path());
}

TEST_CASE("checkpoint: a failed run names its newest checkpoint and the command that continues it", "[checkpoint]") {
  if (!device_available()) return;
  // v0 = 28 at Δt = 0.01 crosses edges from both sides after ~2 000 steps on the CPU, and dt_min
  // = Δt leaves no smaller step to retry with: the run fails after some checkpoints.
  Case c = abp_case();
  c.sets.back() = "run.checkpoint={every: 10, keep: 2}";
  c.sets.push_back("step.abp.integrate.v0=28");
  c.sets.push_back("run.dt_min=0.01");
  const fs::path out = fresh_dir("failed");
  const auto failed = pipeline(run_args(c, out, 20000));
  INFO(failed.out);
  REQUIRE(failed.code == 1);
  const std::vector<fs::path> written = checkpoints(out);
  REQUIRE(!written.empty());
  CHECK_THAT(failed.out, Catch::Contains("the newest checkpoint is " + written.back().string()) &&
                             Catch::Contains("--resume " + out.string() + " --allow-changes --set KEY=VALUE"));
  // Continued as the message says, with the change that lets a step be retried at a smaller Δt.
  const auto continued = pipeline(run_args(c, out, 20000) + " --resume --allow-changes --set run.dt_min=1e-6");
  INFO(continued.out);
  CHECK(continued.code == 0);
  fs::remove_all(out);
}
