// `pipeline bench`: time per step (and per stage) over sizes N, as a table and as JSON lines
// appended to bench/results/<pipeline>-<backend>.jsonl. Observer stages are left out (and named
// on the terminal): this times the compute step. Three passes of `steps` steps each: throughput (steps in a row, one wait at the
// end: how a run behaves), latency (each step waited for; the median is reported), and
// per-stage times (each stage waited for, so device work is charged to the stage that did it).
// With --gpus N each size runs on a team of N ranks (core/run/team.h): the table shows rank 0's
// times (the ranks meet every step), then each rank's communication per step, its share of the
// step and its per-stage times.
#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/info.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>

#include "core/backend/device.h"
#include "core/backend/host_wait.h"
#include "core/base/error.h"
#include "core/backend/comm.h"
#include "core/run/domain.h"
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
std::vector<std::uint64_t> parse_sizes(const std::string& s) {
  std::vector<std::uint64_t> out;
  std::stringstream ss(s);
  std::string item;
  const auto refuse = [](const std::string& item) {
    return InputError("--sizes: '" + item + "' is not a size (whole numbers from 1 to 2^31 - 1, e.g. 1024,2^16)");
  };
  while (std::getline(ss, item, ',')) {
    // Accept 2^18 as well as 262144; digits only (stoull would take "-64" and "64abc").
    const bool power = item.rfind("2^", 0) == 0;
    const std::string digits = power ? item.substr(2) : item;
    if (digits.empty() || digits.size() > 10 || digits.find_first_not_of("0123456789") != std::string::npos)
      throw refuse(item);
    const std::uint64_t v = std::stoull(digits);
    if (power ? v > 30 : v < 1 || v > 2147483647u) throw refuse(item);
    out.push_back(power ? std::uint64_t(1) << v : v);
  }
  return out;
}

bool is_observer(const Loaded& loaded, const StepEntry& e) { return loaded.registry->get(e.stage).decl.observer; }

// The passes' names, in the order they run; the terminal's legend and the JSON lines' "passes"
// use them, so a number's pass can be looked up from either.
const char* const kPassNames[] = {"back-to-back", "each step waited for", "profiled"};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

struct Result {
  std::uint64_t n = 0;
  double median_ms = 0, mean_ms = 0;  // each step timed alone (waits for the device)
  double throughput = 0;              // steps/s over `steps` steps in a row (no wait between)
  // The host's own time a step over those steps: the pass's wall time less the time this thread
  // spent blocked on the device (core/backend/host_wait.h), so its stages' host code, launches and
  // records. On CUDA a size whose host_own_ms is near 1000 / throughput is bound by the host; on
  // the CPU it is the step itself.
  double host_own_ms = 0;
  std::map<std::string, double> stage_host_ms;  // per stage, the same pass (StageSlot::host_seconds)
  std::map<std::string, double> stage_ms;       // per stage, profiled pass
  std::map<std::string, double> metrics_mean;   // per step
  double rollbacks_per_step = 0;
  double dt_limits_per_step = 0;  // steps run again at a Δt a stage limited (Outcome::limit_dt)
  // In a team (--gpus N): this rank's time in communication per step over the throughput pass
  // (Communicator::communication_seconds: on CUDA device time of the collectives, waiting for
  // the slowest rank included, plus the host wait of the per-step agreement).
  double comm_ms = 0;
  // In a decomposed team, over the throughput pass (core/run/domain.h): the migrations, the host
  // time of each, and the host time of the other steps' start (migration test, ghost refresh).
  std::uint64_t migrations = 0;
  double migration_ms = 0, step_start_ms = 0;
  std::map<std::string, double> migration_phase_ms;  // per migration, over the whole run
};

