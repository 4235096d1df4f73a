// `pipeline run`: the main job.
#include <oneapi/tbb/global_control.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <iostream>
#include <optional>

#include "core/backend/device.h"
#include "core/base/error.h"
#include "core/run/simulation.h"
#include "tools/pipeline/commands.h"
#include "tools/pipeline/common.h"
#include "tools/pipeline/options.h"

namespace po = boost::program_options;

namespace ff::cli {

namespace {
std::atomic<bool> g_interrupted{false};
extern "C" void on_interrupt(int) { g_interrupted.store(true); }
}  // namespace

int cmd_run(const std::vector<std::string>& args) {
  CommonOptions common;
  std::string out;
  bool force = false;
  bool check_rollbacks = false;
  int threads = 0;
  po::options_description extra;
  extra.add_options()("out", po::value<std::string>(&out), "output directory (default runs/<file stem>)")(
      "force", po::bool_switch(&force), "overwrite existing outputs")(
      "threads", po::value<int>(&threads)->default_value(0), "CPU threads (0 = all cores)")(
      "check-rollbacks", po::bool_switch(&check_rollbacks),
      "after every rollback, check that the whole state was restored bit for bit (slow: copies the state every "
      "step; for stage authors)");
  parse_options(args, extra, common);
  const Backend backend = resolve_backend(common.device);
  Loaded loaded = load(common.file, common.overrides);
  if (out.empty()) out = "runs/" + std::filesystem::path(common.file).stem().string();
  std::optional<tbb::global_control> limit;
  if (threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, std::size_t(threads));

  RunOptions options{backend, out, force, loaded.text};
  options.check_rollbacks = check_rollbacks;
  Simulation sim(loaded.spec, *loaded.registry, options);
  const auto& spec = loaded.spec;
  std::cerr << "flipflow: " << common.file << " — " << spec.system.dimensions << "D, N = " << spec.system.N << ", "
            << spec.run.steps << " steps of Δt = " << spec.run.dt << ", " << to_string(spec.run.precision) << " on "
            << to_string(backend) << (backend == Backend::cuda ? " (" + cuda_device_description() + ")" : "")
            << ", output in " << out << "/\n";

  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  const auto t0 = std::chrono::steady_clock::now();
  try {
    while (sim.state().step < spec.run.steps) {
      if (g_interrupted.load())
        throw RunError("interrupted at step " + std::to_string(sim.state().step) +
                       "; outputs so far are kept as .partial files");
      sim.advance();
    }
    sim.synchronize();
  } catch (...) {
    sim.finish(false);
    throw;
  }
  sim.finish(true);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cerr << "done: " << sim.state().step << " steps in " << secs << " s (" << double(sim.state().step) / secs
            << " steps/s), simulated time " << sim.state().time << ", rollbacks " << sim.stats().rollbacks << "\n";
  return 0;
}

}  // namespace ff::cli
