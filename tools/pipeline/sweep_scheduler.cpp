// `pipeline sweep`: running the runs side by side (sweep_scheduler.h).
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
//    SIGINT/SIGTERM handlers that make it write a checkpoint; stages and plugins were never
//    required to be safe to create and run from several threads at once.
// A child process has none of these problems, has its own log file, and is what `pipeline run
// --resume` already continues. The price: without CUDA MPS, processes sharing a GPU time-slice
// it instead of running their kernels side by side (measured before this command: two
// 60k-particle runs at once on an H100 got 1 370 steps/s each against 7 170 alone, since each
// step waits on the host); under MPS they do not (measured at afdd1e8 on an H200, 60 000 LJ
// spheres of tran-homo-phi*.yaml: two runs at once 13 309 and 12 432 steps/s, one alone
// 13 152). So when more than one run shares a GPU, the sweep uses MPS (cmd_sweep.cpp decides,
// sweep_gpus.cpp starts the daemon). Several GPUs: each run gets CUDA_VISIBLE_DEVICES of the GPU
// with the fewest runs under way.
//
// `--in-process` runs them instead on threads of this process (run_pipeline, cmd_run.cpp): one
// CUDA context a GPU, each run on its own streams, so kernels of different runs overlap without
// MPS; on several GPUs each run's thread makes its GPU current before the run is made (the
// LaunchSettings::gpus are then the process's device ordinals), as a decomposed team's ranks do,
// and the run's scheduler keeps that device for its stages (Scheduler::run_node). There no run captures its step into a CUDA graph (the same bits,
// launched directly: the core's Scheduler::set_graph_capture), so another run's device-wide
// wait cannot break a capture; the outputs are those of `--concurrent 1` (tests/test_sweep.cpp, on the CPU).
// Each run's messages, its stages' included (RunInfo::messages: progress lines, warnings), go to
// its run.log as a child's would.
// One failing run's sticky CUDA error would still end the others. Which of the two fills an H100
// better is measured by bench/sweep_abp.sh.
//
// The loop polls (every 20 ms) rather than blocking in waitpid, because it also watches threads,
// the stop signal and the progress line's clock.
#include "tools/pipeline/sweep_scheduler.h"

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <boost/dll/runtime_symbol_info.hpp>
#include <chrono>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <streambuf>
#include <thread>

#include "core/backend/device.h"
#include "core/base/error.h"
#include "tools/pipeline/commands.h"
#include "tools/pipeline/common.h"

extern char** environ;

namespace fs = std::filesystem;