// One rank's passes (team null: alone). Ranks meet at a barrier before each timed pass.
Result bench_rank(const Loaded& loaded, std::uint64_t n, Backend backend, std::uint64_t steps, std::uint64_t warmup,
                  Communicator* team, std::mutex* setup) {
  PipelineSpec spec = loaded.spec;
  spec.system.N = n;
  spec.run.steps = warmup + 3 * steps;
  // Drop observers: this measures the compute step.
  std::vector<StepEntry> compute;
  for (auto& e : spec.step)
    if (!is_observer(loaded, e)) compute.push_back(e);
  spec.step = compute;
  RunOptions o;
  o.backend = backend;
  o.dry_run = true;
  o.team = team;
  auto meet = [&] {
    if (team) team->barrier();
  };
  std::unique_lock<std::mutex> setting_up;
  if (setup) setting_up = std::unique_lock<std::mutex>(*setup);
  auto owned = std::make_unique<Simulation>(spec, *loaded.registry, o);
  if (setup) setting_up.unlock();
  Simulation& sim = *owned;
  for (std::uint64_t i = 0; i < warmup; ++i) sim.advance();
  sim.synchronize();

  Result r;
  r.n = n;
  {
    meet();
    if (team) team->reset_communication_seconds();
    const Domain* d = sim.domain();
    const std::uint64_t m0 = d ? d->migrations() : 0;
    const double mig0 = d ? d->migration_seconds() : 0, start0 = d ? d->step_start_seconds() : 0;
    const double waited0 = host_wait_seconds();
    std::vector<double> host0;
    for (auto& slot : sim.slots()) host0.push_back(slot.host_seconds);
    const auto t0 = std::chrono::steady_clock::now();
    for (std::uint64_t i = 0; i < steps; ++i) sim.advance();
    sim.synchronize();
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    r.throughput = double(steps) / wall;
    r.host_own_ms = 1e3 * (wall - (host_wait_seconds() - waited0)) / double(steps);
    for (std::size_t k = 0; k < sim.slots().size(); ++k) {
      const StageSlot& slot = sim.slots()[k];
      if (slot.host_seconds > host0[k])
        r.stage_host_ms[slot.info.stage_id] = 1e3 * (slot.host_seconds - host0[k]) / double(steps);
    }
    if (team) r.comm_ms = 1e3 * team->communication_seconds() / double(steps);
    if (d) {
      r.migrations = d->migrations() - m0;
      if (r.migrations) r.migration_ms = 1e3 * (d->migration_seconds() - mig0) / double(r.migrations);
      if (steps > r.migrations) r.step_start_ms = 1e3 * (d->step_start_seconds() - start0) / double(steps - r.migrations);
    }
  }
  meet();
  std::vector<double> ms;
  const auto rollbacks0 = sim.stats().rollbacks;
  const auto dt_limits0 = sim.stats().dt_limits;
  std::map<std::string, double> metric_sum;
  for (std::uint64_t i = 0; i < steps; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    sim.advance();
    sim.synchronize();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    for (auto& kv : sim.stats().metrics) metric_sum[kv.first] += kv.second;
  }
  r.median_ms = median(ms);
  double total = 0;
  for (double x : ms) total += x;
  r.mean_ms = total / double(ms.size());
  r.rollbacks_per_step = double(sim.stats().rollbacks - rollbacks0) / double(steps);
  r.dt_limits_per_step = double(sim.stats().dt_limits - dt_limits0) / double(steps);
  for (auto& kv : metric_sum) r.metrics_mean[kv.first] = kv.second / double(steps);

  meet();
  sim.scheduler().set_profiling(true);
  sim.scheduler().reset_timers();
  for (std::uint64_t i = 0; i < steps; ++i) sim.advance();
  sim.synchronize();
  for (auto& slot : sim.slots())
    if (slot.calls) r.stage_ms[slot.info.stage_id] = 1e3 * slot.seconds / double(steps);
  if (const Domain* d = sim.domain(); d && d->migrations())
    for (auto& [phase, seconds] : d->migration_phase_seconds())
      r.migration_phase_ms[phase] = 1e3 * seconds / double(d->migrations());
  sim.finish(true);
  return r;
}

