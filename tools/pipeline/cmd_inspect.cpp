// `pipeline validate | graph | stages | describe`: look without running.
#include <iomanip>
#include <iostream>
#include <memory>

#include "core/backend/device.h"
#include "core/base/error.h"
#include "core/run/simulation.h"
#include "core/stage/state.h"
#include "tools/pipeline/commands.h"
#include "tools/pipeline/common.h"
#include "tools/pipeline/options.h"

namespace po = boost::program_options;

namespace ff::cli {

namespace {
// The graph needs every stage's accesses, known once the stages are configured on the real
// initial state (which also checks that the initial condition can be built). No files.
std::unique_ptr<Simulation> dry_run(const Loaded& loaded) {
  RunOptions o;
  o.dry_run = true;
  return std::make_unique<Simulation>(loaded.spec, *loaded.registry, o);
}
}  // namespace

int cmd_validate(const std::vector<std::string>& args) {
  CommonOptions common;
  parse_options(args, {}, common);
  Loaded loaded = load(common.file, common.overrides);
  const auto& s = loaded.spec;
  auto sim_ptr = dry_run(loaded);
  auto& sim = *sim_ptr;
  std::cout << common.file << ": valid\n"
            << "system: " << s.system.dimensions << "D, N = " << s.system.N << ", init " << s.system.init << "\n"
            << "run: " << s.run.steps << " steps, dt = " << s.run.dt << " (min " << s.run.dt_min << "), seed "
            << s.run.seed << ", " << to_string(s.run.precision) << "\n"
            << sim.graph().summary();
  const auto snap = sim.snapshot_fields();
  std::cout << "rollback snapshot: ";
  if (snap.empty()) std::cout << "none (no stage can request a rollback)";
  for (std::size_t i = 0; i < snap.size(); ++i) std::cout << (i ? ", " : "") << snap[i];
  const auto on_demand = sim.snapshot_on_demand_fields();
  if (!on_demand.empty()) {
    std::cout << "; only on steps that write them: ";
    for (std::size_t i = 0; i < on_demand.size(); ++i) std::cout << (i ? ", " : "") << on_demand[i];
  }
  std::cout << "\n";
  return 0;
}

int cmd_graph(const std::vector<std::string>& args) {
  CommonOptions common;
  parse_options(args, {}, common);
  Loaded loaded = load(common.file, common.overrides);
  std::cout << dry_run(loaded)->graph().dot();
  return 0;
}

int cmd_stages(const std::vector<std::string>&) {
  auto r = make_full_registry();
  for (auto& name : r->names()) {
    const auto& e = r->get(name);
    std::string backends;
    for (auto& kv : e.factories) backends += std::string(backends.empty() ? "" : ",") + to_string(kv.first);
    std::cout << std::left << std::setw(28) << name << " [" << backends << "] " << e.decl.summary << "\n";
  }
  return 0;
}

int cmd_describe(const std::vector<std::string>& args) {
  if (args.size() != 1) throw InputError("usage: pipeline describe STAGE");
  auto r = make_full_registry();
  const auto& e = r->get(args[0]);
  std::cout << e.decl.name << " — " << e.decl.summary << "\n  plugin: " << e.plugin << "\n  backends:";
  for (auto& kv : e.factories) std::cout << " " << to_string(kv.first);
  std::cout << "\n  dimensions:";
  for (int d : e.decl.dimensions) std::cout << " " << d;
  std::cout << (e.decl.observer ? "\n  observer: runs after each accepted step\n" : "\n") << "  parameters:\n";
  for (auto& p : e.decl.params)
    std::cout << "    " << std::left << std::setw(16) << p.name << " "
              << (p.default_value ? "default " + format_value(p, *p.default_value) : std::string("required")) << "; "
              << p.expectation() << "\n      " << p.doc << "\n";
  // Accesses of a default instance (2D if supported, double, CPU). A stage that needs others
  // before it (a pair force needs neighbors.verlet) cannot be configured alone; its accesses
  // before configure() are still listed, with the reason beside them.
  try {
    RunInfo info;
    info.dim = e.decl.dimensions.front();
    const std::unique_ptr<Stage> stage = r->create(e.decl.name, Backend::cpu, ParamValues::defaults(e.decl.params), info);
    State state(info.dim, Precision::f64, 16);
    for (int k = 0; k < info.dim; ++k) state.box.L[k] = 10.0;  // (stages that size grids from the box)
    std::string unconfigured;
    try {
      stage->configure(state);
    } catch (const std::exception& ex) {
      unconfigured = ex.what();
    }
    const auto accesses = stage->accesses();
    std::cout << "  fields (default parameters, CPU" << (unconfigured.empty() ? "" : "; not configured alone") << "):\n";
    for (auto& a : accesses)
      std::cout << "    " << std::left << std::setw(24) << a.field << " " << to_string(a.mode) << " on "
                << to_string(a.where) << "\n";
    if (accesses.empty()) std::cout << "    none\n";
    if (!unconfigured.empty()) std::cout << "    (configured alone it says: " << unconfigured << ")\n";
  } catch (const std::exception& ex) {
    std::cout << "  fields: depend on the configuration (" << ex.what() << ")\n";
  }
  return 0;
}

}  // namespace ff::cli
