// `pipeline sweep FILE.yaml --grid key=v1,v2,... [--grid ...] [--replicas R] [--concurrent K]`:
// every combination of the grid values (and R seeds each) as its own `pipeline run` in its own
// folder, with an index CSV of parameters -> outcome.
//
// This file ties the parts together: the command line and the plan (sweep_args.cpp), the
// sweep's folder, the resources the runs get, then the runs (sweep_scheduler.cpp, whose header
// says why they are child processes unless --in-process).
//
// Before anything is written, every combination goes through the loader and a dry run on the
// CPU (as `pipeline validate`): a bad key or value is an InputError naming the --grid argument
// (exit 2). The index (<out>/index.csv) is rewritten atomically when a run starts or ends. A run
// that fails does not stop the others; its row says why (the last error line of its run.log).
// Running the same command again skips the runs the index says are done, continues the others
// from their newest checkpoint (`pipeline run --resume`) when they have one and restarts them
// (--force) otherwise. <out>/sweep.txt records what the sweep is (file, --set, --grid,
// --replicas, the device); a different sweep in the same folder is refused unless --force, which
// also runs every run again from the start, except one whose grid axes gained values (the runs
// done are kept). A folder that is not a sweep's is refused unless --force, and a lock keeps a
// second sweep out of a folder while one runs there.
//
// Resources: when more than one run shares a GPU, the sweep uses CUDA MPS: a control daemon
// already running (the default pipe directory, or CUDA_MPS_PIPE_DIRECTORY), else one it starts
// itself with a private pipe directory and stops at the end (`--mps auto`, the default; `on`
// requires it, `off` never). Under MPS at most 48 clients share a device (Volta MPS's limit), so
// --concurrent is capped at 48 per GPU there. Several GPUs: the runs are spread over them
// (`--gpus` chooses them; default: CUDA_VISIBLE_DEVICES, else every GPU in
// /proc/driver/nvidia/gpus; with --in-process the process's device ordinals, every one it sees by
// default). On the CPU runs go one after another unless --concurrent says
// otherwise, each with its share of the cores (--threads). With more runs than cores waiting on
// the GPU in one process (--in-process), a waiting thread sleeps instead of spinning, and the
// process asks for 32 hardware work queues instead of 8 (CUDA_DEVICE_MAX_CONNECTIONS). Every run
// learns how many runs share its GPU (runs_sharing_gpu, core/backend/device.h), by which a stage
// may give its kernels fewer SMs (overlap_correct's team); the outputs do not depend on it.
//
// SIGINT/SIGTERM: the runs under way get SIGTERM (they finish their step, write a checkpoint and
// exit 3), the index says `interrupted`, and the sweep exits 3. If the sweep itself is killed,
// its runs get SIGTERM from the kernel (PR_SET_PDEATHSIG) and checkpoint the same way.
//
// Exit codes: 0 every run done, 1 some run failed, 2 bad input, 3 interrupted.
#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/info.h>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>

#include "core/backend/device.h"
#include "core/base/error.h"
#include "core/io/h5md_writer.h"
#include "tools/pipeline/commands.h"
#include "tools/pipeline/sweep.h"
#include "tools/pipeline/sweep_scheduler.h"

#ifdef FLIPFLOW_HAVE_CUDA
#include <cuda_runtime_api.h>
#endif

namespace fs = std::filesystem;

