// `pipeline run`: the main job, with checkpoints and --resume (core/run/checkpoint.h).
//
// Exit codes: 0 done, 1 the run failed, 2 bad input (including a refused --resume),
// 3 stopped by SIGINT or SIGTERM after finishing the step under way and writing a checkpoint
// (continue with `pipeline run FILE --resume`), 130 stopped at once by a second SIGINT.
#include <oneapi/tbb/global_control.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>
#include <streambuf>
#include <thread>

#include <unistd.h>

#include "core/backend/device.h"
#include "core/base/error.h"
#include "core/base/text.h"
#include "core/base/version.h"
#include "core/run/checkpoint.h"
#include "core/run/simulation.h"
#include "core/run/team.h"
#include "tools/pipeline/build_commit.h"
#include "tools/pipeline/commands.h"
#include "tools/pipeline/common.h"
#include "tools/pipeline/options.h"


namespace po = boost::program_options;
namespace fs = std::filesystem;

namespace ff::cli {

namespace {
std::atomic<int> g_signal{0};
// From this many particles a fresh run reports its set-up's start and duration.
constexpr std::uint64_t kLargeSetUp = 100000;
// Stepping this long without a run.checkpoint section earns one warning.
constexpr std::chrono::minutes kLongWithoutCheckpoints{10};
// Set until the run is set up (and cleared by before_steps): the first signal's message says when it stops.
std::atomic<bool> g_setting_up{true};
// The first SIGINT/SIGTERM stops the run at the next step's start, with a checkpoint: after the
// step under way, or at step 0 once set-up ends (which keeps a long set-up's work). A second
// SIGINT (Ctrl-C pressed again) stops at once, without one. A SIGTERM never does: one request
// to stop often reaches a run twice (a sweep forwards the terminal's Ctrl-C as SIGTERM to runs
// that got the SIGINT too; a batch system signals every process of the job), and a batch
// system's SIGKILL follows its grace period anyway. Only async-signal-safe calls here.
extern "C" void on_signal(int sig) {
  auto say = [](const char* text) {
    std::size_t n = 0;
    while (text[n]) ++n;
    [[maybe_unused]] const ssize_t w = ::write(2, text, n);
  };
  int none = 0;
  if (!g_signal.compare_exchange_strong(none, sig)) {  // (the first signal is the one the run reports)
    if (sig != SIGINT) return;
    say("\nflipflow: a second interrupt: stopped at once, without a checkpoint\n");
    std::_Exit(128 + sig);
  }
  say(g_setting_up.load() ? "\nflipflow: interrupted during set-up: stops once set-up ends, with a checkpoint of step 0 "
                            "(Ctrl-C again to stop at once, without one)\n"
                          : "\nflipflow: interrupted: stops after the step under way, with a checkpoint (Ctrl-C "
                            "again to stop at once, without one)\n");
}

// The CPU's model name (/proc/cpuinfo), for the record of what produced a run.
std::string cpu_description() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) return line.substr(line.find_first_not_of(' ', colon + 1));
    }
  return "unknown CPU";
}

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::tm utc{};
  gmtime_r(&t, &utc);  // (not std::gmtime: an in-process sweep's runs call this at once)
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return buf;
}

// `--resume` takes an optional value (a directory or a checkpoint file), which Boost's parser
// cannot tell from the positional FILE: take it out of the arguments first.
bool take_resume(std::vector<std::string>& args, std::string& where) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (args[i].rfind("--resume=", 0) == 0) {
      where = args[i].substr(9);
      args.erase(args.begin() + std::ptrdiff_t(i));
      return true;
    }
    if (args[i] == "--resume") {
      const bool has_value = i + 1 < args.size() && args[i + 1].rfind("-", 0) != 0 &&
                             fs::path(args[i + 1]).extension() != ".yaml" && fs::path(args[i + 1]).extension() != ".yml";
      if (has_value) where = args[i + 1];
      args.erase(args.begin() + std::ptrdiff_t(i), args.begin() + std::ptrdiff_t(i + (has_value ? 2 : 1)));
      return true;
    }
  }
  return false;
}

