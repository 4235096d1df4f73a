// `pipeline sweep FILE.yaml --grid key=v1,v2,... [--grid ...] [--replicas R] [--concurrent K]`:
// every combination of the grid values (and R seeds each) as its own `pipeline run` in its own
// folder, with an index CSV of parameters -> outcome.
//
// Two ways to run the runs side by side. By default every run is a child process (this
// program's `run` command), not a Simulation on a thread of this process, because in one process
// the runs are not independent:
//  - field copies from outside a step (set-up, observers' output) wait with
//    cudaDeviceSynchronize (core/backend/cuda/device_buffer.cpp, memory.cu), and cudaFree
//    synchronizes the device: one run's set-up or output waits for every other run's queued
//    work, and a device-wide wait is not allowed while another run captures its step into a
//    CUDA graph (core/run/cuda/graph.cpp; pipelines whose stages are all graph_capturable);
//  - a CUDA error such as an illegal address is sticky for the whole context: one bad run ends
//    all K;
//  - `pipeline run` sets process-wide state: the oneTBB thread limit (tbb::global_control), the
//    SIGINT/SIGTERM handlers that make it write a checkpoint; stages print to the process's
//    stderr (observe.progress); stages and plugins were never required to be safe to create and
//    run from several threads at once.
// A child process has none of these problems, has its own log file, and is what `pipeline run
// --resume` already continues. The price: without CUDA MPS, processes sharing a GPU time-slice
// it instead of running their kernels side by side (measured before this command: two
// 60k-particle runs at once on an H100 got 1 370 steps/s each against 7 170 alone, since each
// step waits on the host); under MPS they do not (measured at afdd1e8 on an H200, 60 000 LJ
// spheres of tran-homo-phi*.yaml: two runs at once 13 309 and 12 432 steps/s, one alone
// 13 152). So when more than one run shares a GPU, the sweep uses MPS: a control daemon
// already running (the default pipe directory, or CUDA_MPS_PIPE_DIRECTORY), else one it starts
// itself with a private pipe directory and stops at the end (`--mps auto`, the default; `on`
// requires it, `off` never). Under MPS at most 48 clients share a device (Volta MPS's limit), so
// --concurrent is capped at 48 per GPU there. Several GPUs: each run gets CUDA_VISIBLE_DEVICES of
// the GPU with the fewest runs under way (`--gpus` chooses them; default: CUDA_VISIBLE_DEVICES,
// else every GPU in /proc/driver/nvidia/gpus). On the CPU runs go one after another unless
// --concurrent says otherwise, each with its share of the cores (--threads).
//
// `--in-process` runs them instead on threads of this process (run_pipeline, cmd_run.cpp): one
// CUDA context, each run on its own streams, so kernels of different runs overlap without MPS,
// on the first GPU only. There no run captures its step into a CUDA graph (the same bits,
// launched directly: Scheduler::set_graph_capture), so another run's device-wide wait cannot
// break a capture; the outputs are those of `--concurrent 1` (tests/test_sweep.cpp, on the CPU).
// One failing run's sticky CUDA error would still end the others. With more runs than cores a
// waiting thread sleeps (cudaDeviceScheduleBlockingSync) instead of spinning.
// Which of the two fills an H100 better is measured by bench/sweep_abp.sh.
//
// Before anything is written, every combination goes through the loader and a dry run on the
// CPU (as `pipeline validate`): a bad key or value is an InputError naming the --grid argument
// (exit 2). The index (<out>/index.csv) is rewritten atomically when a run starts or ends. A run
// that fails does not stop the others; its row says why (the last error line of its run.log).
// Running the same command again skips the runs the index says are done, continues the others
// from their newest checkpoint (`pipeline run --resume`) when they have one and restarts them
// (--force) otherwise. <out>/sweep.txt records what the sweep is (file, --set, --grid,
// --replicas); a different sweep in the same folder is refused unless --force, which also runs
// every run again from the start.
//
// SIGINT/SIGTERM: the runs under way get SIGTERM (they finish their step, write a checkpoint and
// exit 3), the index says `interrupted`, and the sweep exits 3. If the sweep itself is killed,
// its runs get SIGTERM from the kernel (PR_SET_PDEATHSIG) and checkpoint the same way.
//
// Exit codes: 0 every run done, 1 some run failed, 2 bad input, 3 interrupted.
#include <fcntl.h>
#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/info.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <boost/dll/runtime_symbol_info.hpp>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <thread>

