// A pipeline file after validation: plain data, no YAML. Produced by core/input/pipeline_loader.h,
// consumed by the step graph and the simulation.
#pragma once
#include <cstdint>
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

struct SystemSpec {
  int dimensions = 2;
  std::uint64_t N = 0;
  double packing_fraction = 0;  // used when `box` is not given
  std::vector<double> box;      // explicit edge lengths (dimensions entries), optional
  double sigma = 1.0;           // reference diameter
  std::vector<SpeciesSpec> types{SpeciesSpec{}};
  std::string init = "random";  // random | triangular_lattice_sample | lattice_sample
};

struct RunSpec {
  std::uint64_t steps = 0;
  double dt = 0;
  double dt_min = 0;                  // default dt / 1024
  std::uint64_t dt_grow_after = 100;  // good steps before Δt doubles back toward dt
  std::uint64_t seed = 0;
  Precision precision = Precision::f64;
};

struct StepEntry {
  std::string id;                 // unique in the pipeline; default: the stage name (name#2 ...)
  std::string stage;              // registry name
  ParamValues params;             // validated, every declared key present (defaults filled)
  std::vector<std::string> after; // ids this entry runs after
  bool after_given = false;       // false: runs after the previous entry
  std::uint64_t every = 1;        // run on steps where step % every == 0
  Location where;
};

struct PipelineSpec {
  std::string file;
  SystemSpec system;
  RunSpec run;
  std::vector<std::string> plugins;
  std::vector<StepEntry> step;
};

}  // namespace ff