std::string lines(const std::vector<std::string>& v) {
  std::string out;
  for (auto& s : v) out += "\n  " + s;
  return out;
}
}  // namespace

namespace {
// "checkpoint-000000000300.h5 and 2 more": the first file's name and how many follow.
std::string first_and_more(const std::vector<std::string>& files) {
  return fs::path(files.front()).filename().string() +
         (files.size() > 1 ? " and " + std::to_string(files.size() - 1) + " more" : "");
}

// The command that continues this run: its file and --set arguments (a continuation must have
// the same structure and parameters), its device, --resume with its folder.
std::string resume_command(const RunRequest& req, const std::string& out) {
  std::string c = "pipeline run " + shell_word(req.file);
  for (auto& o : req.overrides) c += " --set " + shell_word(o);
  if (req.device != "auto") c += " --device " + shell_word(req.device);
  if (req.threads > 0) c += " --threads " + std::to_string(req.threads);
  if (req.gpus > 1) c += " --gpus " + std::to_string(req.gpus);
  return c + " --resume " + shell_word(out);
}

// `earlier` then `later`, a key set in both only where `later` sets it (the list a continuation
// applies and records: it does not grow with every continuation).
std::vector<std::string> earlier_then_later(const std::vector<std::string>& earlier,
                                            const std::vector<std::string>& later) {
  auto key = [](const std::string& set) { return trimmed(set.substr(0, set.find('='))); };
  std::vector<std::string> out;
  for (auto& e : earlier) {
    bool replaced = false;
    for (auto& l : later) replaced = replaced || key(l) == key(e);
    if (!replaced) out.push_back(e);
  }
  out.insert(out.end(), later.begin(), later.end());
  return out;
}

// A stream that writes nowhere: the messages of ranks other than 0.
struct NullBuffer : std::streambuf {
  int overflow(int c) override { return c; }
};

// The run of one rank (`team` null: alone). In a team every rank builds its Simulation from
// the same pipeline (`given`, or for a continuation the pipeline loaded again with the
// checkpoint's --set arguments, by each rank alike), one after another under `setup`, one lock
// for the process: the plugins' set-up is not meant for several threads at once. Rank 0 alone
// logs, writes checkpoints and outputs, and the ranks agree every step on whether to stop (a
// signal seen by any rank).
int run_rank(const RunRequest& req, const std::optional<Loaded>& given, const std::exception_ptr& given_error,
             Backend backend, std::ostream& log, const std::atomic<int>& stop,
             const std::function<void()>& before_steps, Communicator* team, std::mutex& setup) {
  const bool lead = !team || team->rank() == 0;
  std::string out = req.out;
  const std::string& resume_where = req.resume_where;
  if (out.empty()) {
    if (req.resuming && !resume_where.empty())
      out = fs::is_regular_file(resume_where) ? fs::path(resume_where).parent_path().string() : resume_where;
    else
      out = "runs/" + fs::path(req.file).stem().string();
  }
  // A continuation: its checkpoint, and the pipeline with the continued run's --set arguments
  // before this command's, so that a continuation gives only what it changes (before, a run made
  // with --set system.N=1024 could be continued only by repeating it, and was refused otherwise
  // as a different structure).
  std::optional<ResumePoint> resume_point;
  std::optional<Loaded> with_earlier_sets;
  if (req.resuming) {
    std::lock_guard<std::mutex> one_at_a_time(setup);
    resume_point = find_resume_point(resume_where.empty() ? out : resume_where);
    const std::vector<std::string> earlier_sets = checkpoint_overrides(resume_point->data);
    if (!earlier_sets.empty()) with_earlier_sets = load(req.file, earlier_then_later(earlier_sets, req.overrides));
  }
  if (!with_earlier_sets && !given) std::rethrow_exception(given_error);
  const Loaded& loaded = with_earlier_sets ? *with_earlier_sets : *given;
  const auto& spec = loaded.spec;

  // What produced this run, recorded in the H5MD file and in checkpoints.
  RunRecord record;
  record.pipeline_text = loaded.text;
  record.effective_pipeline = loaded.effective;
  record.overrides = loaded.overrides;
  for (auto& line : resolved_parameters(spec)) record.resolved += line + "\n";
  const std::string device = backend == Backend::cuda ? cuda_device_description() : cpu_description();
  record.attributes = {{"flipflow_version", FF_VERSION_STRING},
                       {"commit", flipflow_build_commit()},
                       {"device", device},
                       {"threads", std::to_string(req.threads > 0 ? req.threads : int(std::thread::hardware_concurrency()))},
                       {"started", utc_now()}};

  if (team) record.attributes.push_back({"ranks", std::to_string(team->size())});

  RunOptions options{backend, out, req.force, loaded.text};
  options.check_rollbacks = req.check_rollbacks;
  options.team = team;
  options.messages = req.messages;
  // A fresh run among an earlier run's checkpoints would mix the two: its own checkpoints would
  // be pruned by step against the older ones, and a later --resume would continue the newest,
  // the earlier run's. Refused, or with --force removed once the run is set up (below).
  // A continuation likewise refuses the checkpoints in its folder that are not its past (below),
  // without a --force (which a continuation does not take).
  std::vector<std::string> earlier;
  if (!req.resuming && lead)
    for (auto& [step, file] : checkpoint_files(out)) earlier.push_back(file);
  if (!earlier.empty() && !req.force)
    throw InputError("'" + out + "' holds checkpoints of an earlier run (" + first_and_more(earlier) +
                     "); use --resume to continue it, --force to start over (removes them), or --out to write elsewhere");
  std::unique_ptr<Simulation> sim;
  std::string history;
  std::unique_lock<std::mutex> setting_up(setup);
  if (req.resuming) {
    ResumePoint& rp = *resume_point;
    for (auto& s : rp.skipped) log << "flipflow: warning: skipped a checkpoint: " << s << "\n";
    const PipelineChanges changes = compare_with_checkpoint(rp.data, spec);
    if (!changes.structure.empty())
      throw InputError("cannot resume from '" + rp.path + "': the pipeline's structure differs from the run's:" +
                       lines(changes.structure) +
                       "\nA continuation must have the same N, dimensions, precision, species and stages (it takes "
                       "the run's own --set arguments from the checkpoint, where it recorded them, and this "
                       "command's after them): undo the change, or start a new run from a frame of this one "
                       "(system: {init: {from: FILE.h5, frame: -1}})");
    if (!changes.parameters.empty() && !req.allow_changes)
      throw InputError("cannot resume from '" + rp.path + "': parameters changed since the checkpoint:" +
                       lines(changes.parameters) +
                       "\nPass --allow-changes to continue with them (they are recorded in the H5MD file under "
                       "/parameters/history), or undo them");
    const std::uint64_t step = rp.data.u64("clock/step");
    // Checkpoints in the folder that are not this continuation's past: newer than the one it
    // continues (a later point, or another timeline), or any at all when it continues a file from
    // elsewhere. Pruned by step against its own, they would delete them.
    if (lead) {
      std::error_code ec;
      const bool here = fs::equivalent(fs::path(rp.path).parent_path(), out, ec);
      for (auto& [s, file] : checkpoint_files(out))
        if ((s > step || !here) && !fs::equivalent(file, rp.path, ec)) earlier.push_back(file);
      if (!earlier.empty())  // (--force does not go with --resume: it would overwrite the outputs continued)
        throw InputError("'" + out + "' holds checkpoints that are not the past of step " + std::to_string(step) + " of " +
                         rp.path + " (" + first_and_more(earlier) + "): continuing among them would mix two runs; move them out of the folder, or continue into "
                         "another --out");
    }
    record.resumed_from = rp.path;
    record.resume_step = step;
    for (auto& c : changes.parameters) record.changes += c + "\n";
    options.resume = true;
    options.record = record;
    sim = std::make_unique<Simulation>(spec, *loaded.registry, options, state_from_checkpoint(rp.data));
    restore_checkpoint(*sim, rp.data);
    history = checkpoint_history(rp.data) + "step " + std::to_string(step) + ": resumed from " + rp.path + " at " +
              utc_now() + (changes.parameters.empty() ? "" : "; changes:" + lines(changes.parameters)) + "\n";
    log << "flipflow: resuming " << req.file << " at step " << step << " from " << rp.path << "\n";
    if (step >= spec.run.steps)
      log << "flipflow: the checkpoint is at step " << step << " and run.steps is " << spec.run.steps
          << ": nothing to run (extend the run with --set run.steps=...)\n";
  } else {
    options.record = record;
    // A large system's set-up (random placement near its jamming fraction, the stages' own) can
    // take minutes on a CPU: say so, rather than be silent until the first step.
    const bool large = spec.system.N >= kLargeSetUp;
    if (large) log << "flipflow: setting up " << spec.system.N << " particles (initial state, stages) ...\n" << std::flush;
    const auto set_up = std::chrono::steady_clock::now();
    sim = std::make_unique<Simulation>(spec, *loaded.registry, options);
    if (large) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "flipflow: set up in %.1f s\n",
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - set_up).count());
      log << buf;
    }
  }
  setting_up.unlock();
  for (auto& f : earlier) {
    std::error_code ec;
    fs::remove(f, ec);
    if (ec) throw RunError("--force: cannot remove the earlier run's checkpoint '" + f + "': " + ec.message());
  }
  log << "flipflow: " << req.file << " — " << spec.system.dimensions << "D, N = " << spec.system.N << ", "
      << spec.run.steps << " steps of Δt = " << spec.run.dt << ", " << to_string(spec.run.precision) << " on "
      << to_string(backend) << (backend == Backend::cuda ? " (" + device + ")" : "") << ", output in " << out
      << "/\n";
  if (team)
    log << "flipflow: a team of " << team->size() << " ranks"
        << (backend == Backend::cuda ? " on GPUs 0-" + std::to_string(team->size() - 1) + ", " + nccl_description()
                                     : " (CPU threads)")
        << "; rank 0 writes the outputs\n";
  if (team && sim->domain() && sim->domain()->fills_gap())
    log << "flipflow: warning: a decomposed team of the Delaunay stages is correct but not yet faster than one "
           "rank: each step does host work (band measures, the correction's team loop, CGAL at every migration; "
           "docs/multi-gpu.md, \"What remains\"). Measured: 4.2 steps/s for bench-abp at N = 262 144 on two H200s, "
           "~3 400 on one\n";

  if (req.no_graph_capture) sim->scheduler().set_graph_capture(false);
  // Rank 0 alone writes checkpoints (every rank holds the same state); a decomposed team none
  // (each rank holds a part: Simulation refuses run.checkpoint there).
  std::optional<Checkpointer> checkpoints;
  if (lead && !sim->domain()) checkpoints.emplace(*sim, out, spec.run.checkpoint_every, spec.run.checkpoint_keep, record, history);
  if (before_steps && lead) before_steps();
  const std::uint64_t first = sim->state().step;
  const double first_time = sim->state().time;
  if (team) team->reset_communication_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  bool warned_no_checkpoints = false;
  try {
    while (sim->state().step < spec.run.steps) {
      std::int64_t sig = stop.load();
      if (team) team->all_reduce(&sig, 1, ReduceOp::max);  // every rank stops after the same step
      if (sig) {
        // The step under way was finished: keep it in a checkpoint and stop.
        const std::string path = checkpoints ? checkpoints->write() : std::string();
        sim->finish(false);
        log << "flipflow: stopped by " << (sig == SIGINT ? "SIGINT" : "SIGTERM") << " after step " << sim->state().step;
        if (path.empty())  // a decomposed team (each rank holds a part of the state)
          log << "; a decomposed team writes no checkpoints, so this run cannot be continued (run on one GPU, "
                 "or with --gpus 1, to make it resumable)\n";
        else
          log << "; checkpoint " << path << "; continue with: " << resume_command(req, out) << "\n";
        return kExitInterrupted;
      }
      sim->advance();
      if (checkpoints) checkpoints->after_step();
      // A long run without periodic checkpoints loses everything to a kill -9 or a lost node: say
      // so once, while there is time to stop it (SIGINT keeps it) and add them.
      if (!spec.run.checkpoint && !warned_no_checkpoints && checkpoints && sim->state().step % 256 == 0 &&
          std::chrono::steady_clock::now() - t0 > kLongWithoutCheckpoints) {
        warned_no_checkpoints = true;
        log << "flipflow: this run has stepped for 10 minutes without a run.checkpoint section: killed outright "
               "(kill -9, out of memory, a lost node) it could not be continued, and g(r) and cluster rows "
               "would be lost (docs/checkpoints.md). Ctrl-C stops it with a checkpoint, and "
            << resume_command(req, out) << " --set 'run.checkpoint={every: N}' continues it with them\n";
      }
    }
    sim->synchronize();
    if (spec.run.checkpoint && checkpoints) checkpoints->write();
  } catch (const RunError& e) {
    sim->finish(false);
    // The state at the failure may be what failed (non-finite, overlapping): no checkpoint of it,
    // but the newest one and the command that continues from it with the parameters changed.
    const std::string newest = checkpoints && checkpoints->written() ? checkpoints->newest() : record.resumed_from;
    if (newest.empty() || !lead) throw;
    const std::uint64_t at = checkpoints && checkpoints->written() ? checkpoints->newest_step() : record.resume_step;
    std::string command = resume_command(req, out);
    std::error_code ec;
    if (!fs::equivalent(fs::path(newest).parent_path(), out, ec))  // resumed from elsewhere: that file
      command.replace(command.rfind(" --resume "), std::string::npos,
                      " --resume " + shell_word(newest) + " --out " + shell_word(out));
    throw RunError(std::string(e.what()) + "\nflipflow: the newest checkpoint is " + newest + " (step " +
                   std::to_string(at) + "); to continue from it with what made the run fail changed: " + command +
                   " --allow-changes --set KEY=VALUE");
  } catch (...) {
    sim->finish(false);
    throw;
  }
  sim->finish(true);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double steps = double(sim->state().step - first);
  log << "done: " << steps << " steps in " << secs << " s (" << steps / secs
      << " steps/s), simulated time " << sim->state().time << ", rollbacks " << sim->stats().rollbacks;
  // Attempts run again at a smaller Δt because a stage limited it (Outcome::limit_dt).
  if (sim->stats().dt_limits) log << ", Δt limited " << sim->stats().dt_limits;
  if (const std::uint64_t n = checkpoints ? checkpoints->written() : 0) {
    // What checkpointing cost this run: mean write time (the device idle) and the file size.
    char buf[96];
    std::snprintf(buf, sizeof buf, ", checkpoints %llu (%.1f MB, %.1f ms each)", static_cast<unsigned long long>(n),
                  double(checkpoints->last_bytes()) / 1e6, 1e3 * checkpoints->write_seconds() / double(n));
    log << buf;
  }
  if (team) {
    // Rank 0's time in collectives (on CUDA device time, waiting for the slowest rank included).
    char buf[96];
    std::snprintf(buf, sizeof buf, ", communication %.3g s on rank 0 (%.1f %%)", team->communication_seconds(),
                  100 * team->communication_seconds() / secs);
    log << buf;
  }
  log << "\n";
  // A run whose rollbacks kept Δt below run.dt covered less time than its steps promise: for a
  // model whose Δt is part of it (boids' map step), a different run. Said with who asked.
  const double nominal = steps * spec.run.dt;
  if (sim->stats().rollbacks && lead) {
    for (auto& s : sim->rollback_sources()) log << "rollbacks: " << s << "\n";
    if (steps > 0 && sim->state().time - first_time < 0.9 * nominal) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "%.4g is %.0f %% of the %.4g that %.0f steps of run.dt = %g make", sim->state().time - first_time,
                    100 * (sim->state().time - first_time) / nominal, nominal, steps, spec.run.dt);
      log << "flipflow: warning: the simulated time " << buf
          << ": each rollback halved Δt, which doubles back only after run.dt_grow_after = " << spec.run.dt_grow_after
          << " good steps (the stages above asked for them)\n";
    }
  }
  return 0;
}
}  // namespace

