// Checkpoints and --resume end to end (the `pipeline` command): a run of 2n steps equals n steps
// + --resume + n steps in every dataset of its H5MD file (and its CSV files), for ABP, hard
// disks with rollbacks in the second half, the phoretic short-range model (a Verlet list) and a
// pipeline of `every:` observers; after SIGKILL at a random step; after SIGTERM (exit 3, a
// checkpoint at the step it stopped); and the refusals (changed N, changed stages, changed
// parameters without --allow-changes, a corrupt and a truncated checkpoint), each exit 2, with
// the previous checkpoint still resuming (a corrupt or truncated newest one in the folder is
// skipped).
//
// Runs on the CPU; FLIPFLOW_TEST_DEVICE=cuda runs the same on the GPU (skipped without one).
#include <catch2/catch.hpp>
#include <hdf5.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <thread>
#include <tuple>

#include "core/backend/device.h"
#include "support/cli.h"
#include "support/h5md_files.h"

extern char** environ;

namespace fs = std::filesystem;

namespace {

using namespace ff::test;  // pipeline_exe, repo_file, datasets, require_same_h5md, ...

std::string device() { return ff::test::test_device(); }
bool device_available() { return ff::test::test_device_available("checkpoint continuation on CUDA"); }

fs::path fresh_dir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("ff_ckpt_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

ff::test::CommandResult pipeline(const std::string& args) {
  return ff::test::run_command(pipeline_exe() + " " + args + " --device " + device() + " --threads 2",
                               fs::temp_directory_path() / ("ff_ckpt_" + std::to_string(::getpid()) + ".log"));
}

std::string quoted(const std::vector<std::string>& sets) {
  std::string s;
  for (auto& x : sets) s += " --set '" + x + "'";
  return s;
}

// ---- reading an H5MD file (the rest: support/h5md_files.h) ----

// A /parameters attribute (scalar string) or "" when missing.
std::string parameter_attribute(const fs::path& file, const std::string& object, const std::string& attr) {
  hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return "";
  std::string out;
  if (H5Aexists_by_name(f, object.c_str(), attr.c_str(), H5P_DEFAULT) > 0) {
    hid_t a = H5Aopen_by_name(f, object.c_str(), attr.c_str(), H5P_DEFAULT, H5P_DEFAULT);
    hid_t t = H5Aget_type(a);
    out.assign(H5Tget_size(t), '\0');
    H5Aread(a, t, out.data());
    while (!out.empty() && out.back() == '\0') out.pop_back();
    H5Tclose(t);
    H5Aclose(a);
  }
  H5Fclose(f);
  return out;
}

// The last value of /observables/<name>/value (double).
double last_observable(const fs::path& file, const std::string& name) {
  const auto d = datasets(file);
  const Dataset& v = d.at("observables/" + name + "/value");
  REQUIRE(v.bytes.size() >= sizeof(double));
  double x;
  std::memcpy(&x, v.bytes.data() + v.bytes.size() - sizeof(double), sizeof(double));
  return x;
}

double observable_at(const fs::path& file, const std::string& name, std::int64_t step) {
  const auto d = datasets(file);
  const Dataset& s = d.at("observables/" + name + "/step");
  const Dataset& v = d.at("observables/" + name + "/value");
  for (std::size_t k = 0; k * 8 < s.bytes.size(); ++k) {
    std::int64_t st;
    std::memcpy(&st, s.bytes.data() + 8 * k, 8);
    if (st == step) {
      double x;
      std::memcpy(&x, v.bytes.data() + 8 * k, 8);
      return x;
    }
  }
  FAIL("no frame at step " << step << " in " << name);
  return 0;
}

std::vector<fs::path> checkpoints(const fs::path& dir) {
  std::vector<fs::path> out;
  for (auto& e : fs::directory_iterator(dir)) {
    const std::string n = e.path().filename().string();
    if (n.rfind("checkpoint-", 0) == 0 && e.path().extension() == ".h5") out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

// One pipeline, its --set arguments, the H5MD file and CSV files it writes.
struct Case {
  std::string file;
  std::vector<std::string> sets;
  std::string h5;
  std::vector<std::string> csv;
};

std::string run_args(const Case& c, const fs::path& out, std::uint64_t steps) {
  return "run " + c.file + quoted(c.sets) + " --set run.steps=" + std::to_string(steps) + " --out " + out.string();
}

// 2n steps in one run; n steps, then --resume to 2n: the same files.
void check_continuation(const Case& c, std::uint64_t n, const std::string& name) {
  const fs::path one = fresh_dir(name + "_one"), two = fresh_dir(name + "_two");
  require_success(pipeline(run_args(c, one, 2 * n)));
  require_success(pipeline(run_args(c, two, n)));
  REQUIRE(!checkpoints(two).empty());
  auto second = require_success(pipeline(run_args(c, two, 2 * n) + " --resume"));
  CHECK_THAT(second.out, Catch::Contains("resuming"));
  CHECK(require_same_h5md(one / c.h5, two / c.h5) >= 4);
  for (auto& csv : c.csv) {
    INFO("CSV " << csv);
    REQUIRE(fs::exists(one / csv));
    CHECK(file_text(one / csv) == file_text(two / csv));
  }
  // Item 3: the output records what produced it, and the continuation its history.
  CHECK(parameter_attribute(two / c.h5, "/parameters", "flipflow_version") != "");
  CHECK(parameter_attribute(two / c.h5, "/parameters", "commit") != "");
  CHECK(parameter_attribute(two / c.h5, "/parameters/history/0", "step") == std::to_string(n));
  CHECK(parameter_attribute(two / c.h5, "/parameters", "device") != "");
  // The effective pipeline and the resolved parameters carry the --set values, not the file's.
  for (auto& set : c.sets) {
    INFO("--set " << set);
    CHECK_THAT(parameter_text(two / c.h5, "/parameters/overrides"), Catch::Contains(set));
  }
  if (!c.sets.empty() && c.sets.front() == "system.N=400") {
    CHECK_THAT(parameter_text(two / c.h5, "/parameters/effective_pipeline"), Catch::Contains("N: 400"));
    CHECK_THAT(parameter_text(two / c.h5, "/parameters/resolved"), Catch::Contains("run.seed = "));
  }
  fs::remove_all(one);
  fs::remove_all(two);
}

pid_t spawn_pipeline(const std::string& args, const fs::path& log) {
  const std::string cmd = "exec " + pipeline_exe() + " " + args + " --device " + device() + " --threads 2 > " +
                          log.string() + " 2>&1";
  pid_t pid = 0;
  const char* argv[] = {"/bin/sh", "-c", cmd.c_str(), nullptr};
  REQUIRE(posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char* const*>(argv), environ) == 0);
  return pid;
}

// Waits until `dir` holds a checkpoint (or the process ended); true when one appeared.
bool wait_for_checkpoint(const fs::path& dir, pid_t pid, double seconds) {
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < seconds) {
    if (fs::exists(dir) && !checkpoints(dir).empty()) return true;
    int status;
    if (waitpid(pid, &status, WNOHANG) == pid) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return false;
}

// Removes a test's two output folders, or keeps both (and says where) when their files differ:
// what a failed comparison needs to be looked into.
void remove_unless_different(const fs::path& ref, const fs::path& out, const std::string& h5) {
  if (!same_h5md(ref / h5, out / h5)) {
    WARN("kept for inspection: " << ref.string() << " and " << out.string());
    return;
  }
  fs::remove_all(ref);
  fs::remove_all(out);
}

Case abp_case() {
  return {repo_file("pipelines/abp.yaml").string(),
          {"system.N=400", "step.observe.msd.every=10", "step.observe.h5md.every=10",
           "step.observe.progress.every=1000", "run.checkpoint={every: 25, keep: 2}"},
          "abp.h5",
          {}};
}

}  // namespace

TEST_CASE("checkpoint continuation: ABP, n + resume + n steps equal 2n steps in every H5MD dataset", "[checkpoint]") {
  if (!device_available()) return;
  check_continuation(abp_case(), 60, "abp");
}

TEST_CASE("checkpoint continuation: --resume takes the run's own --set arguments, so it gives only what changes",
          "[checkpoint]") {
  // Before: a run made with --set system.N=400 was refused on --resume without that --set again
  // ("the pipeline's structure differs"), with advice to start a new run from a frame.
  if (!device_available()) return;
  Case c = abp_case();
  c.sets.back() = "run.checkpoint={every: 25,\n keep: 2}";  // a value over two lines is recorded and taken whole
  const std::uint64_t n = 60;
  const fs::path one = fresh_dir("inherit_one"), two = fresh_dir("inherit_two");
  require_success(pipeline(run_args(c, one, 2 * n)));
  require_success(pipeline(run_args(c, two, n)));
  auto resumed = require_success(pipeline("run " + c.file + " --set run.steps=" + std::to_string(2 * n) + " --out " +
                                          two.string() + " --resume"));
  CHECK_THAT(resumed.out, Catch::Contains("resuming") && Catch::Contains("N = 400"));
  CHECK(require_same_h5md(one / c.h5, two / c.h5) >= 4);
  // Its checkpoints record the sets it ran with (the earlier run's, then its own), once each.
  const std::vector<fs::path> written = checkpoints(two);
  REQUIRE(!written.empty());
  const std::string sets = text_dataset(written.back(), "pipeline/overrides");
  INFO(written.back().string() << " pipeline/overrides: " << sets);
  CHECK_THAT(sets, Catch::Contains("system.N=400") && Catch::Contains("run.steps=" + std::to_string(2 * n)));
  std::size_t steps_sets = 0;
  for (std::size_t at = sets.find("run.steps="); at != std::string::npos; at = sets.find("run.steps=", at + 1)) ++steps_sets;
  CHECK(steps_sets == 1);
  // A second continuation inherits from the first's checkpoint in turn.
  auto again = require_success(pipeline("run " + c.file + " --set run.steps=" + std::to_string(3 * n) + " --out " +
                                        two.string() + " --resume"));
  CHECK_THAT(again.out, Catch::Contains("N = 400"));
  fs::remove_all(one);
  fs::remove_all(two);
  // A file valid only with the run's --set (D: -1 refused): the continuation's own load waits for
  // the checkpoint's sets (before: refused at the first load, naming D).
  const fs::path dir = fresh_dir("inherit_fix");
  fs::create_directories(dir);
  std::ofstream(dir / "fix.yaml") << "system: {dimensions: 2, N: 100, packing_fraction: 0.2, init: random}\n"
                                     "run: {steps: 20, dt: 0.001, checkpoint: {every: 10}}\nplugins: [brownian]\n"
                                     "step:\n  - {stage: brownian.integrate, D: -1}\n"
                                     "  - {stage: observe.h5md, every: 10, file: t.h5, fields: [position]}\n";
  const std::string file = (dir / "fix.yaml").string(), out = (dir / "out").string();
  require_success(pipeline("run " + file + " --set step.brownian.integrate.D=1 --out " + out));
  CHECK(pipeline("run " + file + " --set run.steps=40 --out " + (dir / "fresh").string()).code == 2);
  require_success(pipeline("run " + file + " --set run.steps=40 --resume --out " + out));
  fs::remove_all(dir);
}

TEST_CASE("checkpoint continuation: hard disks with rollbacks in the second half, and g(r)", "[checkpoint]") {
  if (!device_available()) return;
  // Δt = 0.05 at η = 0.5 makes detect_inversion ask for a rollback every few steps (19 in 120),
  // and Δt regrowing after 5 good steps keeps the controller's streak in play at the checkpoint.
  Case c{repo_file("pipelines/hard-disks.yaml").string(),
         {"system.N=400", "run.dt=0.05", "run.dt_grow_after=5", "step.observe.gr.from_step=0",
          "step.observe.gr.every=5",
          "step.observe.h5md.every=10",
          "step.observe.progress.every=1000", "run.checkpoint={every: 30}"},
         "trajectory.h5",
         {"gr.csv"}};
  const std::uint64_t n = 60;
  check_continuation(c, n, "hard_disks");
  // The rollbacks the test relies on: some in the second half (their count grows after step n).
  const fs::path out = fresh_dir("hard_disks_rollbacks");
  require_success(pipeline(run_args(c, out, 2 * n)));
  const double at_n = observable_at(out / c.h5, "rollbacks", std::int64_t(n));
  const double at_end = last_observable(out / c.h5, "rollbacks");
  INFO("rollbacks at step " << n << ": " << at_n << ", at the end: " << at_end);
  CHECK(at_end > at_n);
  // Scratch fields (detect_inversion's Lawson candidates: rewritten every step before they are
  // read, their contents between steps left in thread order) are not in a checkpoint, so two
  // identical runs write the same fields; the carried state is.
  const std::vector<fs::path> written = checkpoints(out);
  REQUIRE(!written.empty());
  const hid_t file = H5Fopen(written.back().string().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(H5Lexists(file, "/fields", H5P_DEFAULT) > 0);
  CHECK(H5Lexists(file, "/fields/position", H5P_DEFAULT) > 0);
  CHECK(H5Lexists(file, "/fields/delaunay.halfedge", H5P_DEFAULT) > 0);
  CHECK(H5Lexists(file, "/fields/delaunay.lawson_candidates", H5P_DEFAULT) == 0);
  H5Fclose(file);
  fs::remove_all(out);
}

TEST_CASE("checkpoint continuation: phoretic short range (a Verlet list carried across)", "[checkpoint]") {
  if (!device_available()) return;
  Case c{repo_file("pipelines/phoretic-c0-short.yaml").string(),
         {"system.N=400", "step.observe.h5md.every=10", "step.observe.progress.every=1000",
          "run.checkpoint={every: 50}"},
         "phoretic-c0-short.h5",
         {}};
  check_continuation(c, 50, "phoretic");
}

TEST_CASE("checkpoint continuation: 3D hard spheres (Verlet list rebuilt inside overlap_correct.verlet)",
          "[checkpoint]") {
  if (!device_available()) return;
  Case c{repo_file("pipelines/hard-spheres.yaml").string(),
         {"system.N=1000", "run.dt=0.001", "step.observe.gr.from_step=0", "step.observe.h5md.every=10",
          "step.observe.progress.every=1000", "run.checkpoint={every: 40}"},
         "trajectory.h5",
         {"gr.csv"}};
  check_continuation(c, 50, "hard_spheres");
}

TEST_CASE("checkpoint continuation: observers on `every:` schedules the checkpoint falls between", "[checkpoint]") {
  if (!device_available()) return;
  const fs::path dir = fresh_dir("every_pipeline");
  const fs::path file = dir / "every.yaml";
  std::ofstream(file) << R"(system: {dimensions: 2, N: 300, packing_fraction: 0.3, init: random}
run: {steps: 100, dt: 0.001, seed: 7, checkpoint: {every: 13, keep: 3}}
plugins: [brownian]
step:
  - {stage: delaunay.sort}
  - {stage: brownian.integrate, D: 1.0}
  - {stage: delaunay.detect_inversion}
  - {stage: delaunay.flip}
  - {stage: delaunay.lawson}
  - {stage: overlap_correct}
  - {stage: observe.msd, every: 3}
  - {stage: observe.gr, every: 5, r_max: 3.0, bins: 60}
  - {stage: observe.clusters, every: 7, bond: 1.2}
  - {stage: observe.h5md, every: 4, file: every.h5, fields: [position, image]}
)";
  check_continuation(Case{file.string(), {}, "every.h5", {"gr.csv", "clusters.csv", "cluster_sizes.csv"}}, 50,
                     "every");
  fs::remove_all(dir);
}

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

TEST_CASE("checkpoint: refusals exit 2 naming the difference; the previous checkpoint still resumes",
          "[checkpoint]") {
  if (!device_available()) return;
  Case c = abp_case();
  c.sets.back() = "run.checkpoint={every: 20, keep: 2}";
  const fs::path ref = fresh_dir("refuse_ref"), out = fresh_dir("refuse");
  require_success(pipeline(run_args(c, ref, 80)));
  require_success(pipeline(run_args(c, out, 40)));
  const auto files = checkpoints(out);
  REQUIRE(files.size() == 2);  // steps 20 and 40: keep 2
  CHECK(files[1].filename() == "checkpoint-000000000040.h5");

  // A structural change: N.
  auto n = pipeline(run_args(c, out, 80) + " --set system.N=401 --resume");
  CHECK(n.code == 2);
  CHECK_THAT(n.out, Catch::Contains("system.N: the checkpoint has 400, the pipeline 401"));

  // A structural change: the stage list.
  const fs::path extra = out / "extra-stage.yaml";
  {
    std::string text = file_text(c.file);
    const std::string msd = "  - {stage: observe.msd, every: 100}\n";
    REQUIRE(text.find(msd) != std::string::npos);
    text.replace(text.find(msd), msd.size(), msd + "  - {stage: observe.msd, id: msd2, every: 100}\n");
    std::ofstream(extra) << text;
  }
  Case changed = c;
  changed.file = extra.string();
  auto stages = pipeline(run_args(changed, out, 80) + " --resume");
  CHECK(stages.code == 2);
  CHECK_THAT(stages.out, Catch::Contains("stages: the checkpoint has 9, the pipeline 10"));
  CHECK_THAT(stages.out, Catch::Contains("structure differs"));

  // A parameter change needs --allow-changes.
  auto param = pipeline(run_args(c, out, 80) + " --set step.abp.integrate.v0=2 --resume");
  CHECK(param.code == 2);
  CHECK_THAT(param.out, Catch::Contains("step.abp.integrate.v0: 1 -> 2"));
  CHECK_THAT(param.out, Catch::Contains("--allow-changes"));

  // A corrupt checkpoint: one value changed, the checksum no longer matches.
  const fs::path saved = out / "saved.h5";
  fs::copy_file(files[1], saved);
  {
    hid_t f = H5Fopen(files[1].c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    REQUIRE(f >= 0);
    hid_t d = H5Dopen2(f, "clock/time", H5P_DEFAULT);
    const double t = 123.0;
    REQUIRE(H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, &t) >= 0);
    H5Dclose(d);
    H5Fclose(f);
  }
  auto corrupt = pipeline(run_args(c, out, 80) + " --resume " + files[1].string());
  CHECK(corrupt.code == 2);
  CHECK_THAT(corrupt.out, Catch::Contains("fails its checksum"));

  // A truncated checkpoint.
  fs::copy_file(saved, out / "truncated.h5");
  fs::resize_file(out / "truncated.h5", fs::file_size(saved) / 2);
  auto truncated = pipeline(run_args(c, out, 80) + " --resume " + (out / "truncated.h5").string());
  CHECK(truncated.code == 2);
  CHECK_THAT(truncated.out, Catch::Contains("truncated"));
  fs::remove(out / "truncated.h5");
  fs::remove(saved);

  // The directory: the corrupt newest is skipped with a warning, the one before resumes, and
  // the result is still the uninterrupted run's (frames after step 20 are dropped and redone).
  auto resumed = require_success(pipeline(run_args(c, out, 80) + " --resume"));
  CHECK_THAT(resumed.out, Catch::Contains("fails its checksum"));
  CHECK_THAT(resumed.out, Catch::Contains("at step 20"));
  require_same_h5md(ref / c.h5, out / c.h5);

  // A truncated newest checkpoint in the directory (a crash while the disk filled up, a copy cut
  // short): skipped with a warning like the corrupt one, the one before it resumes, same files.
  {
    const auto now = checkpoints(out);
    REQUIRE(now.size() == 2);  // steps 60 and 80, written by the run that just finished
    REQUIRE(now[1].filename() == "checkpoint-000000000080.h5");
    fs::resize_file(now[1], fs::file_size(now[1]) * 2 / 3);
    auto again = require_success(pipeline(run_args(c, out, 80) + " --resume"));
    CHECK_THAT(again.out, Catch::Contains("truncated"));
    CHECK_THAT(again.out, Catch::Contains("at step 60"));
    CHECK(fs::exists(out / "checkpoint-000000000080.h5.invalid"));
    require_same_h5md(ref / c.h5, out / c.h5);
  }

  // Extending the finished run with a changed parameter: allowed with --allow-changes, recorded.
  require_success(pipeline(run_args(c, out, 100) + " --set step.abp.integrate.v0=2 --resume --allow-changes"));
  CHECK_THAT(parameter_attribute(out / c.h5, "/parameters/history/2", "changes"),  // 0, 1: the resumes above
             Catch::Contains("step.abp.integrate.v0: 1 -> 2"));
  fs::remove_all(ref);
  fs::remove_all(out);
}

TEST_CASE("system.init.from starts a run from an H5MD frame: positions, images, species, orientations, box",
          "[checkpoint][init]") {
  if (!device_available()) return;
  const fs::path dir = fresh_dir("init_from");
  const fs::path file = dir / "source.yaml";
  std::ofstream(file) << R"(system: {dimensions: 2, N: 300, packing_fraction: 0.3, init: random,
         types: [{name: A, fraction: 0.5}, {name: B, fraction: 0.5, diameter: 1.2}]}
run: {steps: 30, dt: 0.01, seed: 3}
plugins: [abp]
step:
  - {stage: abp.integrate, v0: 1.0, Dr: 0.5, D: 0.1}
  - {stage: observe.h5md, every: 10, file: source.h5, fields: [position, image, orientation, type]}
)";
  require_success(pipeline("run " + file.string() + " --out " + (dir / "a").string()));
  // The second run starts from frame -1 (step 30) and writes its first frame at its step 0.
  require_success(pipeline("run " + file.string() + " --out " + (dir / "b").string() +
                           " --set 'system.init={from: " + (dir / "a" / "source.h5").string() +
                           ", frame: -1}' --set run.steps=10"));
  const auto a = datasets(dir / "a" / "source.h5"), b = datasets(dir / "b" / "source.h5");
  for (const char* element : {"position", "image", "orientation", "type"}) {
    INFO(element);
    const Dataset& va = a.at(std::string("particles/all/") + element + "/value");
    const Dataset& vb = b.at(std::string("particles/all/") + element + "/value");
    REQUIRE(va.shape.size() >= 2);
    REQUIRE(va.shape[0] == 4);  // steps 0, 10, 20, 30
    const std::size_t frame_bytes = va.bytes.size() / va.shape[0];
    REQUIRE(vb.bytes.size() >= frame_bytes);
    CHECK(std::equal(va.bytes.end() - std::ptrdiff_t(frame_bytes), va.bytes.end(), vb.bytes.begin()));
  }
  CHECK(a.at("particles/all/box/edges").bytes == b.at("particles/all/box/edges").bytes);
  // A frame out of range and a wrong N are refused with the key named.
  auto bad = pipeline("run " + file.string() + " --out " + (dir / "c").string() + " --set 'system.init={from: " +
                      (dir / "a" / "source.h5").string() + ", frame: 7}'");
  CHECK(bad.code == 2);
  CHECK_THAT(bad.out, Catch::Contains("frame 7 is out of range"));
  auto wrong_n = pipeline("run " + file.string() + " --out " + (dir / "d").string() + " --set system.N=301" +
                          " --set 'system.init={from: " + (dir / "a" / "source.h5").string() + "}'");
  CHECK(wrong_n.code == 2);
  CHECK_THAT(wrong_n.out, Catch::Contains("has 300 particles; system.N is 301"));
  fs::remove_all(dir);
}