#include "core/backend/device.h"
#include "core/base/error.h"
#include "core/run/builtin_stages.h"
#include "core/run/plugin_loader.h"
#include "core/run/simulation.h"
#include "tools/pipeline/commands.h"
#include "tools/pipeline/common.h"
#include "tools/pipeline/options.h"
#include "tools/pipeline/sweep.h"

#ifdef FLIPFLOW_HAVE_CUDA
#include <cuda_runtime_api.h>
#endif

extern char** environ;

namespace po = boost::program_options;
namespace fs = std::filesystem;

namespace ff::cli {

namespace {
using sweep::Axis;
using sweep::Mps;
using sweep::Run;

constexpr int kMpsClientLimit = 48;

std::atomic<int> g_stop{0};
extern "C" void on_sweep_signal(int sig) { g_stop.store(sig); }

std::string file_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// What the sweep is: re-running it in the same folder must mean the same runs.
std::string definition(const std::string& file, const std::string& text, const std::vector<std::string>& sets,
                       const std::vector<std::string>& grids, int replicas) {
  std::ostringstream d;
  d << "pipeline: " << fs::absolute(file).lexically_normal().string() << "\n";
  for (auto& s : sets) d << "set: " << s << "\n";
  for (auto& g : grids) d << "grid: " << g << "\n";
  d << "replicas: " << replicas << "\n";
  d << "--- pipeline file ---\n" << text;
  return d.str();
}

// Checks every combination and fills in seeds, sets, N and steps. Nothing is written.
void plan_runs(const std::string& file, const std::vector<std::string>& user_sets, const std::vector<Axis>& axes,
               const std::vector<std::string>& grid_args, int replicas, std::vector<Run>& runs) {
  std::map<std::string, std::unique_ptr<Registry>> registries;  // by plugin list
  const Run* previous = nullptr;
  for (auto& run : runs) {
    std::vector<std::string> sets = user_sets;
    for (std::size_t k = 0; k < axes.size(); ++k) sets.push_back(axes[k].key + "=" + run.values[k]);
    const bool first_replica = run.replica == 0;
    if (!first_replica) {
      // Replicas differ only in run.seed: base seed + replica.
      run.seed = previous->seed - std::uint64_t(previous->replica) + std::uint64_t(run.replica);
      run.N = previous->N;
      run.steps = previous->steps;
      sets.push_back("run.seed=" + std::to_string(run.seed));
      run.sets = sets;
      previous = &run;
      continue;
    }
    // Which --grid argument a loader error comes from, when one does.
    auto blame = [&](const std::string& what) -> std::string {
      for (std::size_t k = 0; k < axes.size(); ++k)
        if (what.find("--set " + axes[k].key + "=") != std::string::npos)
          return "--grid " + grid_args[k] + " (value '" + run.values[k] + "'): " + what;
      std::string combo;
      for (std::size_t k = 0; k < axes.size(); ++k) combo += (k ? ", " : "") + axes[k].key + "=" + run.values[k];
      return combo.empty() ? what : "with " + combo + ": " + what;
    };
    try {
      auto doc = PipelineDocument::parse(file, sets);
      const auto plugins = doc.plugins();
      std::string plugin_key;
      for (auto& p : plugins) plugin_key += p + "\n";
      auto& registry = registries[plugin_key];
      if (!registry) registry = make_registry(plugins, [&doc](std::size_t i) { return doc.plugin_location(i); });
      const PipelineSpec spec = doc.resolve(*registry);
      run.seed = spec.run.seed;
      run.N = spec.system.N;
      run.steps = spec.run.steps;
      if (replicas > 1) sets.push_back("run.seed=" + std::to_string(run.seed));
      // As `pipeline validate`: every stage configured on the real initial state, no files.
      RunOptions o;
      o.dry_run = true;
      Simulation dry(spec, *registry, o);
    } catch (const InputError& e) {
      throw InputError(blame(e.what()));
    } catch (const std::exception& e) {
      throw InputError(blame(std::string("the dry run failed: ") + e.what()));
    }
    run.sets = sets;
    previous = &run;
  }
}

// ---- running ----

// A run under way: a child process, or (--in-process) a thread of this one.
struct Child {
  pid_t pid = -1;
  std::shared_ptr<std::thread> thread;
  std::shared_ptr<std::atomic<int>> thread_exit;  // -1 while the thread runs
  std::size_t run = 0;
  int gpu = -1;
  bool resuming = false;
  std::chrono::steady_clock::time_point t0;
};

bool has_checkpoint(const fs::path& dir) {
  std::error_code ec;
  for (auto& e : fs::directory_iterator(dir, ec)) {
    const std::string n = e.path().filename().string();
    if (n.rfind("checkpoint-", 0) == 0 && e.path().extension() == ".h5") return true;
  }
  return false;
}

// What a run's log says about its last launch: "done: S steps in T s (R steps/s)", and its
// last error line.
struct LogSummary {
  double steps = 0, seconds = 0, steps_per_s = 0;
  std::string error;
};

LogSummary read_log(const fs::path& log) {
  std::ifstream in(log);
  LogSummary sum;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("== pipeline sweep", 0) == 0) {
      sum = LogSummary{};  // a new launch
    } else if (line.rfind("done: ", 0) == 0) {
      std::istringstream words(line.substr(6));
      std::string steps_word, in_word;
      words >> sum.steps >> steps_word >> in_word >> sum.seconds;
      const auto open = line.find('(');
      if (open != std::string::npos) sum.steps_per_s = std::atof(line.c_str() + open + 1);
    } else if (line.rfind("error: ", 0) == 0 || line.rfind("run failed: ", 0) == 0 ||
               line.find("stopped by") != std::string::npos) {
      sum.error = line;
    }
  }
  return sum;
}