int run_pipeline(const RunRequest& req, std::ostream& log, const std::atomic<int>& stop,
                 const std::function<void()>& before_steps) {
  if (req.resuming && req.force) throw InputError("--resume continues the outputs of a run; --force would overwrite them");
  const Backend backend = resolve_backend(req.device);
  if (req.gpus < 1) throw InputError("--gpus must be at least 1 (got " + std::to_string(req.gpus) + ")");
  // A continuation may be valid only with the --set arguments its checkpoint recorded (run_rank
  // loads it again with them): its own load's error waits until it is known there are none.
  std::optional<Loaded> loaded;
  std::exception_ptr load_error;
  try {
    loaded.emplace(load(req.file, req.overrides));
  } catch (const InputError&) {
    if (!req.resuming) throw;
    load_error = std::current_exception();
  }
  std::optional<tbb::global_control> limit;
  if (req.threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, std::size_t(req.threads));
  static std::mutex setup;  // one for the process: an in-process sweep runs several run_pipeline at once
  if (req.gpus == 1) return run_rank(req, loaded, load_error, backend, log, stop, before_steps, nullptr, setup);
  // A team: one thread per rank (on the CPU backend, threads sharing the cores; --gpus N there
  // tests the split, it does not add cores).
  Team team = make_team(backend, req.gpus);
  NullBuffer nowhere;
  std::ostream quiet(&nowhere);
  int rc = 0;
  run_team(team, [&](Communicator& comm) {
    const int r = run_rank(req, loaded, load_error, backend, comm.rank() == 0 ? log : quiet, stop, before_steps, &comm,
                           setup);
    if (comm.rank() == 0) rc = r;
  });
  return rc;
}

