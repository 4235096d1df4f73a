// A pipeline file after validation: plain data, no YAML. Produced by core/input/pipeline_loader.h,
// consumed by the step graph and the simulation.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "core/stage/params.h"
#include "core/base/types.h"

namespace ff {

// Where something came from, for error messages: "file.yaml:12:5" or "--set run.dt=0.1".
struct Location {
  std::string file;
  int line = 0;    // 1-based; 0 = not from a file (e.g. a --set override)
  int column = 0;  // 1-based
  std::string str() const;
};

struct SpeciesSpec {
  std::string name = "A";
  double fraction = 1.0;   // of N; fractions are normalised to sum to 1
  double diameter = 1.0;   // in units of system.sigma
};

// " (with --set a=1, --set b=2)" for the --set arguments behind a section or step; "" for none.
inline std::string set_by_note(const std::vector<std::string>& set_by) {
  std::string note;
  for (auto& s : set_by) note += (note.empty() ? " (with --set " : ", --set ") + s;
  return note.empty() ? note : note + ")";
}

struct SystemSpec {
  int dimensions = 2;
  std::uint64_t N = 0;
  double packing_fraction = 0;  // used when `box` is not given
  std::vector<double> box;      // explicit edge lengths (dimensions entries), optional
  double sigma = 1.0;           // reference diameter
  std::vector<SpeciesSpec> types{SpeciesSpec{}};
  std::string init = "random";  // random | triangular_lattice_sample | lattice_sample | from
  // init: {from: FILE.h5, frame: k}: start from frame k of an H5MD file (negative: from the end).
  std::string init_from;
  std::int64_t init_frame = -1;
  // Where the initial state was asked for: the `init` key, else the `system` section (the
  // errors of making it name this place; empty for a spec built in code).
  Location where;
  // The --set arguments that changed `system` (its errors name them beside `where`).
  std::vector<std::string> set_by;
};

struct RunSpec {
  std::uint64_t steps = 0;
  double dt = 0;
  double dt_min = 0;                  // default dt / 1024
  std::uint64_t dt_grow_after = 100;  // good steps before Δt doubles back toward dt
  std::uint64_t seed = 0;
  Precision precision = Precision::f64;
  // run.checkpoint: {every: K, keep: k}. A checkpoint every K steps (0: none) and at the end of
  // the run; the newest `keep` files are kept (core/run/checkpoint.h).
  std::uint64_t checkpoint_every = 0;
  std::uint64_t checkpoint_keep = 2;
  bool checkpoint = false;  // run.checkpoint given (end-of-run checkpoint even with every = 0)
};

// When a step entry runs. `every: k`: the steps where step % k == 0. `at: {log: {first, factor}}`:
// the steps round(first·factor^k), k = 0, 1, ..., de-duplicated, and the run's last step (for an
// observer, the step count after the last step: its final state): a
// logarithmic time axis, for observables followed over decades (Tran et al.'s aggregation
// kinetics, 10^-6 ... 10 s) that `every` would sample either too coarsely early or too often late.
struct Schedule {
  std::uint64_t every = 1;
  bool log = false;
  std::uint64_t first = 1;  // log: the first step (>= 1)
  double factor = 1.2;      // log: the ratio of successive steps (> 1)

  bool every_step() const { return !log && every == 1; }
  // The steps of a run of `steps` steps (0 ... steps - 1) this schedule runs on, ascending.
  std::vector<std::uint64_t> log_steps(std::uint64_t steps) const {
    std::vector<std::uint64_t> out;
    for (double k = 0;;) {
      const double s = std::round(double(first) * std::pow(factor, k));
      if (!(s < double(steps))) break;
      if (out.empty() || out.back() != std::uint64_t(s)) out.push_back(std::uint64_t(s));
      // Skip the k whose value rounds to s again (a factor near 1 repeats a step many times: 1 +
      // 1e-10 would take ~10^11 turns), to two before the first estimated not to: the same steps
      // as k = 0, 1, 2, ... one by one, since the values only grow with k.
      k = std::max(k + 1, std::floor(std::log((s + 0.5) / double(first)) / std::log(factor)) - 2);
      if (k + 1 == k) break;  // (a factor within ~1e-15 of 1, which the loader refuses: no further step)
    }
    if (steps > 0 && (out.empty() || out.back() != steps - 1)) out.push_back(steps - 1);
    return out;
  }
  // "every 10", "at log(first 1, factor 1.2)"; empty for every step.
  std::string text() const {
    if (log) {
      std::ostringstream os;
      os << "at log(first " << first << ", factor " << factor << ")";
      return os.str();
    }
    return every > 1 ? "every " + std::to_string(every) : "";
  }
};

struct StepEntry {
  std::string id;                 // unique in the pipeline; default: the stage name (name#2 ...)
  std::string stage;              // registry name
  ParamValues params;             // validated, every declared key present (defaults filled)
  std::vector<std::string> after; // ids this entry runs after
  bool after_given = false;       // false: runs after the previous entry
  Schedule schedule;              // `every` or `at`
  Location where;
  // The --set arguments that changed this entry (step.<id or index>.<param>=...): a stage's
  // error about its parameters names them beside `where`, which is the file's entry.
  std::vector<std::string> set_by;
};

struct PipelineSpec {
  std::string file;
  SystemSpec system;
  RunSpec run;
  std::vector<std::string> plugins;
  std::vector<StepEntry> step;
};

}  // namespace ff
