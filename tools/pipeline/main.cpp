// `pipeline`: run, check and inspect flipflow pipelines. Exit codes: 0 ok, 1 the run failed,
// 2 bad input (file, flags, plugins, a refused --resume), 3 `run` (or `sweep`) stopped by
// SIGINT/SIGTERM after writing a checkpoint; `sweep` exits 1 when any of its runs failed.
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "tools/pipeline/commands.h"
#include "tools/pipeline/options.h"

namespace {
const char* kUsage =
    "usage: pipeline <command> [options]\n"
    "\n"
    "commands:\n"
    "  run FILE.yaml [--set key.path=value]... [--device auto|cpu|cuda] [--out DIR] [--force] [--threads N] [--check-rollbacks]\n"
    "      [--resume [DIR|CHECKPOINT.h5] [--allow-changes]]   continue from the newest valid checkpoint\n"
    "      [--gpus N]   one run on GPUs 0..N-1 (NCCL; on the CPU N threads): stages that can split do, rank 0\n"
    "      writes the outputs (docs/multi-gpu.md)\n"
    "  validate FILE.yaml [--set ...]   check without running; print the resolved step graph\n"
    "  graph FILE.yaml [--set ...]      the step graph in Graphviz DOT\n"
    "  stages                           every stage the plugins on the search path offer\n"
    "  describe STAGE                   one stage: parameters, defaults, reads/writes, backends\n"
    "  bench FILE.yaml [--sizes N,N,...] [--steps S] [--warmup W] [--device ...] [--set ...] [--gpus N]\n"
    "      [--threads N] [--results DIR]   JSON lines to DIR/<file>-<backend>.jsonl (default bench/results)\n"
    "  sweep FILE.yaml --grid key=v1,v2,... [--grid ...] [--replicas R] [--concurrent K] [--out DIR] [--set ...]\n"
    "      [--device ...] [--threads N] [--mps auto|on|off] [--gpus 0,1,...] [--in-process] [--force]\n"
    "      one run per combination and seed, each in its own folder, with an index CSV; run it again to\n"
    "      continue an interrupted sweep. Runs are child processes (--in-process: threads of this process),\n"
    "      K at once on each GPU. With K > 1 processes on a GPU, --mps auto uses a running CUDA MPS daemon, else starts its own\n"
    "      (private pipe directory in /tmp) and stops it when the sweep ends; --mps off never, --mps on requires it\n"
    "\n"
    "Exit codes: 0 done, 1 the run failed, 2 bad input, 3 stopped by SIGINT/SIGTERM after writing a checkpoint,\n"
    "130 stopped at once by a second Ctrl-C (no checkpoint).\n"
    "`pipeline <command> --help` lists a command's options.\n"
    "\n"
    "Plugins are searched in $FLIPFLOW_PLUGIN_PATH, then in ../plugins and ../lib/flipflow/plugins next to\n"
    "this program (a build tree; an installed tree).\n";

const std::map<std::string, std::string> kCommandUsage = {
    {"run", "usage: pipeline run FILE.yaml [options]\n  runs the pipeline; outputs in --out (default runs/<file stem>)."
            "\n  Exit codes: 0 done, 1 the run failed, 2 bad input, 3 stopped by SIGINT/SIGTERM after a checkpoint"
            " (continue with --resume).\n"},
    {"validate", "usage: pipeline validate FILE.yaml [--set key.path=value]...\n  checks without running; prints the "
                 "resolved step graph.\n"},
    {"graph", "usage: pipeline graph FILE.yaml [--set key.path=value]...\n  the step graph in Graphviz DOT.\n"},
    {"bench", "usage: pipeline bench FILE.yaml [options]\n  times the pipeline's step, observers left out, at each --sizes N;"
              " JSON lines to --results.\n  After --warmup steps, three passes of --steps steps: steps/s come from "
              "pass 1 (back-to-back,\n  one wait at the end), the median ms and metrics per step from pass 2 (each "
              "step waited for),\n  ms per stage from pass 3 (profiled: each stage waited for).\n"},
    {"sweep", "usage: pipeline sweep FILE.yaml --grid key.path=v1,v2,... [--grid ...] [options]\n  one run per "
              "combination and seed, each in its own folder under --out, with index.csv (folder, parameters, status,"
              " steps/s).\n  Run the same command again to continue an interrupted sweep; add values to a --grid "
              "axis to extend it.\n  Exit codes: 0 every run done, 1 some run failed, 2 bad input, 3 interrupted.\n"},
};
}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h" || std::string(argv[1]) == "help") {
    std::cout << kUsage;
    return argc < 2 ? 2 : 0;
  }
  const std::string command = argv[1];
  std::vector<std::string> args(argv + 2, argv + argc);
  try {
    if ((command == "stages" || command == "describe") && !args.empty() && (args[0] == "--help" || args[0] == "-h")) {
      std::cout << (command == "stages" ? "usage: pipeline stages\n" : "usage: pipeline describe STAGE\n");
      return 0;
    }
    // A command's --help: its usage line here, its options from parse_options.
    for (auto& a : args)
      if (a == "--help" || a == "-h") {
        const auto line = kCommandUsage.find(command);
        if (line != kCommandUsage.end()) std::cout << line->second << "\n";
        break;
      }
    if (command == "run") return ff::cli::cmd_run(args);
    if (command == "validate") return ff::cli::cmd_validate(args);
    if (command == "graph") return ff::cli::cmd_graph(args);
    if (command == "stages") return ff::cli::cmd_stages(args);
    if (command == "describe") return ff::cli::cmd_describe(args);
    if (command == "bench") return ff::cli::cmd_bench(args);
    if (command == "sweep") return ff::cli::cmd_sweep(args);
    std::cerr << "pipeline: unknown command '" << command << "'\n\n" << kUsage;
    return 2;
  } catch (const ff::cli::HelpShown&) {
    return 0;
  } catch (const ff::InputError& e) {  // (several mistakes in one file: each on its own line)
    for (auto& m : ff::messages_of(e)) std::cerr << "error: " << m << "\n";
    return 2;
  } catch (const ff::RunError& e) {
    std::cerr << "run failed: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "run failed: " << e.what() << "\n";
    return 1;
  }
}
