// Shared by the end-to-end tests that shell out (test_cli, test_render, test_checkpoint,
// test_sweep, test_readers, test_team, test_decomposition*): where the `pipeline` executable and
// the repository's files are, the device they run on, a way to run a command and keep its exit
// code and combined output, and the requirement that it succeeded. Kept here so they all resolve
// paths and devices the same way and a failed command reports itself the same way.
#pragma once
#include <boost/dll/runtime_symbol_info.hpp>
#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>

#include "core/backend/device.h"

namespace ff::test {

// The `pipeline` binary built next to the running test binary.
inline std::string pipeline_exe() {
  return (boost::dll::program_location().parent_path() / "pipeline").string();
}

// A file of the repository: CTest and a bundle's run-tests set FLIPFLOW_TEST_DATA=<root>/tests/data.
// Run by hand, the first of these that holds the file: the repository from this header's own path
// (<repo>/tests/support/cli.h; relative to the build folder when ccache rewrote it, so only from
// there), then the bundle the test binary sits in (<bundle>/bin/test_*, <bundle>/pipelines).
inline std::filesystem::path repo_file(const std::string& rel) {
  namespace fs = std::filesystem;
  if (const char* data = std::getenv("FLIPFLOW_TEST_DATA")) return (fs::path(data) / ".." / ".." / rel).lexically_normal();
  const fs::path from_source = fs::path(__FILE__).parent_path().parent_path().parent_path() / rel;
  const fs::path from_bundle =
      fs::path(boost::dll::program_location().parent_path().parent_path().string()) / rel;
  for (const fs::path& p : {from_source, from_bundle})
    if (fs::exists(p)) return p.lexically_normal();
  return from_source.lexically_normal();
}

// The device the end-to-end tests give `pipeline --device`: FLIPFLOW_TEST_DEVICE, cpu unless set
// (cuda on a GPU node runs the same tests there).
inline std::string test_device() {
  const char* d = std::getenv("FLIPFLOW_TEST_DEVICE");
  return d && *d ? d : "cpu";
}

// Whether test_device() is here (CUDA: a GPU); otherwise the test says it skipped `what`.
inline bool test_device_available(const std::string& what) {
  if (test_device() != "cuda") return true;
  if (ff::cuda_device_available()) return true;
  WARN("SKIPPED (" + ff::no_cuda_device_reason() + "): " + what);
  return false;
}

struct CommandResult {
  int code;         // exit status, -1 if the command did not exit normally
  std::string out;  // stdout and stderr together
  std::string cmd;  // the command line that ran
};

// Runs `cmd` through the shell with stdout+stderr sent to `log` (read back, then removed).
inline CommandResult run_command(const std::string& cmd, const std::filesystem::path& log) {
  const int status = std::system((cmd + " > " + log.string() + " 2>&1").c_str());
  std::stringstream ss;
  {
    std::ifstream in(log);
    ss << in.rdbuf();
  }
  std::filesystem::remove(log);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, ss.str(), cmd};
}

// The last `lines` lines of `text` (all of it when shorter): what a failed command said last.
inline std::string last_lines(const std::string& text, std::size_t lines = 40) {
  std::size_t start = text.size();
  if (start && text[start - 1] == '\n') --start;  // a final newline ends the last line
  for (std::size_t k = 0; k < lines; ++k) {
    const std::size_t newline = start ? text.rfind('\n', start - 1) : std::string::npos;
    if (newline == std::string::npos) return text;
    start = newline;
  }
  return text.substr(start + 1);
}

// Requires that `r` exited with status 0. A failure names the command line, its exit status and
// the last lines of its output, so that the test says which command failed and why. Returns `r`
// for the checks that follow, e.g. `auto r = require_success(run_command(cmd, log));`.
inline CommandResult require_success(CommandResult r) {
  INFO("command: " << r.cmd << "\nexit status " << r.code << "; the last lines of its output:\n" << last_lines(r.out));
  REQUIRE(r.code == 0);
  return r;
}

// Every dataset of an H5MD file but /parameters with its hash (`h5hash`, built beside
// `pipeline`), one "name hash" line each: two runs that wrote the same bits give the same text.
inline CommandResult dataset_hashes(const std::filesystem::path& h5, const std::filesystem::path& log) {
  const std::string h5hash = (std::filesystem::path(pipeline_exe()).parent_path() / "h5hash").string();
  return run_command(h5hash + " " + h5.string() + " | grep -v ' /parameters' | awk '{print $1, $2}'", log);
}

}  // namespace ff::test
