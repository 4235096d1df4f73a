// `pipeline sweep`'s command line and plan (sweep.h): the flags, the --grid axes, and every run
// checked through the loader and a dry run before the sweep writes anything, so that a bad key
// or value is exit 2 naming its --grid argument instead of a folder of failed runs.
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>

#include "core/base/error.h"
#include "core/run/simulation.h"
#include "tools/pipeline/common.h"
#include "tools/pipeline/options.h"
#include "tools/pipeline/sweep.h"

namespace fs = std::filesystem;
namespace po = boost::program_options;

namespace ff::cli::sweep {

SweepArgs parse_args(const std::vector<std::string>& args) {
  SweepArgs a;
  CommonOptions common;
  po::options_description extra;
  extra.add_options()("grid", po::value<std::vector<std::string>>(&a.grid_args)->composing(),
                      "KEY=V1,V2,...: one axis of the grid (keys as for --set)")(
      "replicas", po::value<int>(&a.replicas)->default_value(1), "runs per combination, seeds run.seed + 0 .. R-1")(
      "concurrent", po::value<int>(&a.concurrent)->default_value(1), "runs at once per GPU (on the CPU: in all)")(
      "out", po::value<std::string>(&a.out), "the sweep's folder (default sweeps/<file stem>)")(
      "threads", po::value<int>(&a.threads)->default_value(0), "CPU threads per run (0 = the cores / runs at once)")(
      "mps", po::value<std::string>(&a.mps_mode)->default_value("auto"), "CUDA MPS when runs share a GPU: auto, on, off")(
      "gpus", po::value<std::string>(&a.gpus), "GPUs to spread the runs over, e.g. 0,1 (default: every visible GPU)")(
      "force", po::bool_switch(&a.force), "run every run again from the start, whatever the folder holds")(
      "in-process", po::bool_switch(&a.in_process),
      "run the runs on threads of this process (one GPU, no MPS needed) instead of child processes");
  parse_options(args, extra, common);
  a.file = common.file;
  a.sets = common.overrides;
  a.device = common.device;
  if (a.replicas < 1) throw InputError("--replicas must be at least 1");
  if (a.concurrent < 1) throw InputError("--concurrent must be at least 1");
  if (a.threads < 0) throw InputError("--threads must be 0 (automatic) or more");
  if (a.mps_mode != "auto" && a.mps_mode != "on" && a.mps_mode != "off")
    throw InputError("--mps: expected auto, on or off, got '" + a.mps_mode + "'");

  for (auto& g : a.grid_args) {
    a.axes.push_back(parse_grid(g));
    const Axis& added = a.axes.back();
    for (std::size_t k = 0; k + 1 < a.axes.size(); ++k)
      if (a.axes[k].key == added.key) throw InputError("--grid " + g + ": the key '" + added.key + "' has two --grid arguments");
    if (a.replicas > 1 && added.key == "run.seed")
      throw InputError("--grid " + g + ": --replicas sets run.seed (the pipeline's seed + 0 .. R-1); grid over the seed or give --replicas, not both");
    for (auto& set : a.sets)  // (the grid's value would replace the --set's in every run, silently)
      if (set.substr(0, set.find('=')) == added.key)
        throw InputError("--grid " + g + ": --set " + set + " sets the same parameter; give it one or the other");
  }
  // Before the plan, which would name a combination's values in the message.
  if (!fs::is_regular_file(a.file)) throw InputError("cannot read pipeline file '" + a.file + "'");
  return a;
}

namespace {

// A loader or dry-run error of one combination, said with the --grid argument it comes from
// (the loader names the offending --set, which is the axis's key), else with the combination.
std::string blame(const SweepArgs& a, const Run& run, const std::string& what) {
  for (std::size_t k = 0; k < a.axes.size(); ++k)
    if (what.find("--set " + a.axes[k].key + "=") != std::string::npos)
      return "--grid " + a.grid_args[k] + " (value '" + run.values[k] + "'): " + what;
  std::string combo;
  for (std::size_t k = 0; k < a.axes.size(); ++k) combo += (k ? ", " : "") + a.axes[k].key + "=" + run.values[k];
  return combo.empty() ? what : "with " + combo + ": " + what;
}

// An axis key as the step entry's id names it: step.<index>.<param> (or step[<index>].<param>) ->
// step.<id>.<param>.
std::string canonical_key(std::string key, const PipelineSpec& spec) {
  if (key.rfind("step[", 0) == 0) {  // step[i].param, as messages print it: step.i.param
    const std::size_t close = key.find(']');
    if (close != std::string::npos) key = "step." + key.substr(5, close - 5) + key.substr(close + 1);
  }
  if (key.rfind("step.", 0) != 0) return key;
  const std::size_t last = key.rfind('.');
  const std::string entry = key.substr(5, last - 5);
  if (entry.empty() || entry.find_first_not_of("0123456789") != std::string::npos || entry.size() > 6) return key;
  const std::size_t i = std::size_t(std::stoul(entry));
  return i < spec.step.size() ? "step." + spec.step[i].id + key.substr(last) : key;
}

// Two axes that set one parameter, spelled once by index and once by id: the later one would
// overwrite the other in every run, and the folders would name values that were never run.
void refuse_one_parameter_twice(const SweepArgs& a, const PipelineSpec& spec) {
  for (std::size_t k = 0; k < a.axes.size(); ++k)
    for (std::size_t j = 0; j < k; ++j)
      if (canonical_key(a.axes[k].key, spec) == canonical_key(a.axes[j].key, spec))
        throw InputError("--grid " + a.grid_args[k] + ": sets the same parameter as --grid " + a.grid_args[j] + " (" +
                         canonical_key(a.axes[k].key, spec) + ")");
}

// Fills in every run's seed, sets, N and steps. The first replica of a combination goes through
// the loader and a dry run; the others differ from it only in the seed, so they are derived from
// it without loading again.
// Where the dry runs after the first put their messages.
std::FILE* quiet() {
  static std::FILE* nowhere = std::fopen("/dev/null", "w");
  return nowhere ? nowhere : stderr;
}

void resolve_runs(const SweepArgs& a, std::vector<Run>& runs) {
  // A registry per plugin list: loading plugins is the slow part of resolving, and most sweeps
  // use one list for every combination.
  std::map<std::string, std::unique_ptr<Registry>> registries;
  const Run* previous = nullptr;
  for (auto& run : runs) {
    std::vector<std::string> sets = a.sets;
    for (std::size_t k = 0; k < a.axes.size(); ++k) sets.push_back(a.axes[k].key + "=" + run.values[k]);
    if (run.replica != 0) {
      // Replicas differ only in run.seed: base seed + replica.
      run.seed = previous->seed - std::uint64_t(previous->replica) + std::uint64_t(run.replica);
      run.N = previous->N;
      run.steps = previous->steps;
      sets.push_back("run.seed=" + std::to_string(run.seed));
      run.sets = sets;
      previous = &run;
      continue;
    }
    try {
      auto doc = PipelineDocument::parse(a.file, sets);
      const auto plugins = doc.plugins();
      std::string plugin_key;
      for (auto& p : plugins) plugin_key += p + "\n";
      auto& registry = registries[plugin_key];
      if (!registry) registry = make_registry(plugins, [&doc](std::size_t i) { return doc.plugin_location(i); });
      const PipelineSpec spec = doc.resolve(*registry);
      if (&run == &runs.front()) refuse_one_parameter_twice(a, spec);
      run.seed = spec.run.seed;
      run.N = spec.system.N;
      run.steps = spec.run.steps;
      // With replicas every replica's `pipeline run` is given its seed, the first's (the pipeline's
      // own) too, so that each records it among its --set arguments.
      if (a.replicas > 1) sets.push_back("run.seed=" + std::to_string(run.seed));
      // As `pipeline validate`: every stage configured on the real initial state, no files.
      // Its warnings (an output outside the run's folder, a repeated stage) once, from the
      // first combination: they are the same for every run, and each run's log has them too.
      RunOptions o;
      o.dry_run = true;
      if (&run != &runs.front()) o.messages = quiet();
      Simulation dry(spec, *registry, o);
    } catch (const InputError& e) {
      throw InputError(blame(a, run, e.what()));
    } catch (const std::exception& e) {
      throw InputError(blame(a, run, std::string("the dry run failed: ") + e.what()));
    }
    run.sets = sets;
    previous = &run;
  }
}

}  // namespace

std::vector<Run> plan(const SweepArgs& a) {
  std::vector<Run> runs = combinations(a.axes, a.replicas);
  resolve_runs(a, runs);
  name_folders(a.axes, runs, a.replicas > 1);
  return runs;
}

}  // namespace ff::cli::sweep