std::string duration(double s) {
  std::ostringstream o;
  if (s >= 3600) o << int(s / 3600) << "h" << std::setw(2) << std::setfill('0') << int(s / 60) % 60 << "m";
  else if (s >= 60) o << int(s / 60) << "m" << std::setw(2) << std::setfill('0') << int(s) % 60 << "s";
  else o << std::fixed << std::setprecision(s < 10 ? 1 : 0) << s << "s";
  return o.str();
}

}  // namespace

int cmd_sweep(const std::vector<std::string>& args) {
  CommonOptions common;
  std::vector<std::string> grid_args;
  std::string out, mps_mode, gpus_arg;
  int replicas = 1, concurrent = 1, threads = 0;
  bool force = false, in_process = false;
  po::options_description extra;
  extra.add_options()("grid", po::value<std::vector<std::string>>(&grid_args)->composing(),
                      "KEY=V1,V2,...: one axis of the grid (keys as for --set)")(
      "replicas", po::value<int>(&replicas)->default_value(1), "runs per combination, seeds run.seed + 0 .. R-1")(
      "concurrent", po::value<int>(&concurrent)->default_value(1), "runs at once per GPU (on the CPU: in all)")(
      "out", po::value<std::string>(&out), "the sweep's folder (default sweeps/<file stem>)")(
      "threads", po::value<int>(&threads)->default_value(0), "CPU threads per run (0 = the cores / runs at once)")(
      "mps", po::value<std::string>(&mps_mode)->default_value("auto"), "CUDA MPS when runs share a GPU: auto, on, off")(
      "gpus", po::value<std::string>(&gpus_arg), "GPUs to spread the runs over, e.g. 0,1 (default: every visible GPU)")(
      "force", po::bool_switch(&force), "run every run again from the start, whatever the folder holds")(
      "in-process", po::bool_switch(&in_process),
      "run the runs on threads of this process (one GPU, no MPS needed) instead of child processes");
  parse_options(args, extra, common);
  if (replicas < 1) throw InputError("--replicas must be at least 1");
  if (concurrent < 1) throw InputError("--concurrent must be at least 1");
  if (threads < 0) throw InputError("--threads must be 0 (automatic) or more");
  if (mps_mode != "auto" && mps_mode != "on" && mps_mode != "off")
    throw InputError("--mps: expected auto, on or off, got '" + mps_mode + "'");

  std::vector<Axis> axes;
  for (auto& g : grid_args) {
    axes.push_back(sweep::parse_grid(g));
    for (std::size_t k = 0; k + 1 < axes.size(); ++k)
      if (axes[k].key == axes.back().key) throw InputError("--grid " + g + ": the key '" + axes[k].key + "' has two --grid arguments");
    if (replicas > 1 && axes.back().key == "run.seed")
      throw InputError("--grid " + g + ": --replicas sets run.seed (the pipeline's seed + 0 .. R-1); grid over the seed or give --replicas, not both");
  }
  const Backend backend = resolve_backend(common.device);
  std::vector<Run> runs = sweep::combinations(axes, replicas);
  plan_runs(common.file, common.overrides, axes, grid_args, replicas, runs);
  sweep::name_folders(axes, runs, replicas > 1);

  // Everything is valid: from here on the sweep writes.
  if (out.empty()) out = "sweeps/" + fs::path(common.file).stem().string();
  const fs::path root(out);
  const std::string def = definition(common.file, file_text(common.file), common.overrides, grid_args, replicas);
  const fs::path def_file = root / "sweep.txt", index_file = root / "index.csv";
  if (fs::exists(def_file) && file_text(def_file) != def && !force)
    throw InputError("'" + out + "' holds another sweep (" + def_file.string() +
                     " records its file, --set, --grid and --replicas): use another --out, or --force to run this "
                     "one there from the start");
  fs::create_directories(root);
  {
    std::ofstream d(def_file, std::ios::trunc);
    d << def;
  }
  // Runs an earlier invocation finished are kept as they are.
  std::size_t skipped = 0;
  if (!force) {
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
      ++skipped;
    }
  }

  const bool cuda = backend == Backend::cuda;
  std::vector<std::string> gpus = cuda ? sweep::visible_gpus(gpus_arg) : std::vector<std::string>{""};
  std::string mps_note;
  if (in_process && gpus.size() > 1) {
    mps_note = "--in-process: every run on the first GPU this process sees (spreading over GPUs needs child processes)";
    gpus.resize(1);
  }
  Mps mps(mps_mode, cuda && concurrent > 1 && !in_process, mps_note);
  int per_gpu = concurrent;
  if (mps.active() && per_gpu > kMpsClientLimit) {
    mps_note += "; --concurrent " + std::to_string(per_gpu) + " capped at " + std::to_string(kMpsClientLimit) +
                " runs per GPU (MPS's client limit)";
    per_gpu = kMpsClientLimit;
  }
  const int slots = per_gpu * int(gpus.size());
  const int cores = tbb::info::default_concurrency();
  const int run_threads = threads > 0 ? threads : std::max(1, cores / slots);
  std::optional<tbb::global_control> thread_limit;  // --in-process: one limit for all runs
  if (in_process && threads > 0)
    thread_limit.emplace(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
#ifdef FLIPFLOW_HAVE_CUDA
  // More runs than cores waiting on the GPU in one process: a waiting thread sleeps instead of
  // spinning, or the spinning ones would keep those whose work is done from their cores.
  if (in_process && cuda && slots > cores) cudaSetDeviceFlags(cudaDeviceScheduleBlockingSync);
#endif
  const std::size_t todo = runs.size() - skipped;
  std::cerr << "sweep: " << runs.size() << " runs of " << common.file << " (" << axes.size() << " grid ax" << (axes.size() == 1 ? "is" : "es") << ", "
            << replicas << " replica" << (replicas > 1 ? "s" : "") << "), " << todo << " to run, " << skipped
            << " done before; up to " << per_gpu << " at once"
            << (cuda ? " per GPU on " + std::to_string(gpus.size()) + " GPU" + (gpus.size() > 1 ? "s" : "") : " on the CPU")
            << (in_process ? ", on threads of this process"
                           : ", " + std::to_string(run_threads) + " CPU thread" + (run_threads > 1 ? "s" : "") + " each")
            << "; index " << index_file.string()
            << "\n";
  if (!mps_note.empty()) std::cerr << "sweep: " << mps_note << "\n";
  sweep::write_index(index_file.string(), axes, runs);

  const std::string exe = boost::dll::program_location().string();
  std::vector<std::string> base_env;
  for (char** e = environ; *e; ++e) {
    const std::string s = *e;
    if (cuda && s.rfind("CUDA_VISIBLE_DEVICES=", 0) == 0) continue;
    base_env.push_back(s);
  }
  for (auto& e : mps.env()) base_env.push_back(e);

  std::signal(SIGINT, on_sweep_signal);
  std::signal(SIGTERM, on_sweep_signal);
  const pid_t me = ::getpid();
  std::vector<Child> children;
  // Leaving on an exception (an index that cannot be written, say) with runs on threads: they
  // stop as on SIGTERM (a checkpoint) and are joined before their std::thread objects go.
  struct JoinThreads {
    std::vector<Child>& children;
    ~JoinThreads() {
      for (auto& c : children)
        if (c.thread && c.thread->joinable()) {
          g_stop.store(SIGTERM);
          c.thread->join();
        }
    }
  } join_threads{children};
  std::vector<int> on_gpu(gpus.size(), 0);
  std::size_t next = 0, done = 0, failed = 0, interrupted = 0;
  const auto t_start = std::chrono::steady_clock::now();
  const bool tty = ::isatty(2);
  // The particle-steps the runs of this invocation made, and the span from the first step of any
  // of them to the last step of any (seconds since t_start): the sweep's throughput with the
  // set-up before the first step and the clean-up after the last left out.
  double particle_steps = 0, first_step = 1e300, last_step = 0;

  // `restart`: from the beginning even where a checkpoint is (after a refused --resume).
  auto launch = [&](std::size_t i, int gpu, bool restart) {
    Run& r = runs[i];
    const fs::path dir = root / r.folder;
    fs::create_directories(dir);
    std::vector<std::string> argv = {exe, "run", common.file, "--out", dir.string(), "--device", to_string(backend),
                                     "--threads", std::to_string(run_threads)};
    for (auto& s : r.sets) {
      argv.push_back("--set");
      argv.push_back(s);
    }
    // The folder is the sweep's own (sweep.txt guards against another sweep's): a run that does
    // not continue from a checkpoint overwrites what an earlier, unfinished launch left there.
    const bool resume = !restart && !force && has_checkpoint(dir);
    argv.push_back(resume ? "--resume" : "--force");
    const fs::path log = dir / "run.log";
    {
      std::ofstream l(log, std::ios::app);
      l << "== pipeline sweep" << (in_process ? " (on a thread of the sweep's process)" : "") << ": ";
      for (std::size_t k = 1; k < argv.size(); ++k) l << (k > 1 ? " " : "") << argv[k];
      l << (cuda && !in_process ? "   (CUDA_VISIBLE_DEVICES=" + gpus[gpu] + ")" : "") << "\n";
    }
    Child child;
    if (in_process) {
      RunRequest req;
      req.file = common.file;
      req.overrides = r.sets;
      req.device = to_string(backend);
      req.out = dir.string();
      req.force = !resume;
      req.resuming = resume;
      req.no_graph_capture = cuda && slots > 1;
      child.thread_exit = std::make_shared<std::atomic<int>>(-1);
      child.thread = std::make_shared<std::thread>([req, log, exit = child.thread_exit] {
        std::ofstream out(log, std::ios::app);
        int rc = 1;
        try {
          rc = run_pipeline(req, out, g_stop);
        } catch (const InputError& e) {
          out << "error: " << e.what() << "\n";
          rc = 2;
        } catch (const std::exception& e) {
          out << "run failed: " << e.what() << "\n";
        }
        out.flush();
        exit->store(rc);
      });
    } else {
      std::vector<std::string> env = base_env;
      if (cuda) env.push_back("CUDA_VISIBLE_DEVICES=" + gpus[gpu]);
      std::vector<char*> cargv, cenv;
      for (auto& a : argv) cargv.push_back(const_cast<char*>(a.c_str()));
      cargv.push_back(nullptr);
      for (auto& e : env) cenv.push_back(const_cast<char*>(e.c_str()));
      cenv.push_back(nullptr);
      const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
      if (fd < 0) throw RunError("cannot open '" + log.string() + "': " + std::strerror(errno));
      const pid_t pid = ::fork();
      if (pid < 0) throw RunError(std::string("cannot start a run: fork: ") + std::strerror(errno));
      if (pid == 0) {
        // The run checkpoints and stops if the sweep dies.
        ::prctl(PR_SET_PDEATHSIG, SIGTERM);
        if (::getppid() != me) ::_exit(3);
        ::dup2(fd, 1);
        ::dup2(fd, 2);
        ::execve(exe.c_str(), cargv.data(), cenv.data());
        ::_exit(127);
      }
      ::close(fd);
      child.pid = pid;
    }
    r.status = "running";
    r.exit_code = -1;
    r.gpu = cuda ? gpus[gpu] : "";
    r.message = resume ? "resumed from a checkpoint" : "";
    child.run = i;
    child.gpu = gpu;
    child.resuming = resume;
    child.t0 = std::chrono::steady_clock::now();
    children.push_back(child);
    if (cuda) ++on_gpu[gpu];
  };

  auto progress = [&](bool final_line) {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    std::ostringstream line;
    line << "sweep: " << done + skipped << "/" << runs.size() << " done, " << children.size() << " running, " << failed
         << " failed";
    if (interrupted) line << ", " << interrupted << " interrupted";
    line << ", " << duration(elapsed);
    const std::size_t finished_here = done + failed;
    if (!final_line && finished_here > 0 && finished_here < todo)
      line << ", ETA " << duration(elapsed / double(finished_here) * double(todo - finished_here));
    std::cerr << "\r\033[K" << line.str() << (final_line ? "\n" : "") << std::flush;
  };

  // `status`: from waitpid for a process; an exit code shifted into WEXITSTATUS for a thread.
  auto reap = [&](std::size_t c, int status) {
    Child ch = children[c];
    children.erase(children.begin() + std::ptrdiff_t(c));
    if (ch.thread) ch.thread->join();
    if (cuda) --on_gpu[ch.gpu];
    Run& r = runs[ch.run];
    r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - ch.t0).count();
    const LogSummary summary = read_log(root / r.folder / "run.log");
    std::string error = summary.error;
    r.steps_per_s = summary.steps_per_s;
    if (WIFEXITED(status)) {
      r.exit_code = WEXITSTATUS(status);
    } else {
      r.exit_code = 128 + WTERMSIG(status);
      error = std::string("killed by signal ") + std::to_string(WTERMSIG(status)) + " (" + strsignal(WTERMSIG(status)) + ")";
    }
    // A refused resume (every checkpoint invalid, say): start again from the beginning, once.
    if (ch.resuming && r.exit_code == 2 && !g_stop.load()) {
      launch(ch.run, ch.gpu, true);
      runs[ch.run].message = "its checkpoints were refused (run.log); restarted";
      return;
    }
    std::string verb;
    if (r.exit_code == 0) {
      r.status = "done";
      r.message = ch.resuming ? "resumed from a checkpoint" : "";
      ++done;
      particle_steps += double(r.N) * summary.steps;
      // The run's last step came shortly before it exited; its first, `seconds` before that.
      const double end = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
      first_step = std::min(first_step, end - summary.seconds);
      last_step = std::max(last_step, end);
      verb = "done";
    } else if (r.exit_code == 3 || (g_stop.load() && !WIFEXITED(status))) {
      r.status = "interrupted";
      r.message = error;
      ++interrupted;
      verb = "interrupted";
    } else {
      r.status = "failed";
      r.message = error.empty() ? "exit " + std::to_string(r.exit_code) + " (see run.log)" : error;
      ++failed;
      verb = "FAILED";
    }
    if (!tty || verb != "done") {
      if (tty) std::cerr << "\r\033[K";
      std::cerr << "sweep: [" << done + failed + interrupted << "/" << todo << "] " << verb << " " << r.folder;
      if (r.exit_code == 0 && r.steps_per_s > 0) std::cerr << " (" << std::setprecision(4) << r.steps_per_s << " steps/s)";
      if (r.exit_code != 0) std::cerr << ": " << r.message;
      std::cerr << "\n";
    }
  };

  bool forwarded = false;
  auto last_draw = std::chrono::steady_clock::now() - std::chrono::seconds(1);
  while (true) {
    if (g_stop.load() && !forwarded) {
      // Threads see g_stop themselves.
      for (auto& ch : children)
        if (ch.pid > 0) ::kill(ch.pid, SIGTERM);
      forwarded = true;
    }
    bool changed = false;
    while (!g_stop.load() && next < runs.size() && int(children.size()) < slots) {
      if (runs[next].status == "done") {
        ++next;
        continue;
      }
      const int gpu = cuda ? int(std::min_element(on_gpu.begin(), on_gpu.end()) - on_gpu.begin()) : 0;
      launch(next, gpu, false);
      ++next;
      changed = true;
    }
    if (changed) sweep::write_index(index_file.string(), axes, runs);
    if (children.empty()) break;
    bool reaped = false;
    for (std::size_t c = 0; c < children.size() && !reaped; ++c)
      if (children[c].thread && children[c].thread_exit->load() >= 0) {
        reap(c, (children[c].thread_exit->load() & 0xff) << 8);  // as waitpid reports an exit code
        reaped = true;
      }
    if (!in_process) {
      int status = 0;
      const pid_t pid = ::waitpid(-1, &status, WNOHANG);
      if (pid > 0) {
        for (std::size_t c = 0; c < children.size(); ++c)
          if (children[c].pid == pid) {
            reap(c, status);
            break;
          }
        reaped = true;
      }
    }
    if (reaped) {
      sweep::write_index(index_file.string(), axes, runs);
      continue;
    }
    if (tty && std::chrono::steady_clock::now() - last_draw > std::chrono::milliseconds(500)) {
      progress(false);
      last_draw = std::chrono::steady_clock::now();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  // Runs never started because of a signal stay pending; the next invocation starts them.
  sweep::write_index(index_file.string(), axes, runs);
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  if (tty) progress(true);
  std::cerr << "sweep: " << done << " run" << (done == 1 ? "" : "s") << " done in " << duration(elapsed);
  if (particle_steps > 0 && elapsed > 0) {
    std::cerr << "; " << std::setprecision(4) << particle_steps / elapsed << " particle-steps/s over its wall time";
    if (last_step > first_step)
      std::cerr << ", " << std::setprecision(4) << particle_steps / (last_step - first_step)
                << " from the first step of any run to the last of any";
  }
  std::cerr << "\n";
  if (failed) std::cerr << "sweep: " << failed << " run" << (failed == 1 ? "" : "s") << " failed: see the index's message column and each folder's run.log\n";
  if (g_stop.load()) {
    std::cerr << "sweep: stopped by " << (g_stop.load() == SIGINT ? "SIGINT" : "SIGTERM")
              << "; run the same command again to continue\n";
    return 3;
  }
  return failed ? 1 : 0;
}

}  // namespace ff::cli