namespace ff::cli::sweep {

namespace {

using Clock = std::chrono::steady_clock;

// The signal that stops the sweep (0: none). Runs on threads watch it themselves, as
// run_pipeline's `stop`.
std::atomic<int> g_stop{0};
extern "C" void on_sweep_signal(int sig) { g_stop.store(sig); }

double seconds_between(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double>(to - from).count();
}

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
               line.find("stopped by") != std::string::npos || line.find("a second interrupt") != std::string::npos) {
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

// A run under way: a child process, or (--in-process) a thread of this one.
struct ActiveRun {
  pid_t pid = -1;
  std::shared_ptr<std::thread> thread;
  std::shared_ptr<std::atomic<int>> thread_exit;  // the thread's exit code; -1 while it runs
  std::size_t run = 0;                            // index into the runs
  int gpu = 0;                                    // index into LaunchSettings::gpus
  bool resuming = false;                          // launched with --resume
  Clock::time_point started;
};

// One invocation's runs: which are under way (and on which GPU), which is next, the tallies and
// the throughput window. run() is the loop; the rest are its steps.
class RunScheduler {
 public:
  RunScheduler(const LaunchSettings& settings, const std::vector<Axis>& axes, std::vector<Run>& runs);
  // Leaving on an exception (an index that cannot be written, say) with runs on threads: they
  // stop as on SIGTERM (a checkpoint) and are joined before their std::thread objects go.
  ~RunScheduler();
  RunScheduler(const RunScheduler&) = delete;
  RunScheduler& operator=(const RunScheduler&) = delete;

  Outcome run();

 private:
  bool start_pending();
  // `restart`: from the beginning even where a checkpoint is (after a refused --resume).
  void launch(std::size_t i, int gpu, bool restart);
  void start_thread(ActiveRun& active, const Run& r, int gpu, const fs::path& dir, const fs::path& log,
                    bool resume) const;
  pid_t start_process(const std::vector<std::string>& argv, int gpu, const fs::path& log) const;
  bool collect_finished();
  // `status`: from waitpid for a process; an exit code shifted into WEXITSTATUS for a thread.
  void finish(std::size_t active_index, int status);
  void report_finished(const Run& r, const std::string& verb) const;
  void draw_progress(bool final_line) const;
  int print_summary() const;
  void save_index() const { write_index(s_.index_file, axes_, s_.shared_sets, runs_); }

  const LaunchSettings& s_;
  const std::vector<Axis>& axes_;
  std::vector<Run>& runs_;
  const bool cuda_;
  const std::string exe_;                // this program: every child is its `run` command
  std::vector<std::string> child_env_;   // without CUDA_VISIBLE_DEVICES, which each child gets its own of
  const pid_t sweep_pid_;
  const bool tty_;
  std::vector<ActiveRun> active_;
  std::vector<int> runs_on_gpu_;
  std::size_t next_ = 0;                 // the first run not yet launched (or passed over as done)
  std::size_t done_before_ = 0;          // by an earlier invocation
  std::size_t to_run_ = 0;               // the others
  std::size_t done_ = 0, failed_ = 0, interrupted_ = 0;
  Clock::time_point t_start_;
  // The particle-steps the runs of this invocation made, and the span from the first step of any
  // of them to the last step of any (seconds since t_start_): the sweep's throughput with the
  // set-up before the first step and the clean-up after the last left out.
  double particle_steps_ = 0, first_step_ = 1e300, last_step_ = 0;
};

RunScheduler::RunScheduler(const LaunchSettings& settings, const std::vector<Axis>& axes, std::vector<Run>& runs)
    : s_(settings),
      axes_(axes),
      runs_(runs),
      cuda_(!settings.gpus.empty()),
      exe_(boost::dll::program_location().string()),
      sweep_pid_(::getpid()),
      tty_(::isatty(2)),
      runs_on_gpu_(settings.gpus.size(), 0) {
  for (char** e = environ; *e; ++e) {
    const std::string s = *e;
    if (cuda_ && s.rfind("CUDA_VISIBLE_DEVICES=", 0) == 0) continue;
    child_env_.push_back(s);
  }
  for (auto& e : s_.extra_env) child_env_.push_back(e);
  for (auto& r : runs_) done_before_ += r.status == "done";
  to_run_ = runs_.size() - done_before_;
}

RunScheduler::~RunScheduler() {
  for (auto& a : active_)
    if (a.thread && a.thread->joinable()) {
      g_stop.store(SIGTERM);
      a.thread->join();
    }
}

Outcome RunScheduler::run() {
  std::signal(SIGINT, on_sweep_signal);
  std::signal(SIGTERM, on_sweep_signal);
  t_start_ = Clock::now();
  bool stop_forwarded = false;
  auto last_draw = Clock::now() - std::chrono::seconds(1);
  while (true) {
    if (g_stop.load() && !stop_forwarded) {
      // Threads see g_stop themselves.
      for (auto& a : active_)
        if (a.pid > 0) ::kill(a.pid, SIGTERM);
      stop_forwarded = true;
    }
    if (start_pending()) save_index();
    if (active_.empty()) break;
    if (collect_finished()) {
      save_index();
      continue;
    }
    if (tty_ && Clock::now() - last_draw > std::chrono::milliseconds(500)) {
      draw_progress(false);
      last_draw = Clock::now();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  // Runs never started because of a signal stay pending; the next invocation starts them.
  save_index();
  const int stop_signal = print_summary();
  return Outcome{done_, failed_, interrupted_, stop_signal};
}

// Launches runs in order while there is room and no stop; true when any was launched.
bool RunScheduler::start_pending() {
  bool launched = false;
  while (!g_stop.load() && next_ < runs_.size() && int(active_.size()) < s_.runs_at_once) {
    if (runs_[next_].status == "done") {
      ++next_;
      continue;
    }
    // The GPU with the fewest runs under way (the first of those on a tie).
    const int gpu = cuda_ ? int(std::min_element(runs_on_gpu_.begin(), runs_on_gpu_.end()) - runs_on_gpu_.begin()) : 0;
    launch(next_, gpu, false);
    ++next_;
    launched = true;
  }
  return launched;
}

void RunScheduler::launch(std::size_t i, int gpu, bool restart) {
  Run& r = runs_[i];
  const fs::path dir = s_.root / r.folder;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) {  // (a file in its place, a full disk): this run fails, the others go on
    r.status = "failed";
    r.exit_code = 2;
    r.message = "cannot create its folder '" + dir.string() + "': " + ec.message();
    ++failed_;
    report_finished(r, "FAILED");
    return;
  }
  std::vector<std::string> argv = {exe_, "run", s_.pipeline_file, "--out", dir.string(), "--device", s_.device,
                                   "--threads", std::to_string(s_.threads_per_run)};
  for (auto& s : r.sets) {
    argv.push_back("--set");
    argv.push_back(s);
  }
  // The folder is the sweep's own (sweep.txt guards against another sweep's): a run that does
  // not continue from a checkpoint overwrites what an earlier, unfinished launch left there.
  const bool resume = !restart && !s_.force && has_checkpoint(dir);
  argv.push_back(resume ? "--resume" : "--force");
  // Each launch starts with this line in run.log: what was run (read_log reads the outcome of
  // the last launch only), and the equivalent command for running it by hand.
  const fs::path log = dir / "run.log";
  {
    std::ofstream l(log, std::ios::app);
    l << "== pipeline sweep" << (s_.in_process ? " (on a thread of the sweep's process)" : "") << ": ";
    if (cuda_ && !s_.in_process) l << "CUDA_VISIBLE_DEVICES=" << shell_word(s_.gpus[gpu]) << " ";
    for (std::size_t k = 0; k < argv.size(); ++k) l << (k ? " " : "") << shell_word(argv[k]);
    if (cuda_ && s_.in_process) l << "   (CUDA device " << s_.gpus[gpu] << ")";
    l << "\n";
  }
  ActiveRun active;
  if (s_.in_process) start_thread(active, r, gpu, dir, log, resume);
  else active.pid = start_process(argv, gpu, log);
  r.status = "running";
  r.exit_code = -1;
  r.gpu = cuda_ ? s_.gpus[gpu] : "";
  r.message = resume ? "resumed from a checkpoint" : "";
  active.run = i;
  active.gpu = gpu;
  active.resuming = resume;
  active.started = Clock::now();
  active_.push_back(active);
  if (cuda_) ++runs_on_gpu_[gpu];
}

// An ostream's buffer writing into a C stream: run_pipeline's log and the run's stages
// (RunInfo::messages) write into run.log through one FILE, so their lines keep their order.
class CFileBuf final : public std::streambuf {
 public:
  explicit CFileBuf(std::FILE* f) : f_(f) {}

 protected:
  int_type overflow(int_type c) override {
    if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
    return std::fputc(c, f_) == EOF ? traits_type::eof() : c;
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    return std::streamsize(std::fwrite(s, 1, std::size_t(n), f_));
  }
  int sync() override { return std::fflush(f_) == 0 ? 0 : -1; }

 private:
  std::FILE* f_;
};

// The run as run_pipeline on a thread, its messages and its stages' appended to its run.log; its
// exit code as `pipeline run`'s (main.cpp) lands in active.thread_exit.
void RunScheduler::start_thread(ActiveRun& active, const Run& r, int gpu, const fs::path& dir, const fs::path& log,
                             bool resume) const {
  RunRequest req;
  req.file = s_.pipeline_file;
  req.overrides = r.sets;
  req.device = s_.device;
  req.out = dir.string();
  req.force = !resume;
  req.resuming = resume;
  // One run's device-wide wait would break another's graph capture (this file's header).
  req.no_graph_capture = cuda_ && s_.runs_at_once > 1;
  active.thread_exit = std::make_shared<std::atomic<int>>(-1);
  const int device = cuda_ ? std::stoi(s_.gpus[gpu]) : -1;  // (in-process: ordinals, cmd_sweep.cpp)
  active.thread = std::make_shared<std::thread>([req, log, device, exit = active.thread_exit]() mutable {
    int rc = 1;
    std::FILE* file = std::fopen(log.c_str(), "a");
    if (!file) {  // (the sweep wrote its first line there just before: a full disk, a removed folder)
      std::fprintf(stderr, "flipflow: sweep: cannot open '%s': %s\n", log.c_str(), std::strerror(errno));
      exit->store(rc);
      return;
    }
    std::setvbuf(file, nullptr, _IOLBF, 1 << 14);  // a line at a time: `tail -f run.log` follows the run
    CFileBuf buf(file);
    std::ostream out(&buf);
    req.messages = file;
    try {
      if (device >= 0) use_cuda_device(device);  // everything the run makes lives on its GPU
      rc = run_pipeline(req, out, g_stop);
    } catch (const InputError& e) {
      for (auto& m : messages_of(e)) out << "error: " << m << "\n";
      rc = 2;
    } catch (const std::exception& e) {
      out << "run failed: " << e.what() << "\n";
    }
    out.flush();
    std::fclose(file);
    exit->store(rc);
  });
}

// `argv` as a child process on GPU `gpu`, its stdout and stderr appended to its run.log.
pid_t RunScheduler::start_process(const std::vector<std::string>& argv, int gpu, const fs::path& log) const {
  std::vector<std::string> env = child_env_;
  if (cuda_) env.push_back("CUDA_VISIBLE_DEVICES=" + s_.gpus[gpu]);
  // Built before fork: the child only calls async-signal-safe functions until execve.
  std::vector<char*> cargv, cenv;
  for (auto& a : argv) cargv.push_back(const_cast<char*>(a.c_str()));
  cargv.push_back(nullptr);
  for (auto& e : env) cenv.push_back(const_cast<char*>(e.c_str()));
  cenv.push_back(nullptr);
  const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd < 0) throw RunError("cannot open '" + log.string() + "': " + std::strerror(errno));
  const std::string cant_start = "error: cannot start " + exe_ + " (execve failed, errno ";
  const pid_t pid = ::fork();
  if (pid < 0) throw RunError(std::string("cannot start a run: fork: ") + std::strerror(errno));
  if (pid == 0) {
    // The run checkpoints and stops if the sweep dies; if the sweep died before the prctl took
    // effect, the child was already re-parented and stops at once (exit 3, as interrupted).
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != sweep_pid_) ::_exit(3);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    ::execve(exe_.c_str(), cargv.data(), cenv.data());
    // Say why in run.log (the index's message is its last error line): errno's number, since
    // only async-signal-safe calls are allowed here (write, not strerror).
    const int err = errno;
    char digits[12];
    int n = 0;
    for (int e = err; n == 0 || e > 0; e /= 10) digits[n++] = char('0' + e % 10);
    [[maybe_unused]] ssize_t w = ::write(2, cant_start.data(), cant_start.size());
    while (n > 0) w = ::write(2, &digits[--n], 1);
    w = ::write(2, ")\n", 2);
    ::_exit(127);
  }
  ::close(fd);
  return pid;
}

// Finishes one run that has ended, if any: a thread that has stored its exit code, else (child
// processes) whatever waitpid reports. True when something was collected.
bool RunScheduler::collect_finished() {
  bool collected = false;
  for (std::size_t c = 0; c < active_.size() && !collected; ++c)
    if (active_[c].thread && active_[c].thread_exit->load() >= 0) {
      finish(c, (active_[c].thread_exit->load() & 0xff) << 8);  // as waitpid reports an exit code
      collected = true;
    }
  if (!s_.in_process) {
    int status = 0;
    const pid_t pid = ::waitpid(-1, &status, WNOHANG);
    if (pid > 0) {
      for (std::size_t c = 0; c < active_.size(); ++c)
        if (active_[c].pid == pid) {
          finish(c, status);
          break;
        }
      collected = true;
    }
  }
  return collected;
}

void RunScheduler::finish(std::size_t active_index, int status) {
  const ActiveRun ended = active_[active_index];
  active_.erase(active_.begin() + std::ptrdiff_t(active_index));
  if (ended.thread) ended.thread->join();
  if (cuda_) --runs_on_gpu_[ended.gpu];
  Run& r = runs_[ended.run];
  r.wall_s = seconds_between(ended.started, Clock::now());
  const LogSummary summary = read_log(s_.root / r.folder / "run.log");
  std::string error = summary.error;
  // The child's execve error carries only errno's number (start_process): say it in words here.
  const std::size_t errno_at = error.find("(execve failed, errno ");
  if (errno_at != std::string::npos) {
    const int number = std::atoi(error.c_str() + errno_at + 22);
    error = error.substr(0, errno_at) + "(execve: " + std::strerror(number) + ")";
  }
  r.steps_per_s = summary.steps_per_s;
  if (WIFEXITED(status)) {
    r.exit_code = WEXITSTATUS(status);
  } else {
    r.exit_code = 128 + WTERMSIG(status);
    error = std::string("killed by signal ") + std::to_string(WTERMSIG(status)) + " (" + strsignal(WTERMSIG(status)) + ")";
  }
  // A refused resume (every checkpoint invalid, say): start again from the beginning, once.
  if (ended.resuming && r.exit_code == 2 && !g_stop.load()) {
    launch(ended.run, ended.gpu, true);
    r.message = "its checkpoints were refused (run.log); restarted";
    return;
  }
  std::string verb;
  if (r.exit_code == 0) {
    r.status = "done";
    r.message = ended.resuming ? "resumed from a checkpoint" : "";
    ++done_;
    particle_steps_ += double(r.N) * summary.steps;
    // The run's last step came shortly before it exited; its first, `seconds` before that.
    const double end = seconds_between(t_start_, Clock::now());
    first_step_ = std::min(first_step_, end - summary.seconds);
    last_step_ = std::max(last_step_, end);
    verb = "done";
  } else if (r.exit_code == 3 || g_stop.load()) {
    // Exit 3: the run stopped on SIGTERM after writing a checkpoint; ended any other way while
    // the sweep was stopping (killed, or stopped at once by a second Ctrl-C, exit 130):
    // interrupted too, not failed, so the next invocation continues it.
    // (not the run's own "continue with: pipeline run ... --resume", which would leave the index behind)
    r.status = "interrupted";
    r.message = r.exit_code == 3 ? "stopped with a checkpoint; run the sweep's command again to continue it"
                                 : error.empty() ? "exit " + std::to_string(r.exit_code) + " (see run.log)" : error;
    ++interrupted_;
    verb = "interrupted";
  } else {
    r.status = "failed";
    r.message = error.empty() ? "exit " + std::to_string(r.exit_code) + " (see run.log)" : error;
    ++failed_;
    verb = "FAILED";
  }
  report_finished(r, verb);
}

// A line per finished run; on a terminal only the ones that did not finish well, the progress
// line saying the rest.
void RunScheduler::report_finished(const Run& r, const std::string& verb) const {
  if (tty_ && verb == "done") return;
  if (tty_) std::cerr << "\r\033[K";
  std::cerr << "sweep: [" << done_ + failed_ + interrupted_ << "/" << to_run_ << "] " << verb << " " << r.folder;
  if (r.exit_code == 0 && r.steps_per_s > 0) std::cerr << " (" << std::setprecision(4) << r.steps_per_s << " steps/s)";
  if (r.exit_code != 0) std::cerr << ": " << r.message;
  std::cerr << "\n";
}

// The line a terminal shows while the sweep runs, redrawn in place.
void RunScheduler::draw_progress(bool final_line) const {
  const double elapsed = seconds_between(t_start_, Clock::now());
  std::ostringstream line;
  line << "sweep: " << done_ + done_before_ << "/" << runs_.size() << " done, " << active_.size() << " running, "
       << failed_ << " failed";
  if (interrupted_) line << ", " << interrupted_ << " interrupted";
  line << ", " << duration(elapsed);
  // From the runs done alone: a run that fails at once says nothing about how long the others take.
  const std::size_t left = to_run_ - done_ - failed_;
  if (!final_line && done_ > 0 && left > 0) line << ", ETA " << duration(elapsed / double(done_) * double(left));
  std::cerr << "\r\033[K" << line.str() << (final_line ? "\n" : "") << std::flush;
}

// The last lines: how many runs finished and the throughput; returns the stop signal, if any.
int RunScheduler::print_summary() const {
  const double elapsed = seconds_between(t_start_, Clock::now());
  if (to_run_ == 0) {
    std::cerr << "sweep: nothing to run: all " << runs_.size() << " runs were done before (" << s_.index_file << ")\n";
    return g_stop.load();
  }
  if (tty_) draw_progress(true);
  std::cerr << "sweep: " << done_ << " run" << (done_ == 1 ? "" : "s") << " done in " << duration(elapsed);
  if (particle_steps_ > 0 && elapsed > 0) {
    std::cerr << "; " << std::setprecision(4) << particle_steps_ / elapsed << " particle-steps/s over its wall time";
    if (last_step_ > first_step_)
      std::cerr << ", " << std::setprecision(4) << particle_steps_ / (last_step_ - first_step_)
                << " from the first step of any run to the last of any";
  }
  std::cerr << "\n";
  if (failed_)
    std::cerr << "sweep: " << failed_ << " run" << (failed_ == 1 ? "" : "s")
              << " failed: see the index's message column and each folder's run.log\n";
  const int stop_signal = g_stop.load();
  if (stop_signal)
    std::cerr << "sweep: stopped by " << (stop_signal == SIGINT ? "SIGINT" : "SIGTERM")
              << "; run the same command again to continue\n";
  return stop_signal;
}

}  // namespace

Outcome run_all(const LaunchSettings& settings, const std::vector<Axis>& axes, std::vector<Run>& runs) {
  RunScheduler scheduler(settings, axes, runs);
  return scheduler.run();
}

}  // namespace ff::cli::sweep
