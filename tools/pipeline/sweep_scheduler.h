// `pipeline sweep`: running the planned runs a few at a time (sweep_scheduler.cpp, whose header
// says why they are child processes by default): launching each `pipeline run`, collecting its
// outcome into its Run and the index, the progress lines, failures and SIGINT/SIGTERM.
#pragma once
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "tools/pipeline/sweep.h"

namespace ff::cli::sweep {

// How the runs are launched: what cmd_sweep.cpp decided from the options and the machine.
struct LaunchSettings {
  std::string pipeline_file;           // FILE of every `pipeline run`
  std::string device;                  // --device of every run: "cpu" or "cuda"
  std::filesystem::path root;          // the sweep's folder; a run's is root / Run::folder
  std::string index_file;              // rewritten whenever a run starts or ends
  std::vector<std::string> shared_sets;  // the sweep's --set arguments: columns of the index
  std::vector<std::string> gpus;       // CUDA_VISIBLE_DEVICES value of each GPU; empty on the CPU
  int runs_at_once = 1;                // in all, over every GPU
  int threads_per_run = 1;             // --threads of each child process
  bool in_process = false;             // threads of this process instead of child processes
  bool force = false;                  // --force: no run continues from a checkpoint
  std::vector<std::string> extra_env;  // added to the children's environment (MPS's pipe directory)
};

// How the runs of this invocation ended.
struct Outcome {
  std::size_t done = 0, failed = 0, interrupted = 0;
  int stop_signal = 0;  // SIGINT or SIGTERM when the sweep was stopped, else 0
};

// Runs every run whose status is not "done", at most runs_at_once at a time, in order; each
// run's folder gets its run.log, and its Run (and the index) its status, exit code, rate, wall
// time and message. A run that fails does not stop the others. SIGINT/SIGTERM: the runs under
// way are told to checkpoint and stop, no more start. Prints progress and a summary on stderr.
// Throws RunError when a run cannot be started (fork, its log file).
Outcome run_all(const LaunchSettings& settings, const std::vector<Axis>& axes, std::vector<Run>& runs);

}  // namespace ff::cli::sweep