// Every rank's result (one when gpus == 1). A team is made per size: NCCL communicators are
// cheap next to a size's passes, and a failed size leaves nothing behind.
std::vector<Result> bench_one(const Loaded& loaded, std::uint64_t n, Backend backend, std::uint64_t steps,
                              std::uint64_t warmup, int gpus) {
  if (gpus == 1) return {bench_rank(loaded, n, backend, steps, warmup, nullptr, nullptr)};
  Team team = make_team(backend, gpus);
  std::vector<Result> results = std::vector<Result>(std::size_t(gpus));
  std::mutex setup;  // Simulation set-up one rank at a time (as in `pipeline run`)
  run_team(team, [&](Communicator& comm) {
    results[std::size_t(comm.rank())] = bench_rank(loaded, n, backend, steps, warmup, &comm, &setup);
  });
  return results;
}

// --set values are the user's text: control characters would break the line's JSON.
std::string json_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '"' || c == '\\') {
      o += '\\';
      o += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char u[8];
      std::snprintf(u, sizeof u, "\\u%04x", unsigned(static_cast<unsigned char>(c)));
      o += u;
    } else {
      o += c;
    }
  }
  return o;
}

// A map of names to numbers as a JSON object, in the map's order.
std::string json_object(const std::map<std::string, double>& m) {
  std::ostringstream o;
  o << "{";
  for (auto it = m.begin(); it != m.end(); ++it)
    o << (it == m.begin() ? "" : ",") << "\"" << json_escape(it->first) << "\":" << it->second;
  o << "}";
  return o.str();
}
}  // namespace

