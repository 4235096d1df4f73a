// Shared by the end-to-end tests that shell out (test_cli, test_render): where the `pipeline`
// executable and the repository's files are, and a way to run a command and keep its exit code
// and combined output. Kept here so both tests resolve paths the same way.
#pragma once
#include <boost/dll/runtime_symbol_info.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>

namespace ff::test {

// The `pipeline` binary built next to the running test binary.
inline std::string pipeline_exe() {
  return (boost::dll::program_location().parent_path() / "pipeline").string();
}

// A file of the repository: CTest sets FLIPFLOW_TEST_DATA=<repo>/tests/data; run by hand, the
// repository is found from this header's own path (<repo>/tests/support/cli.h).
inline std::filesystem::path repo_file(const std::string& rel) {
  namespace fs = std::filesystem;
  const char* data = std::getenv("FLIPFLOW_TEST_DATA");
  fs::path base = data ? fs::path(data) / ".." / ".." : fs::path(__FILE__).parent_path().parent_path().parent_path();
  return (base / rel).lexically_normal();
}

struct CommandResult {
  int code;         // exit status, -1 if the command did not exit normally
  std::string out;  // stdout and stderr together
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
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, ss.str()};
}

}  // namespace ff::test
