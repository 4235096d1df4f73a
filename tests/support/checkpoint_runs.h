// Helpers of the checkpoint tests (test_checkpoint.cpp: continuations and refusals;
// test_checkpoint_signals.cpp: runs stopped by signals, killed or failed): running `pipeline` on
// the test's device, a pipeline with its --set arguments (Case), reading checkpoints and H5MD
// observables, and a run spawned in the background.
#pragma once
#include <catch2/catch.hpp>
#include <hdf5.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "support/cli.h"
#include "support/h5md_files.h"

extern char** environ;

namespace ff::test::checkpoint_runs {

namespace fs = std::filesystem;
inline std::string device() { return ff::test::test_device(); }
inline bool device_available() { return ff::test::test_device_available("checkpoint continuation on CUDA"); }

inline fs::path fresh_dir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("ff_ckpt_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

inline ff::test::CommandResult pipeline(const std::string& args) {
  return ff::test::run_command(pipeline_exe() + " " + args + " --device " + device() + " --threads 2",
                               fs::temp_directory_path() / ("ff_ckpt_" + std::to_string(::getpid()) + ".log"));
}

inline std::string quoted(const std::vector<std::string>& sets) {
  std::string s;
  for (auto& x : sets) s += " --set '" + x + "'";
  return s;
}

// ---- reading an H5MD file (the rest: support/h5md_files.h) ----

// A /parameters attribute (scalar string) or "" when missing.
inline std::string parameter_attribute(const fs::path& file, const std::string& object, const std::string& attr) {
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
inline double last_observable(const fs::path& file, const std::string& name) {
  const auto d = datasets(file);
  const Dataset& v = d.at("observables/" + name + "/value");
  REQUIRE(v.bytes.size() >= sizeof(double));
  double x;
  std::memcpy(&x, v.bytes.data() + v.bytes.size() - sizeof(double), sizeof(double));
  return x;
}

inline double observable_at(const fs::path& file, const std::string& name, std::int64_t step) {
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

inline std::vector<fs::path> checkpoints(const fs::path& dir) {
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

inline std::string run_args(const Case& c, const fs::path& out, std::uint64_t steps) {
  return "run " + c.file + quoted(c.sets) + " --set run.steps=" + std::to_string(steps) + " --out " + out.string();
}

// 2n steps in one run; n steps, then --resume to 2n: the same files.
inline void check_continuation(const Case& c, std::uint64_t n, const std::string& name) {
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

inline pid_t spawn_pipeline(const std::string& args, const fs::path& log) {
  const std::string cmd = "exec " + pipeline_exe() + " " + args + " --device " + device() + " --threads 2 > " +
                          log.string() + " 2>&1";
  pid_t pid = 0;
  const char* argv[] = {"/bin/sh", "-c", cmd.c_str(), nullptr};
  REQUIRE(posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char* const*>(argv), environ) == 0);
  return pid;
}

// Waits until `dir` holds a checkpoint (or the process ended); true when one appeared.
inline bool wait_for_checkpoint(const fs::path& dir, pid_t pid, double seconds) {
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
inline void remove_unless_different(const fs::path& ref, const fs::path& out, const std::string& h5) {
  if (!same_h5md(ref / h5, out / h5)) {
    WARN("kept for inspection: " << ref.string() << " and " << out.string());
    return;
  }
  fs::remove_all(ref);
  fs::remove_all(out);
}

inline Case abp_case() {
  return {repo_file("pipelines/abp.yaml").string(),
          {"system.N=400", "step.observe.msd.every=10", "step.observe.h5md.every=10",
           "step.observe.progress.every=1000", "run.checkpoint={every: 25, keep: 2}"},
          "abp.h5",
          {}};
}

}  // namespace ff::test::checkpoint_runs