int cmd_bench(const std::vector<std::string>& args) {
  CommonOptions common;
  std::string sizes_arg, results_dir;
  std::int64_t steps_arg = 200, warmup_arg = 20;  // (signed: boost reads "-1" into an unsigned as 2^64 - 1)
  int threads = 0, gpus = 1;
  po::options_description extra;
  extra.add_options()("sizes", po::value<std::string>(&sizes_arg), "comma-separated N (default: the file's N)")(
      "steps", po::value<std::int64_t>(&steps_arg)->default_value(200), "steps in each of the three timed passes, per size")(
      "warmup", po::value<std::int64_t>(&warmup_arg)->default_value(20), "untimed steps first")(
      "threads", po::value<int>(&threads)->default_value(0), "CPU threads (0 = all cores)")(
      "gpus", po::value<int>(&gpus)->default_value(1),
      "ranks sharing each run (GPUs 0..N-1 through NCCL; N threads on the CPU): per-rank times and the "
      "communication share are reported")(
      "results", po::value<std::string>(&results_dir)->default_value("bench/results"),
      "folder the JSON lines are appended to, as DIR/<file>-<backend>.jsonl (the default, relative to the "
      "working directory, is where the repository keeps recorded results)");
  parse_options(args, extra, common);
  if (steps_arg < 1) throw InputError("--steps must be at least 1 (got " + std::to_string(steps_arg) + ")");
  if (warmup_arg < 0) throw InputError("--warmup must be 0 or more (got " + std::to_string(warmup_arg) + ")");
  if (threads < 0) throw InputError("--threads must be 0 (all cores) or more (got " + std::to_string(threads) + ")");
  const std::uint64_t steps = std::uint64_t(steps_arg), warmup = std::uint64_t(warmup_arg);
  if (gpus < 1) throw InputError("--gpus must be at least 1 (got " + std::to_string(gpus) + ")");
  const Backend backend = resolve_backend(common.device);
  Loaded loaded = load(common.file, common.overrides);
  std::optional<tbb::global_control> limit;
  if (threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
  const int cores = threads > 0 ? threads : tbb::info::default_concurrency();
  auto sizes = sizes_arg.empty() ? std::vector<std::uint64_t>{loaded.spec.system.N} : parse_sizes(sizes_arg);

  std::error_code ec;
  fs::create_directories(results_dir, ec);
  if (ec) throw InputError("--results: cannot create '" + results_dir + "': " + ec.message());
  const std::string stem = fs::path(common.file).stem().string();
  // One file per pipeline and backend, so CPU and GPU results never mix.
  const fs::path jsonl_path = fs::path(results_dir) / (stem + "-" + to_string(backend) + ".jsonl");
  std::ofstream jsonl(jsonl_path, std::ios::app);
  if (!jsonl) throw InputError("--results: cannot open '" + jsonl_path.string() + "' for appending: " + std::strerror(errno));
  std::string device = backend == Backend::cuda ? cuda_device_description() : std::to_string(cores) + " CPU threads";
  if (gpus > 1)
    device = std::to_string(gpus) + " ranks: " +
             (backend == Backend::cuda ? std::to_string(gpus) + " x " + device + ", " + nccl_description()
                                       : "threads sharing " + device);
  const std::time_t now = std::time(nullptr);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));

  const RunSpec& run = loaded.spec.run;
  std::cout << "pipeline " << common.file << " on " << to_string(backend) << " (" << device << "), "
            << to_string(run.precision) << " precision: " << warmup << " warm-up steps, then three passes of " << steps
            << " steps per size\n";
  // Each column comes from its own pass: steps/s and the median can disagree by more than noise.
  std::cout << "steps/s: pass 1 (" << kPassNames[0] << "); median ms, metrics: pass 2 (" << kPassNames[1]
            << "); per stage: pass 3 (" << kPassNames[2] << ")"
            << (gpus > 1 ? "; per rank, communication and migrations: pass 1" : "") << "\n";
  std::string left_out;
  for (auto& e : loaded.spec.step)
    if (is_observer(loaded, e)) left_out += (left_out.empty() ? "" : ", ") + e.id;
  if (!left_out.empty()) std::cout << "observers left out (the compute step is timed): " << left_out << "\n";
  std::cout << "JSON lines appended to " << jsonl_path.string() << "\n";
  // What tells one bench's lines from another's, and which pass (1-based, into "passes") each
  // number comes from.
  std::string overrides_json = "[";
  for (std::size_t i = 0; i < loaded.overrides.size(); ++i)
    overrides_json += (i ? ",\"" : "\"") + json_escape(loaded.overrides[i]) + "\"";
  overrides_json += "]";
  std::string passes_json = "[";
  for (std::size_t i = 0; i < std::size(kPassNames); ++i) passes_json += (i ? ",\"" : "\"") + std::string(kPassNames[i]) + "\"";
  passes_json += "]";
  std::string pass_json =
      "{\"steps_per_s\":1,\"particle_steps_per_s\":1,\"host_own_ms\":1,\"median_ms\":2,\"mean_ms\":2,"
      "\"rollbacks_per_step\":2,\"dt_limits_per_step\":2,\"metrics_per_step\":2,\"stage_ms\":3,\"stage_host_ms\":1";
  if (gpus > 1)
    pass_json += ",\"per_rank.comm_ms\":1,\"per_rank.comm_share\":1,\"per_rank.migrations\":1,"
                 "\"per_rank.migration_ms\":1,\"per_rank.step_start_ms\":1,\"per_rank.stage_ms\":3";
  pass_json += "}";
  std::cout << std::left << std::setw(10) << "N" << std::setw(14) << "median ms" << std::setw(14) << "steps/s"
            << std::setw(18) << "particle-steps/s" << "  per stage (ms)\n";
  for (auto n : sizes) {
    const std::vector<Result> all = bench_one(loaded, n, backend, steps, warmup, gpus);
    const Result& r = all.front();  // rank 0: the step as the run sees it (ranks meet every step)
    std::ostringstream stages;
    for (auto& kv : r.stage_ms) stages << " " << kv.first << "=" << std::setprecision(3) << kv.second;
    std::cout << std::left << std::setw(10) << n << std::setw(14) << std::setprecision(4) << r.median_ms
              << std::setw(14) << std::setprecision(5) << r.throughput << std::setw(18) << std::setprecision(4)
              << double(n) * r.throughput << " " << stages.str() << "\n";
    for (auto& kv : r.metrics_mean) std::cout << "            " << kv.first << " per step: " << kv.second << "\n";
    if (backend == Backend::cuda) {
      std::cout << "            host's own time per step (pass 1): " << std::setprecision(3) << r.host_own_ms
                << " ms of " << 1e3 / r.throughput
                << (r.host_own_ms > 0.9e3 / r.throughput ? " (the host bounds the step)" : "") << "; in the stages (ms):";
      for (auto& kv : r.stage_host_ms) std::cout << " " << kv.first << "=" << std::setprecision(3) << kv.second;
      std::cout << "\n";
    }
    if (gpus > 1)
      for (std::size_t k = 0; k < all.size(); ++k) {
        std::cout << "            rank " << k << ": communication " << std::setprecision(4) << all[k].comm_ms
                  << " ms/step (" << std::setprecision(3) << 100 * all[k].comm_ms * all[k].throughput / 1e3
                  << " % of the step), per stage (ms):";
        for (auto& kv : all[k].stage_ms) std::cout << " " << kv.first << "=" << std::setprecision(3) << kv.second;
        std::cout << "\n";
        if (all[k].migrations || all[k].step_start_ms > 0)
          std::cout << "            rank " << k << ": step mean " << std::setprecision(4) << all[k].mean_ms
                    << " ms; begin_step (host): " << all[k].step_start_ms << " ms in a step without migration, "
                    << all[k].migrations << " migration(s) in " << steps << " steps, " << all[k].migration_ms
                    << " ms each\n";
        if (!all[k].migration_phase_ms.empty()) {
          std::cout << "            rank " << k << ": a migration's phases (host ms):";
          for (auto& [phase, ms] : all[k].migration_phase_ms) std::cout << " " << phase << "=" << std::setprecision(3) << ms;
          std::cout << "\n";
        }
      }
    jsonl << "{\"date\":\"" << date << "\",\"pipeline\":\"" << json_escape(common.file) << "\",\"backend\":\""
          << to_string(backend) << "\",\"device\":\"" << json_escape(device) << "\",\"N\":" << n
          << ",\"steps\":" << steps << ",\"median_ms\":" << r.median_ms << ",\"mean_ms\":" << r.mean_ms
          << ",\"steps_per_s\":" << r.throughput << ",\"particle_steps_per_s\":" << double(n) * r.throughput
          << ",\"host_own_ms\":" << r.host_own_ms
          << ",\"rollbacks_per_step\":" << r.rollbacks_per_step
          << ",\"dt_limits_per_step\":" << r.dt_limits_per_step << ",\"ranks\":" << gpus
          << ",\"threads\":" << cores << ",\"precision\":\"" << to_string(run.precision) << "\",\"seed\":" << run.seed
          << ",\"warmup\":" << warmup << ",\"overrides\":" << overrides_json << ",\"commit\":\""
          << json_escape(flipflow_build_commit()) << "\",\"passes\":" << passes_json << ",\"pass\":" << pass_json;
    if (gpus > 1) {
      // Per rank: communication per step and its share of the step, the profiled stage times.
      jsonl << ",\"per_rank\":[";
      for (std::size_t k = 0; k < all.size(); ++k) {
        jsonl << (k ? "," : "") << "{\"comm_ms\":" << all[k].comm_ms << ",\"migrations\":" << all[k].migrations
              << ",\"migration_ms\":" << all[k].migration_ms << ",\"step_start_ms\":" << all[k].step_start_ms
              << ",\"comm_share\":" << all[k].comm_ms * all[k].throughput / 1e3 << ",\"stage_ms\":";
        jsonl << json_object(all[k].stage_ms) << "}";
      }
      jsonl << "]";
    }
    jsonl << ",\"stage_ms\":" << json_object(r.stage_ms) << ",\"stage_host_ms\":" << json_object(r.stage_host_ms)
          << ",\"metrics_per_step\":" << json_object(r.metrics_mean) << "}\n";
    // Each size's line and row as soon as it is measured: an interrupted bench keeps the sizes done.
    jsonl.flush();
    std::cout.flush();
    if (!jsonl) throw RunError("writing '" + jsonl_path.string() + "' failed: " + std::strerror(errno));
  }
  return 0;
}

}  // namespace ff::cli
