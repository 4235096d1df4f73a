// `pipeline sweep`: its command line and plan (sweep_args.cpp: options, grid axes, every run
// resolved and dry-run), the combinations, folder names and index CSV (sweep_plan.cpp), the GPUs
// and CUDA MPS (sweep_gpus.cpp). The running of the plan is sweep_scheduler.h; cmd_sweep.cpp ties
// them together.
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace ff::cli::sweep {

// One --grid argument: a --set key and the values it takes.
struct Axis {
  std::string key;
  std::vector<std::string> values;
};

// "key=v1,v2,..." -> Axis. Commas inside [...], {...} or quotes do not split, so a value may
// be a YAML list or map (--grid 'system.box=[10,10],[20,20]'). InputError naming the argument.
Axis parse_grid(const std::string& arg);

// One run of the sweep: a combination of grid values and a replica.
struct Run {
  std::string folder;               // under the sweep's output folder
  std::vector<std::string> values;  // one per axis
  int replica = 0;
  std::uint64_t seed = 0;         // run.seed of this run (after --set, --grid and the replica)
  std::vector<std::string> sets;  // --set arguments of its `pipeline run`: the sweep's, the grid's, the seed
  std::uint64_t N = 0, steps = 0;
  // Outcome, as the index records it.
  std::string status = "pending";  // pending, running, done, failed, interrupted
  int exit_code = -1;              // -1: not finished (written empty)
  double steps_per_s = 0;          // the run's own rate (its "done:" line), 0 when unknown
  double wall_s = 0;               // wall time of its last launch, process start to exit
  std::string gpu;                 // CUDA_VISIBLE_DEVICES given to it (empty on the CPU)
  std::string message;             // why it failed, or how it was resumed
};

// Every combination of the axes (the first axis varying slowest), `replicas` runs each. Folder
// names are `label=value` per axis joined by '_' (label: the key's last component, the whole
// key where two axes share one), then `seed=S` when replicas > 1; characters outside
// [A-Za-z0-9._+=-] become '_'; names that still collide get '-h' and a hash of their values.
// Seeds and sets are filled in by the caller (they need the resolved pipeline).
std::vector<Run> combinations(const std::vector<Axis>& axes, int replicas);
void name_folders(const std::vector<Axis>& axes, std::vector<Run>& runs, bool with_seed);

// `pipeline sweep FILE --grid ...` as given (sweep_args.cpp). Flags as in main.cpp's usage.
struct SweepArgs {
  std::string file;                    // the pipeline
  std::vector<std::string> sets;       // --set, for every run
  std::string device = "auto";         // --device
  std::vector<std::string> grid_args;  // --grid, as written (for messages and sweep.txt)
  std::vector<Axis> axes;              // --grid, parsed; one per argument, keys distinct
  int replicas = 1;                    // --replicas: runs per combination
  int concurrent = 1;                  // --concurrent: runs at once per GPU (on the CPU: in all)
  int threads = 0;                     // --threads per run; 0: the cores shared out
  std::string out;                     // --out; empty: sweeps/<file stem>
  std::string mps_mode = "auto";       // --mps: auto, on, off
  std::string gpus;                    // --gpus; empty: every visible GPU
  bool force = false;                  // --force: every run again from the start
  bool in_process = false;             // --in-process: runs on threads, not child processes
};

// Parses and checks the flags and the --grid arguments. InputError (exit 2) on anything wrong.
SweepArgs parse_args(const std::vector<std::string>& args);

// Every run of the sweep (combinations, then folder names), each resolved through the loader
// with its --set arguments and dry-run on the CPU as `pipeline validate` does, which fills in
// its seed, sets, N and steps. Nothing is written. A bad key or value is an InputError naming
// the --grid argument (and value) it comes from.
std::vector<Run> plan(const SweepArgs& args);

// The index: one row per run, written to a temporary file and renamed (readers never see half
// a file). Columns: folder, one per axis (its key), one per key the sweep's --set arguments give
// every run (its value, the last where a key is given twice: an index read alone, or beside
// another sweep's, still says what its runs shared), replica, seed, status, exit_code,
// steps_per_s, particle_steps_per_s, wall_s, gpu, message.
void write_index(const std::string& path, const std::vector<Axis>& axes, const std::vector<std::string>& shared_sets,
                 const std::vector<Run>& runs);
// Rows of an existing index by folder (column name -> value); empty when there is none.
std::map<std::string, std::map<std::string, std::string>> read_index(const std::string& path);

// The GPUs to spread runs over: --gpus, else CUDA_VISIBLE_DEVICES, else every GPU the driver lists
// (/proc/driver/nvidia/gpus); at least one.
std::vector<std::string> visible_gpus(const std::string& gpus_arg);
// --in-process: the CUDA device ordinals of this process to use, from --gpus (0,1,...: each
// below the device count, or an InputError naming it) or every device it sees.
std::vector<std::string> process_gpus(const std::string& gpus_arg);

// An MPS control daemon for the runs sharing a GPU: one already running (the default pipe
// directory, or CUDA_MPS_PIPE_DIRECTORY), else one started with a private pipe directory in /tmp
// and stopped on destruction. mode: auto, on (InputError when MPS cannot be had), off.
// active() false: no MPS (`note` says why when it was wanted).
class Mps {
 public:
  Mps(const std::string& mode, bool wanted, std::string& note);
  ~Mps();
  Mps(const Mps&) = delete;
  Mps& operator=(const Mps&) = delete;
  bool active() const { return active_; }
  // What the runs' environment needs (CUDA_MPS_PIPE_DIRECTORY, ...) when the daemon is ours.
  const std::vector<std::string>& env() const { return env_; }

 private:
  bool active_ = false, owned_ = false;
  std::string control_;
  std::string dir_;
  std::vector<std::string> env_;
};

// CSV field quoting (RFC 4180) and a line's fields.
std::string csv_field(const std::string& s);
std::vector<std::string> csv_split(const std::string& line);

}  // namespace ff::cli::sweep