int cmd_run(const std::vector<std::string>& raw_args) {
  std::vector<std::string> args = raw_args;
  RunRequest req;
  req.resuming = take_resume(args, req.resume_where);
  CommonOptions common;
  po::options_description extra;
  extra.add_options()("out", po::value<std::string>(&req.out), "output directory (default runs/<file stem>)")(
      "force", po::bool_switch(&req.force), "overwrite existing outputs")(
      "threads", po::value<int>(&req.threads)->default_value(0), "CPU threads (0 = all cores)")(
      "gpus", po::value<int>(&req.gpus)->default_value(1),
      "ranks sharing the run: GPUs 0..N-1 through NCCL on CUDA, N threads on the CPU; every rank holds the state, "
      "stages that can split their work do (docs/multi-gpu.md)")(
      // (listed for --help only: take_resume takes --resume and its optional value out first)
      "resume", po::value<std::string>()->implicit_value(""),
      "[DIR|CHECKPOINT.h5]: continue from the newest valid checkpoint of DIR (default: the output "
      "directory), or from the given file")(
      "allow-changes", po::bool_switch(&req.allow_changes),
      "with --resume: continue with changed parameters (recorded in the H5MD file's /parameters/history)")(
      "check-rollbacks", po::bool_switch(&req.check_rollbacks),
      "after every rollback, check that the whole state was restored bit for bit (slow: copies the state every "
      "step; for stage authors)");
  parse_options(args, extra, common);
  if (req.threads < 0) throw InputError("--threads must be 0 (all cores) or more (got " + std::to_string(req.threads) + ")");
  if (req.allow_changes && !req.resuming)
    throw InputError("--allow-changes applies to a continuation: add --resume, or drop it for a fresh run");
  req.file = common.file;
  req.overrides = common.overrides;
  req.device = common.device;
  // SIGINT/SIGTERM from set-up on (on_signal).
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  return run_pipeline(req, std::cerr, g_signal, [] { g_setting_up.store(false); });
}

}  // namespace ff::cli