namespace ff::cli {

namespace {
using sweep::Mps;
using sweep::Run;
using sweep::SweepArgs;

constexpr int kMpsClientLimit = 48;

std::string file_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// What the sweep is: re-running it in the same folder must mean the same runs.
std::string definition(const SweepArgs& a, Backend backend) {
  std::ostringstream d;
  d << "pipeline: " << fs::absolute(a.file).lexically_normal().string() << "\n";
  d << "device: " << to_string(backend) << "\n";
  for (auto& s : a.sets) d << "set: " << s << "\n";
  for (auto& g : a.grid_args) d << "grid: " << g << "\n";
  d << "replicas: " << a.replicas << "\n";
  d << "--- pipeline file ---\n" << file_text(a.file);
  return d.str();
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> v;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) v.push_back(l);
  return v;
}

// Whether the sweep recorded as `before` is this one with values added to its grid axes or
// more replicas (the same file, device, --set and axes in the same order, each axis's old values
// among its new ones; replicas the same, or more where there were already several, whose folders
// are named by seed: with one replica the folders have no seed in their names, so a second
// replica is another sweep): then every run it made is a run of this one, in the same folder with
// the same parameters and seed, and the folder may be continued. `added` says what was added.
bool extends(const std::string& before, const std::string& now, std::string& added) {
  // A definition's --grid arguments, its replicas, and its other lines.
  struct Parts {
    std::vector<std::string> grid, rest;
    long replicas = 1;
  };
  auto parts = [](const std::string& text) {
    Parts p;
    for (auto& l : lines_of(text))
      if (l.rfind("grid: ", 0) == 0) p.grid.push_back(l.substr(6));
      else if (l.rfind("replicas: ", 0) == 0) p.replicas = std::strtol(l.c_str() + 10, nullptr, 10);
      else p.rest.push_back(l);
    return p;
  };
  const Parts b = parts(before), n = parts(now);
  const auto& b_grid = b.grid;
  const auto& n_grid = n.grid;
  if (b.rest != n.rest || b_grid.size() != n_grid.size()) return false;
  if (n.replicas != b.replicas && !(b.replicas > 1 && n.replicas > b.replicas)) return false;
  if (n.replicas > b.replicas)
    added = "replicas " + std::to_string(b.replicas) + " -> " + std::to_string(n.replicas) + " (seeds + " +
            std::to_string(b.replicas) + " .. " + std::to_string(n.replicas - 1) + ")";
  for (std::size_t k = 0; k < b_grid.size(); ++k) {
    sweep::Axis old_axis, new_axis;
    try {
      old_axis = sweep::parse_grid(b_grid[k]);
      new_axis = sweep::parse_grid(n_grid[k]);
    } catch (const InputError&) {
      return false;
    }
    if (old_axis.key != new_axis.key) return false;
    for (auto& v : old_axis.values)
      if (std::find(new_axis.values.begin(), new_axis.values.end(), v) == new_axis.values.end()) return false;
    for (auto& v : new_axis.values)
      if (std::find(old_axis.values.begin(), old_axis.values.end(), v) == old_axis.values.end())
        added += (added.empty() ? "" : ", ") + new_axis.key + "=" + v;
  }
  return true;
}

// The lines of `before` and `now` that differ, for the message that refuses another sweep:
// "was: ... / now: ..." (the pipeline file's text as "the pipeline file's line L").
std::string differences(const std::string& before, const std::string& now) {
  const auto b = lines_of(before), n = lines_of(now);
  const auto file_start = [](const std::vector<std::string>& v) {
    return std::size_t(std::find(v.begin(), v.end(), "--- pipeline file ---") - v.begin());
  };
  const std::size_t bf = file_start(b), nf = file_start(n);
  std::string out;
  int shown = 0;
  auto note = [&](const std::string& what) {
    if (shown++ < 4) out += "\n  " + what;
  };
  const std::vector<std::string> bh(b.begin(), b.begin() + bf), nh(n.begin(), n.begin() + nf);
  for (auto& l : bh)
    if (std::find(nh.begin(), nh.end(), l) == nh.end()) note("was:  " + l);
  for (auto& l : nh)
    if (std::find(bh.begin(), bh.end(), l) == bh.end()) note("now:  " + l);
  if (shown == 0 && bh != nh)  // the same lines in another order (two --grid arguments swapped)
    for (std::size_t k = 0; k < std::min(bh.size(), nh.size()); ++k)
      if (bh[k] != nh[k]) {
        note("was:  " + bh[k] + "  (in this order)");
        note("now:  " + nh[k]);
        break;
      }
  const std::size_t bl = b.size() - std::min(b.size(), bf + 1), nl = n.size() - std::min(n.size(), nf + 1);
  for (std::size_t k = 0; k < std::max(bl, nl); ++k) {
    const std::string x = k < bl ? b[bf + 1 + k] : "(no line)", y = k < nl ? n[nf + 1 + k] : "(no line)";
    if (x != y) {
      note("the pipeline file's line " + std::to_string(k + 1) + " was '" + x + "', now '" + y + "'");
      break;
    }
  }
  if (shown > 4) out += "\n  (and " + std::to_string(shown - 4) + " more)";
  return out;
}

// An exclusive lock on the sweep's folder for as long as the sweep runs: a second sweep
// started into it (the same command again while the first still runs under nohup or tmux)
// would run the same runs into the same folders.
class FolderLock {
 public:
  explicit FolderLock(const fs::path& root) {
    const fs::path file = root / ".sweep.lock";
    fd_ = ::open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) throw InputError("cannot open '" + file.string() + "': " + std::strerror(errno));
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      if (errno != EWOULDBLOCK) {
        // A file system without locks (Lustre mounted noflock, some NFS and FUSE mounts): go on
        // unguarded rather than never run there.
        std::cerr << "sweep: warning: cannot lock '" << file.string() << "' (" << std::strerror(errno)
                  << "): nothing keeps a second sweep out of this folder while this one runs\n";
        return;
      }
      char pid[32] = {};
      [[maybe_unused]] const ssize_t n = ::pread(fd_, pid, sizeof pid - 1, 0);
      ::close(fd_);
      const std::string who = std::string(pid).substr(0, std::string(pid).find('\n'));
      throw InputError("'" + root.string() + "' is in use by another pipeline sweep" +
                       (who.empty() ? std::string() : " (pid " + who + ")") +
                       ": wait for it to end (or stop it: it checkpoints its runs), then run this command again");
    }
    const std::string pid = std::to_string(::getpid()) + "\n";
    if (::ftruncate(fd_, 0) == 0) [[maybe_unused]] const ssize_t w = ::pwrite(fd_, pid.data(), pid.size(), 0);
  }
  ~FolderLock() { ::close(fd_); }  // (the lock goes with the descriptor)
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;

 private:
  int fd_ = -1;
};