TEST_CASE("h5md comparison: a differing dataset is reported by its first differing frame, step and entry",
          "[checkpoint]") {
  // What a failed comparison above prints instead of the datasets' bytes.
  Dataset a, b, steps;
  a.shape = {5, 4, 2};  // 5 frames of 4 particles x 2 int32
  a.bytes.assign(5 * 4 * 2 * 4, 0);
  b = a;
  b.bytes[3 * 32 + 2 * 8 + 4] = 1;  // frame 3, particle 2, component 1: entry 5
  b.bytes[4 * 32] = 7;              // frame 4, entry 0
  steps.shape = {5};
  for (std::int64_t k = 0; k < 5; ++k) {
    const std::int64_t s = 10 * k;
    const auto* p = reinterpret_cast<const unsigned char*>(&s);
    steps.bytes.insert(steps.bytes.end(), p, p + sizeof s);
  }
  const std::map<std::string, Dataset> series{{"particles/all/image/step", steps}};
  CHECK(first_difference("particles/all/image/value", a, a, series) == "");
  CHECK(first_difference("particles/all/image/value", a, b, series) ==
        "2 of 5 frames differ; the first is frame 3 (step 30), from its entry 5 (byte 20 of 32)");
  // Without a step series (or for a dataset that is not a series' value): the frame alone.
  CHECK(first_difference("observables/x", a, b, {}) ==
        "2 of 5 frames differ; the first is frame 3, from its entry 5 (byte 20 of 32)");
  Dataset shorter = a;
  shorter.bytes.resize(32);
  CHECK(first_difference("particles/all/image/value", a, shorter, series) == "160 bytes against 32");
}
