#pragma once
#include <atomic>
#include <cstdio>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

namespace ff::cli {

constexpr int kExitInterrupted = 3;

// One `pipeline run`, as its options say.
struct RunRequest {
  std::string file;
  std::vector<std::string> overrides;  // --set
  std::string device = "auto";
  std::string out;                     // empty: runs/<file stem>, or the --resume folder
  bool force = false;
  bool resuming = false;
  std::string resume_where;            // --resume DIR|CHECKPOINT.h5 (empty: the output folder)
  bool allow_changes = false;
  bool check_rollbacks = false;
  int threads = 0;                     // > 0: limit oneTBB (process-wide) for the run's duration
  int gpus = 1;                        // > 1: a team of ranks (core/run/team.h), one thread each
  // Launch every step's work directly, never from a captured CUDA graph (same bits): for runs
  // sharing a process, where a device-wide wait of one would break another's capture.
  bool no_graph_capture = false;
  // Where the run's stages write their messages (RunInfo::messages): stderr, or, for a run of an
  // in-process sweep, the C stream behind its `log` (its run.log), so the lines stay in order.
  std::FILE* messages = stderr;
};

// Runs one pipeline as `pipeline run` does, writing its messages to `log`. When `stop` becomes
// non-zero (the signal number) the run finishes the step under way, writes a checkpoint and
// returns kExitInterrupted; else 0 when done. `before_steps` is called once the run is set up,
// before its first step. InputError / RunError as `pipeline run` reports them (exit 2 / 1).
int run_pipeline(const RunRequest& req, std::ostream& log, const std::atomic<int>& stop,
                 const std::function<void()>& before_steps = {});

int cmd_run(const std::vector<std::string>& args);
int cmd_validate(const std::vector<std::string>& args);
int cmd_graph(const std::vector<std::string>& args);
int cmd_stages(const std::vector<std::string>& args);
int cmd_describe(const std::vector<std::string>& args);
int cmd_bench(const std::vector<std::string>& args);
int cmd_sweep(const std::vector<std::string>& args);
}  // namespace ff::cli