// Makes `out` this sweep's folder, recording what the sweep is in its sweep.txt: the runs'
// folders there are overwritten or continued, so another sweep's, or a folder that is not a
// sweep's, are refused unless --force. A sweep whose grid gained values, or that has more
// replicas, continues its folder.
std::unique_ptr<FolderLock> claim_folder(const std::string& out, const SweepArgs& a, Backend backend) {
  const fs::path root(out);
  const std::string def = definition(a, backend);
  const fs::path def_file = root / "sweep.txt";
  std::error_code ec;
  if (!a.force && fs::is_directory(root) && !fs::exists(def_file)) {
    for (auto& e : fs::directory_iterator(root, ec))
      if (e.path().filename() != ".sweep.lock")
        throw InputError("'" + out + "' exists and is not a sweep's folder (it holds " + e.path().filename().string() +
                         ", and no sweep.txt): use another --out, or --force to write the sweep there (its runs' "
                         "folders and index.csv would be overwritten)");
  }
  fs::create_directories(root, ec);
  if (ec) throw InputError("--out: cannot create the sweep's folder '" + out + "': " + ec.message());
  auto lock = std::make_unique<FolderLock>(root);
  if (fs::exists(def_file) && !a.force) {
    std::string before = file_text(def_file);
    // (sweep.txt from before it recorded the device: the same sweep on the device it names now)
    if (before.find("\ndevice: ") == std::string::npos) {
      const std::size_t line_end = before.find('\n');
      if (line_end != std::string::npos) before.insert(line_end + 1, std::string("device: ") + to_string(backend) + "\n");
    }
    std::string added;
    if (before != def && !extends(before, def, added))
      throw InputError("'" + out + "' holds another sweep (" + def_file.string() + " records its file, device, --set, "
                       "--grid and --replicas):" + differences(before, def) +
                       (before.find("\nreplicas: 1\n") != std::string::npos && a.replicas > 1
                            ? "\nIts runs had one replica each, in folders named without a seed: more replicas "
                              "are another sweep (another --out), or give this one a run.seed axis"
                            : "") +
                       "\nUse another --out; --force to run this one there from the start; or give the same "
                       "arguments with values added to a --grid axis, or more --replicas where it had two or "
                       "more, to extend that sweep");
    if (!added.empty()) std::cerr << "sweep: extends the sweep in " << out << " with " << added << "\n";
  }
  std::ofstream d(def_file, std::ios::trunc);
  d << def;
  d.close();
  if (!d) {  // (a full disk: an empty sweep.txt would make the same command "another sweep" next time)
    fs::remove(def_file, ec);
    throw InputError("cannot write '" + def_file.string() + "'");
  }
  return lock;
}

// Marks the runs an earlier invocation finished (the index says done and the folder is there)
// as done, with the outcome the index recorded; they are not run again. Returns how many.
std::size_t keep_finished_runs(const fs::path& root, const fs::path& index_file, std::vector<Run>& runs) {
  std::size_t kept = 0;
  const auto previous = sweep::read_index(index_file.string());
  for (auto& r : runs) {
    auto it = previous.find(r.folder);
    if (it == previous.end() || !fs::is_directory(root / r.folder)) continue;
    auto row = it->second;
    if (row["status"] != "done") continue;
    r.status = "done";
    r.exit_code = 0;
    r.steps_per_s = std::atof(row["steps_per_s"].c_str());
    r.wall_s = std::atof(row["wall_s"].c_str());
    r.gpu = row["gpu"];
    r.message = row["message"];
    ++kept;
  }
  return kept;
}

}  // namespace

int cmd_sweep(const std::vector<std::string>& args) {
  const SweepArgs a = sweep::parse_args(args);
  // --in-process: every run's stream is one of the context's hardware work queues, 8 unless
  // CUDA_DEVICE_MAX_CONNECTIONS says otherwise, and streams sharing a queue run one after the
  // other (a run's kernel waits behind another run's in the same queue): with K runs at once at
  // most 8 kernels run side by side. 32 is the most the driver gives. Read when the CUDA context
  // is made, so set before the first CUDA call; a value in the environment is kept. (Child
  // processes keep the default: under MPS the clients share one pool of connections, and more
  // for each means fewer clients.)
  if (a.in_process) ::setenv("CUDA_DEVICE_MAX_CONNECTIONS", "32", 0);
  const Backend backend = resolve_backend(a.device);
  std::vector<Run> runs = sweep::plan(a);
  const bool cuda = backend == Backend::cuda;
  if (!cuda && !a.gpus.empty())
    throw InputError("--gpus " + a.gpus + ": the runs are on the CPU (--device " + a.device + "); --gpus is for CUDA");
  // Child processes get a GPU by CUDA_VISIBLE_DEVICES (its entries); threads of this process by
  // its device ordinals.
  std::vector<std::string> gpus = !cuda         ? std::vector<std::string>{""}
                                   : a.in_process ? sweep::process_gpus(a.gpus)
                                                  : sweep::visible_gpus(a.gpus);

  // Everything is valid: from here on the sweep writes.
  const std::string out = a.out.empty() ? "sweeps/" + fs::path(a.file).stem().string() : a.out;
  const fs::path root(out), index_file = root / "index.csv";
  const auto lock = claim_folder(out, a, backend);
  const std::size_t skipped = a.force ? 0 : keep_finished_runs(root, index_file, runs);

  // Where the runs go and how many at once.
  std::string mps_note;
  Mps mps(a.mps_mode, cuda && a.concurrent > 1 && !a.in_process, mps_note);
  int per_gpu = a.concurrent;
  if (mps.active() && per_gpu > kMpsClientLimit) {
    mps_note += "; --concurrent " + std::to_string(per_gpu) + " capped at " + std::to_string(kMpsClientLimit) +
                " runs per GPU (MPS's client limit)";
    per_gpu = kMpsClientLimit;
  }
  const int slots = per_gpu * int(gpus.size());
  if (a.in_process && slots > 1 && !hdf5_thread_safe())
    throw InputError("sweep --in-process runs " + std::to_string(slots) +
                     " runs at once in this process, and this HDF5 library is not built thread-safe: their files "
                     "would corrupt each other. Leave out --in-process (a process per run), or use --concurrent 1");
  const int cores = tbb::info::default_concurrency();
  const int run_threads = a.threads > 0 ? a.threads : std::max(1, cores / slots);
  std::optional<tbb::global_control> thread_limit;  // --in-process: one limit for all runs
  if (a.in_process && a.threads > 0)
    thread_limit.emplace(tbb::global_control::max_allowed_parallelism, std::size_t(a.threads));
#ifdef FLIPFLOW_HAVE_CUDA
  // More runs than cores waiting on the GPU in one process: a waiting thread sleeps instead of
  // spinning, or the spinning ones would keep those whose work is done from their cores.
  if (a.in_process && cuda && slots > cores) {
    for (const std::string& g : gpus) {  // (a flag of each device's context, set before it exists)
      use_cuda_device(std::stoi(g));
      const cudaError_t e = cudaSetDeviceFlags(cudaDeviceScheduleBlockingSync);
      if (e != cudaSuccess)
        std::cerr << "sweep: waiting threads will spin on GPU " << g << " (cudaSetDeviceFlags: " << cudaGetErrorString(e)
                  << ")\n";
    }
    use_cuda_device(std::stoi(gpus.front()));
  }
#endif

  const std::size_t todo = runs.size() - skipped;
  std::cerr << "sweep: " << runs.size() << " runs of " << a.file << " (" << a.axes.size() << " grid ax" << (a.axes.size() == 1 ? "is" : "es") << ", "
            << a.replicas << " replica" << (a.replicas > 1 ? "s" : "") << "), " << todo << " to run, " << skipped
            << " done before; up to " << per_gpu << " at once"
            << (cuda ? " per GPU on " + std::to_string(gpus.size()) + " GPU" + (gpus.size() > 1 ? "s" : "") : " on the CPU")
            << (a.in_process ? ", on threads of this process"
                             : ", " + std::to_string(run_threads) + " CPU thread" + (run_threads > 1 ? "s" : "") + " each")
            << "; index " << index_file.string()
            << "\n";
  if (!mps_note.empty()) std::cerr << "sweep: " << mps_note << "\n";
  sweep::write_index(index_file.string(), a.axes, a.sets, runs);

  sweep::LaunchSettings launch;
  launch.pipeline_file = a.file;
  launch.device = to_string(backend);
  launch.root = root;
  launch.index_file = index_file.string();
  launch.shared_sets = a.sets;
  if (cuda) launch.gpus = gpus;
  launch.runs_at_once = slots;
  launch.threads_per_run = run_threads;
  launch.in_process = a.in_process;
  launch.force = a.force;
  launch.extra_env = mps.env();
  // How many runs share each GPU (core/backend/device.h): stages size their device work by it.
  if (cuda) {
    const std::size_t runs_per_gpu = std::max<std::size_t>(1, (todo + gpus.size() - 1) / gpus.size());
    const int sharing = int(std::min(std::size_t(per_gpu), runs_per_gpu));
    if (a.in_process) set_runs_sharing_gpu(sharing);
    else launch.extra_env.push_back("FLIPFLOW_RUNS_SHARING_GPU=" + std::to_string(sharing));
  }
  const sweep::Outcome outcome = sweep::run_all(launch, a.axes, runs);
  if (outcome.stop_signal) return kExitInterrupted;
  return outcome.failed ? 1 : 0;
}

}  // namespace ff::cli
