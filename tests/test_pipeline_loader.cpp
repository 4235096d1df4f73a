// The pipeline loader against a hand-made registry (no plugins): a valid file resolves with
// every default filled; every malformed file in tests/data/yaml/bad_*.yaml fails with the
// exact file:line:column and the key path / expectation; --set overrides apply or fail with
// their own location.
#include <catch2/catch.hpp>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/input/pipeline_loader.h"
#include "core/input/pipeline_spec.h"
#include "core/run/plugin_loader.h"

namespace {

using Catch::Contains;
using Catch::StartsWith;

struct NullStage final : ff::Stage {
  std::vector<ff::Access> accesses() const override { return {}; }
  ff::Outcome run(ff::StepContext&) override { return ff::Outcome::ok(); }
};

ff::ParamSpec reals(std::string name) {
  ff::ParamSpec s;
  s.name = std::move(name);
  s.type = ff::ParamType::real_list;
  s.default_value = std::vector<double>{};
  return s.at_least(0);
}

// Four fake stages that cover every parameter type, a 2D-only stage and a required parameter.
const ff::Registry& registry() {
  static const ff::Registry r = [] {
    ff::Registry reg;
    auto add = [&reg](ff::StageDecl d) {
      const std::string name = d.name;
      reg.declare(std::move(d));
      reg.implement(name, ff::Backend::cpu,
                    [](const ff::ParamValues&, const ff::RunInfo&) { return std::make_unique<NullStage>(); });
    };
    using ff::ParamSpec;
    add({"fake.integrate", "moves particles",
         {ParamSpec::real("D", 1.0, "diffusion").at_least(0),
          ParamSpec::string("mode", "euler", "scheme").one_of({"euler", "heun"})}});
    add({"fake.force", "pair force",
         {ParamSpec::real("k", std::nullopt, "stiffness").above(0), ParamSpec::real("cutoff", 2.5, "").above(0)}});
    add({"fake.lawson", "2D flips",
         {ParamSpec::integer("max_rounds", 50, "").at_least(1), ParamSpec::boolean("verbose", false, "")},
         {2}});
    add({"fake.observe", "writes files",
         {ParamSpec::strings("fields", {"position"}, "").one_of({"position", "orientation"}), reals("weights")},
         {2, 3},
         true});
    return reg;
  }();
  return r;
}

std::string data_dir() {
  if (const char* d = std::getenv("FLIPFLOW_TEST_DATA")) return std::string(d) + "/yaml";
  const std::string here = __FILE__;
  return here.substr(0, here.find_last_of('/')) + "/data/yaml";
}

std::string path_of(const std::string& name) { return data_dir() + "/" + name + ".yaml"; }

// Everything a `pipeline validate` would do: parse, list plugins, resolve.
std::string error_of(const std::string& path, const std::vector<std::string>& overrides = {}) {
  try {
    auto doc = ff::PipelineDocument::parse(path, overrides);
    doc.plugins();
    doc.resolve(registry());
  } catch (const ff::InputError& e) {
    return e.what();
  }
  return "(no error)";
}

std::string error_of_text(const std::string& yaml, const std::vector<std::string>& overrides) {
  try {
    auto doc = ff::PipelineDocument::parse_string(yaml, "inline.yaml", overrides);
    doc.plugins();
    doc.resolve(registry());
  } catch (const ff::InputError& e) {
    return e.what();
  }
  return "(no error)";
}

const char* kMinimal =
    "system: {N: 10, packing_fraction: 0.5}\n"
    "run: {steps: 10, dt: 0.01}\n"
    "step:\n"
    "  - {stage: fake.integrate}\n"
    "  - {stage: fake.lawson, id: lawson.a}\n";

}  // namespace

TEST_CASE("a valid pipeline resolves with every default filled", "[pipeline_loader]") {
  auto doc = ff::PipelineDocument::parse(path_of("good"));
  CHECK(doc.plugins() == std::vector<std::string>{"fake"});
  const ff::PipelineSpec spec = doc.resolve(registry());

  CHECK(spec.file == path_of("good"));
  CHECK(spec.system.dimensions == 2);
  CHECK(spec.system.N == 1000);
  CHECK(spec.system.packing_fraction == Approx(0.5));
  CHECK(spec.system.box.empty());
  CHECK(spec.system.sigma == 1.0);
  CHECK(spec.system.init == "triangular_lattice_sample");
  REQUIRE(spec.system.types.size() == 2);
  CHECK(spec.system.types[0].name == "A");
  CHECK(spec.system.types[0].diameter == 1.0);
  CHECK(spec.system.types[1].fraction == Approx(0.25));
  CHECK(spec.system.types[1].diameter == Approx(1.4));

  CHECK(spec.run.steps == 10000);  // written 1e4: an exact integer
  CHECK(spec.run.dt == Approx(0.01));
  CHECK(spec.run.dt_min == Approx(0.01 / 1024));
  CHECK(spec.run.dt_grow_after == 100);
  CHECK(spec.run.seed == 42);
  CHECK(spec.run.precision == ff::Precision::f32);

  REQUIRE(spec.step.size() == 6);
  const auto& s = spec.step;
  CHECK(s[0].params.real("D") == Approx(0.5));
  CHECK(s[0].params.string("mode") == "euler");
  CHECK(s[1].params.real("k") == Approx(10));  // an integer is a fine real
  CHECK(s[1].params.real("cutoff") == Approx(2.5));
  CHECK(s[2].params.integer("max_rounds") == 50);
  CHECK(s[2].params.boolean("verbose") == false);
  CHECK(s[3].params.integer("max_rounds") == 3);
  CHECK(s[5].params.strings("fields") == std::vector<std::string>{"position", "orientation"});
  CHECK(s[5].params.reals("weights") == std::vector<double>{1, 0.5});
  for (auto& e : s) CHECK(e.params.all().size() == registry().get(e.stage).decl.params.size());
  CHECK(s[5].schedule.every == 100);
  CHECK(s[0].schedule.every == 1);
  CHECK(s[4].where.str() == path_of("good") + ":17:5");
}

TEST_CASE("ids default to the stage name (numbered on repeats) and after names earlier ids", "[pipeline_loader]") {
  const auto spec = ff::PipelineDocument::parse(path_of("good")).resolve(registry());
  std::vector<std::string> ids;
  for (auto& e : spec.step) ids.push_back(e.id);
  CHECK(ids == std::vector<std::string>{"fake.integrate", "fake.force", "fake.lawson", "lawson.second",
                                        "fake.integrate#2", "fake.observe"});
  CHECK_FALSE(spec.step[0].after_given);
  CHECK(spec.step[3].after_given);
  CHECK(spec.step[3].after == std::vector<std::string>{"fake.integrate"});  // a single string
  CHECK(spec.step[4].after == std::vector<std::string>{"fake.force", "fake.lawson"});
  CHECK(spec.step[4].stage == "fake.integrate");
  CHECK(spec.step[4].params.string("mode") == "heun");
}

namespace {
struct Bad {
  const char* file;  // tests/data/yaml/<file>.yaml
  const char* at;    // "line:column"
  const char* head;  // what follows "path:line:column: " in the message
};
}  // namespace

TEST_CASE("malformed pipelines fail with file:line:column then the key and the expectation", "[pipeline_loader]") {
  // clang-format off
  const Bad bad = GENERATE(values<Bad>({
      {"bad_top_key", "3:1", "steps: unknown top-level key; did you mean 'step'? (known keys: system, run, plugins, step)"},
      {"bad_section_key", "1:17", "system.packing_fracton: unknown key; did you mean 'packing_fraction'? (known keys: "},
      {"bad_unknown_stage", "5:13", "step[1].stage: unknown stage 'fake.lawsen'; did you mean 'fake.lawson'? "
                                    "(loaded stages: fake.force, fake.integrate, fake.lawson, fake.observe)"},
      {"bad_stage_param", "5:5", "step[0] (fake.lawson).max_round: unknown parameter; did you mean 'max_rounds'? "
                                 "(parameters of fake.lawson: max_rounds, verbose; entry keys: stage, id, after, every, at)"},
      {"bad_wrong_type", "5:14", "step[0] (fake.lawson).verbose: expected true or false, got 'maybe'"},
      {"bad_list_for_number", "2:6", "system.N: expected an integer >= 1, got a list"},
      {"bad_out_of_range", "4:7", "run.dt: expected a real number > 0, got '-0.1'"},
      {"bad_missing_n", "2:3", "system: missing required key 'N' (an integer >= 1)"},
      {"bad_missing_step", "1:1", "missing required top-level key 'step'"},
      {"bad_missing_param", "5:5", "step[1] (fake.force): missing required parameter 'k' (a real number > 0)"},
      {"bad_every", "5:34", "step[1] (fake.observe).every: expected an integer >= 1, got '0'"},
      {"bad_every_and_at", "5:37", "step[1] (fake.observe).at: give 'every' or 'at', not both"},
      {"bad_at_factor", "5:56", "step[1] (fake.observe).at.log.factor: expected a real number > 1, got '1'"},
      {"bad_at_kind", "5:32", "step[1] (fake.observe).at: expected one schedule, 'log' ({log: {first: 1, "
                              "factor: 1.2}}), got 'linear'"},
      {"bad_after_unknown", "6:50", "step[2] (fake.lawson).after: unknown id 'fake.forse'; did you mean 'fake.force'? "
                                    "(ids declared before: fake.integrate, fake.force)"},
      {"bad_after_self", "5:43", "step[1] (fake.lawson).after: an entry cannot run after itself ('flip')"},
      {"bad_after_later", "4:37", "step[0] (fake.integrate).after: 'fake.lawson' is step[1] (fake.lawson), declared "
                                  "later; 'after' may only name entries declared before this one"},
      {"bad_duplicate_id", "5:30", "step[1] (fake.lawson).id: duplicate id 'move' (already the id of step[0] "
                                   "(fake.integrate) at "},
      {"bad_box_length", "4:8", "system.box: expected 2 edge lengths (one per dimension; system.dimensions is 2), got 3"},
      {"bad_box_and_fraction", "4:3", "system: give either 'box' or 'packing_fraction', not both"},
      {"bad_syntax", "2:26", "invalid YAML: illegal flow end"},
      {"bad_precision", "5:14", "run.precision: expected one of: float, double, got 'quad'"},
      {"bad_integer_fraction", "4:38", "step[0] (fake.lawson).max_rounds: expected an integer >= 1, got '1.5'"},
      {"bad_empty_steps", "3:7", "step: expected a non-empty list of stage entries ({stage: <name>, ...}), "
                                 "got an empty list"},
      {"bad_dimensions", "5:13", "step[1].stage: stage 'fake.lawson' supports dimensions 2 only, but "
                                 "system.dimensions is 3"},
      {"bad_duplicate_key", "5:3", "run.dt: duplicate key (first given at "},
      {"bad_packing_fraction", "1:35", "system.packing_fraction: expected a real number > 0 and < 1, got '1.2'"},
      {"bad_dt_min", "2:36", "run.dt_min: expected a real number > 0 and <= run.dt (0.01), got '0.1'"},
      {"bad_types", "6:42", "system.types[1].diameter: expected a real number > 0, got '0'"},
      {"bad_list_item", "4:46", "step[0] (fake.observe).fields[1]: expected one of: position, "
                                "orientation, got 'velocity'"},
      {"bad_plugins", "3:10", "plugins: expected a list of strings, got 'abp'"},
  }));
  // clang-format on
  const std::string path = path_of(bad.file);
  const std::string msg = error_of(path);
  CAPTURE(bad.file, msg);
  CHECK_THAT(msg, StartsWith(path + ":" + bad.at + ": " + bad.head));
}

TEST_CASE("locations print as file:line:column or as the override alone", "[pipeline_loader]") {
  CHECK(ff::Location{"a.yaml", 3, 7}.str() == "a.yaml:3:7");
  CHECK(ff::Location{"--set run.dt=1", 0, 0}.str() == "--set run.dt=1");
}

TEST_CASE("a duplicate id names where the first one is", "[pipeline_loader]") {
  const std::string path = path_of("bad_duplicate_id");
  CHECK_THAT(error_of(path), Contains("already the id of step[0] (fake.integrate) at " + path + ":4:5)"));
}

TEST_CASE("a missing file and an empty file are input errors", "[pipeline_loader]") {
  const std::string missing = data_dir() + "/no_such_file.yaml";
  CHECK(error_of(missing) == "cannot read pipeline file '" + missing + "': No such file or directory");
  CHECK_THAT(error_of(data_dir()), StartsWith("cannot read pipeline file '" + data_dir() + "': "));
  CHECK(error_of_text("", {}) == "inline.yaml:1:1: expected a map with keys system, run, plugins, step, got nothing");
  CHECK(error_of_text("[1, 2]", {}) ==
        "inline.yaml:1:1: expected a map with keys system, run, plugins, step, got a list");
  CHECK_THAT(error_of_text("system:\n\tN: 3\n", {}), Contains("invalid YAML") && Contains("indents with a tab"));
  CHECK(error_of_text("[]", {}) == "inline.yaml:1:1: expected a map with keys system, run, plugins, step, got an empty list");
}

TEST_CASE("scalars are typed strictly", "[pipeline_loader]") {
  auto with_run = [](const std::string& run) {
    return "system: {N: 10, packing_fraction: 0.5}\nrun: {" + run + "}\nstep: [{stage: fake.integrate}]\n";
  };
  auto resolve = [](const std::string& yaml) {
    return ff::PipelineDocument::parse_string(yaml, "t.yaml").resolve(registry());
  };
  CHECK(resolve(with_run("steps: 10000, dt: 1")).run.dt == 1.0);  // integers are reals
  CHECK(resolve(with_run("steps: 2.5e3, dt: 1")).run.steps == 2500);
  CHECK(resolve(with_run("steps: +7, dt: .5")).run.dt == 0.5);
  CHECK_THAT(error_of_text(with_run("steps: 1e-3, dt: 1"), {}),
             Contains("run.steps: expected an integer >= 0, got '1e-3'"));
  CHECK_THAT(error_of_text(with_run("steps: 10, dt: .inf"), {}), Contains("run.dt: expected a real number > 0"));
  CHECK_THAT(error_of_text(with_run("steps: 10, dt: 0x10"), {}), Contains("got '0x10'"));
  CHECK_THAT(error_of_text(with_run("steps: 10, dt:"), {}), Contains("run.dt: expected a real number > 0, got nothing"));
  CHECK_THAT(error_of_text(with_run("steps: 99999999999999999999, dt: 1"), {}), Contains("run.steps: expected"));
}

TEST_CASE("overrides replace or create values before validation", "[pipeline_loader]") {
  const auto spec = ff::PipelineDocument::parse(path_of("good"), {"run.dt=0.001", "run.dt_min=1e-5", "system.N=100",
                                                                  "step.0.D=0.25", "step.1.k=3",
                                                                  "step.lawson.second.max_rounds=7",
                                                                  "step.fake.integrate#2.mode=euler",
                                                                  "step.fake.lawson.verbose=true", "plugins=[a, b]"})
                        .resolve(registry());
  CHECK(spec.run.dt == Approx(0.001));
  CHECK(spec.run.dt_min == Approx(1e-5));
  CHECK(spec.system.N == 100);
  CHECK(spec.step[0].params.real("D") == Approx(0.25));
  CHECK(spec.step[1].params.real("k") == Approx(3));
  CHECK(spec.step[3].params.integer("max_rounds") == 7);
  CHECK(spec.step[4].params.string("mode") == "euler");
  CHECK(spec.step[2].params.boolean("verbose"));
  CHECK(spec.plugins == std::vector<std::string>{"a", "b"});

  // A section the file lacks is created by its overrides.
  const std::string no_run = "system: {N: 10, packing_fraction: 0.5}\nstep: [{stage: fake.integrate}]\n";
  const auto created = ff::PipelineDocument::parse_string(no_run, "t.yaml", {"run.steps=5", "run.dt=0.1"})
                           .resolve(registry());
  CHECK(created.run.steps == 5);
  CHECK(created.run.dt == Approx(0.1));
}

TEST_CASE("errors in overridden values are located at the override", "[pipeline_loader]") {
  const std::string good = path_of("good");
  CHECK(error_of(good, {"run.dt=abc"}) == "--set run.dt=abc: run.dt: expected a real number > 0, got 'abc'");
  CHECK_THAT(error_of(good, {"step.fake.force.kk=1"}),
             StartsWith("--set step.fake.force.kk=1: step[1] (fake.force).kk: unknown parameter; "
                        "did you mean 'k'?"));
  CHECK(error_of(good, {"system.box=[10, 20]"}) ==
        "--set system.box=[10, 20]: system: give either 'box' or 'packing_fraction', not both");
  CHECK(error_of(path_of("bad_box_length"), {"system.box=[10, -1]"}) ==
        "--set system.box=[10, -1]: system.box[1]: expected a real number > 0, got '-1'");
  CHECK(error_of(good, {"step.0.every=0"}) ==
        "--set step.0.every=0: step[0] (fake.integrate).every: expected an integer >= 1, got '0'");
  // An alias inside its own anchor makes a cyclic override; locating must still terminate.
  // (resolve() reads run before plugins: the run.dt error is found behind the cycle, and the
  // cycle's own error is reported after it, at its override.)
  const auto cyclic = ff::PipelineDocument::parse(good, {"run.dt=abc", "plugins=&a [x, *a]"});
  CHECK_THROWS_WITH(cyclic.resolve(registry()), "--set run.dt=abc: run.dt: expected a real number > 0, got 'abc'\n"
                                                "--set plugins=&a [x, *a]: plugins[1]: expected a string, got a list");
  // Errors elsewhere keep their file location.
  CHECK_THAT(error_of(path_of("bad_out_of_range"), {"run.steps=3"}),
             StartsWith(path_of("bad_out_of_range") + ":4:7: run.dt:"));
  // A section created by overrides reports what it still lacks at the override.
  const std::string no_run = "system: {N: 10, packing_fraction: 0.5}\nstep: [{stage: fake.integrate}]\n";
  CHECK(error_of_text(no_run, {"run.dt=0.1"}) == "--set run.dt=0.1: run: missing required key 'steps' (an integer >= 0)");
}

TEST_CASE("every mistake of a file is reported at once, each at its own place", "[pipeline_loader]") {
  const std::string yaml =
      "system: {N: 0, packing_fraction: 0.5, dimensions: 3}\n"              // 1
      "run: {steps: 10, dt: -1, checkpoint: {every: x}}\n"                  // 2
      "step:\n"                                                             // 3
      "  - {stage: fake.integrate, D: -1, mode: rk4}\n"                     // 4
      "  - {stage: fake.lawsen, id: flip}\n"                                // 5
      "  - {stage: fake.force, after: flip, every: 0}\n"                    // 6
      "  - {stage: fake.lawson, max_round: 2}\n";                           // 7
  std::vector<std::string> messages;
  try {
    auto doc = ff::PipelineDocument::parse_string(yaml, "inline.yaml", {});
    doc.resolve(registry());
  } catch (const ff::InputError& e) {
    messages = ff::messages_of(e);
  }
  // In order: system, run, the step entries' heads, then their parameters. Not reported:
  // fake.lawson's dimensions (2 only, system.dimensions says 3, but system was refused, so the
  // dimensions are not known), and nothing of step[1] past its unknown stage (`after: flip`
  // names it, and is not refused for it).
  const std::vector<std::string> expected = {
      "inline.yaml:1:13: system.N: expected an integer >= 1, got '0'",
      "inline.yaml:2:22: run.dt: expected a real number > 0, got '-1'",
      "inline.yaml:2:46: run.checkpoint.every: expected an integer >= 0, got 'x'",
      "inline.yaml:5:13: step[1].stage: unknown stage 'fake.lawsen'; did you mean 'fake.lawson'? (loaded stages: "
      "fake.force, fake.integrate, fake.lawson, fake.observe)",
      "inline.yaml:4:32: step[0] (fake.integrate).D: expected a real number >= 0, got '-1'",
      "inline.yaml:4:42: step[0] (fake.integrate).mode: expected one of: euler, heun, got 'rk4'",
      "inline.yaml:6:45: step[2] (fake.force).every: expected an integer >= 1, got '0'",
      "inline.yaml:6:5: step[2] (fake.force): missing required parameter 'k' (a real number > 0)",
      "inline.yaml:7:26: step[3] (fake.lawson).max_round: unknown parameter; did you mean 'max_rounds'? (parameters "
      "of fake.lawson: max_rounds, verbose; entry keys: stage, id, after, every, at)"};
  CHECK(messages == expected);
}

TEST_CASE("malformed overrides are input errors", "[pipeline_loader]") {
  CHECK(error_of_text(kMinimal, {"run.dt"}) == "--set run.dt: expected KEY.PATH=VALUE, e.g. --set run.dt=0.001");
  CHECK(error_of_text(kMinimal, {"=3"}) == "--set =3: expected KEY.PATH=VALUE, e.g. --set run.dt=0.001");
  CHECK_THAT(error_of_text(kMinimal, {"sytem.N=3"}),
             StartsWith("--set sytem.N=3: unknown section 'sytem'; did you mean 'system'?"));
  CHECK_THAT(error_of_text(kMinimal, {"run=3"}), StartsWith("--set run=3: expected one of system.<key>, run.<key>"));
  CHECK_THAT(error_of_text(kMinimal, {"system.types.0.name=B"}), StartsWith("--set system.types.0.name=B: expected"));
  // A key inside a map or list: the message writes out the whole value, from the file's, with the
  // change made (before: 'system.init={frame: ...}' for a file's {from: a.h5, frame: -1}, which
  // then failed for want of 'from').
  CHECK_THAT(error_of_text(kMinimal, {"run.checkpoint.every=5"}),
             Contains("a value inside run.checkpoint is set by giving run.checkpoint whole: --set 'run.checkpoint={every: 5}'"));
  const std::string nested = "system: {dimensions: 2, N: 100, packing_fraction: 0.3, init: {from: a.h5, frame: -1},\n"
                             "  types: [{name: A, fraction: 0.5}, {name: B, fraction: 0.5, diameter: 1.2}]}\n"
                             "run: {steps: 10, dt: 0.01}\nstep:\n  - {stage: fake.integrate}\n";
  CHECK_THAT(error_of_text(nested, {"system.init.frame=3"}), Contains("--set 'system.init={from: a.h5, frame: 3}'"));
  CHECK_THAT(error_of_text(nested, {"system.types[0].fraction=0.3"}),
             Contains("--set 'system.types=[{name: A, fraction: 0.3}, {name: B, fraction: 0.5, diameter: 1.2}]'"));
  CHECK_THAT(error_of_text("system: {N: 10, packing_fraction: 0.5, init: random}\nrun: {steps: 10, dt: 0.01}\n"
                            "step:\n  - {stage: fake.integrate}\n",
                            {"system.init.frame=3"}),
             Contains("--set 'system.init={frame: 3}' (the file has system.init: random, not a map"));
  CHECK_THAT(error_of_text(kMinimal, {"step.D=3"}), StartsWith("--set step.D=3: expected one of"));
  CHECK(error_of_text(kMinimal, {"step.7.D=3"}) == "--set step.7.D=3: no step[7]: the step list has 2 entries");
  CHECK(error_of_text(kMinimal, {"step.lawson.b.max_rounds=3"}) ==
        "--set step.lawson.b.max_rounds=3: no step entry with id 'lawson.b'; did you mean 'lawson.a'? "
        "(ids: fake.integrate, lawson.a)");
  CHECK_THAT(error_of_text(kMinimal, {"run.dt=[1,"}), StartsWith("--set run.dt=[1,: the value is not valid YAML: "));
  // A good override by id with a dot in it; the entries record which --set changed them (a stage's
  // configure error names them).
  const auto spec = ff::PipelineDocument::parse_string(kMinimal, "m.yaml", {"step.lawson.a.max_rounds=4", "step.1.verbose=true", "run.dt=0.1"})
                        .resolve(registry());
  CHECK(spec.step[1].params.integer("max_rounds") == 4);
  CHECK(spec.step[1].set_by == std::vector<std::string>{"step.lawson.a.max_rounds=4", "step.1.verbose=true"});
  CHECK(spec.step[0].set_by.empty());
}

// Issue 19, item 6: a plugin that is not found is reported where the file names it, so the
// user knows which entry to fix (PipelineDocument::plugin_location, find_plugins).
TEST_CASE("a missing plugin is reported at its place in the file", "[pipeline_loader]") {
  const std::string text =
      "system: {dimensions: 2, N: 10, packing_fraction: 0.1}\n"
      "run: {steps: 1, dt: 0.01}\n"
      "plugins:\n"
      "  - first\n"
      "  - no_such_model\n"
      "step:\n"
      "  - {stage: fake.integrate}\n";
  auto doc = ff::PipelineDocument::parse_string(text, "p.yaml");
  CHECK(doc.plugin_location(0) == "p.yaml:4:5: plugins[0]");
  CHECK(doc.plugin_location(1) == "p.yaml:5:5: plugins[1]");
  // The flow form, and a name that --set put there.
  auto flow = ff::PipelineDocument::parse_string("system: {N: 10}\nrun: {steps: 1}\nplugins: [a, bb]\nstep: []\n", "f.yaml");
  CHECK(flow.plugin_location(1) == "f.yaml:3:14: plugins[1]");
  auto set = ff::PipelineDocument::parse_string(text, "p.yaml", {"plugins=[zz]"});
  CHECK_THAT(set.plugin_location(0), StartsWith("--set plugins=[zz]: plugins[0]"));
  // find_plugins puts the location before find_plugin's message (which lists the search path).
  const std::vector<std::string> path = {"/nonexistent-plugin-dir"};
  CHECK_THROWS_WITH(ff::find_plugins({"no_such_model"}, path, [&](std::size_t) { return doc.plugin_location(1); }),
                    StartsWith("p.yaml:5:5: plugins[1]: plugin 'no_such_model' not found") &&
                        Contains("/nonexistent-plugin-dir"));
  // Without a location (a caller that has none) the message is find_plugin's own.
  CHECK_THROWS_WITH(ff::find_plugins({"no_such_model"}, path, {}), StartsWith("plugin 'no_such_model' not found"));
  // A file that is no shared library, and one listed twice, are reported at their entry too
  // (before: Boost's dlopen text without a place, and "registered twice" by the same library).
  const std::string dir = "/tmp/ff_plugins_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/libflipflow_plugin_text.so") << "not a library\n";
  std::ofstream(dir + "/libflipflow_plugin_elf.so") << "\x7f" << "ELF and the rest\n";
  CHECK_THROWS_WITH(ff::find_plugins({"text"}, {dir}, [&](std::size_t) { return doc.plugin_location(0); }),
                    StartsWith("p.yaml:4:5: plugins[0]: plugin 'text'") && Contains("is not a shared library"));
  CHECK_THROWS_WITH(ff::find_plugins({"elf", dir + "/libflipflow_plugin_elf.so"}, {dir},
                                     [&](std::size_t i) { return doc.plugin_location(i); }),
                    StartsWith("p.yaml:5:5: plugins[1]: plugin '" + dir + "/libflipflow_plugin_elf.so' is listed twice"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("a log schedule's steps: as round(first·factor^k) one k at a time, also for a factor near 1",
          "[pipeline_loader]") {
  // The reference: every k in turn (what log_steps did before it skipped repeats; a factor of
  // 1 + 1e-10 made `pipeline validate` run for minutes).
  auto one_by_one = [](const ff::Schedule& s, std::uint64_t steps) {
    std::vector<std::uint64_t> out;
    for (long long k = 0;; ++k) {
      const double v = std::round(double(s.first) * std::pow(s.factor, double(k)));
      if (!(v < double(steps))) break;
      if (out.empty() || out.back() != std::uint64_t(v)) out.push_back(std::uint64_t(v));
    }
    if (steps > 0 && (out.empty() || out.back() != steps - 1)) out.push_back(steps - 1);
    return out;
  };
  for (std::uint64_t first : {1u, 3u, 100u})
    for (double factor : {1.0001, 1.01, 1.2, 1.5, 2.0, 10.0})
      for (std::uint64_t steps : {1u, 2u, 50u, 12345u, 2000001u}) {
        ff::Schedule s;
        s.log = true;
        s.first = first;
        s.factor = factor;
        INFO("first " << first << ", factor " << factor << ", steps " << steps);
        CHECK(s.log_steps(steps) == one_by_one(s, steps));
      }
  ff::Schedule near;
  near.log = true;
  near.factor = 1.0000000001;
  const auto steps = near.log_steps(2000);  // every step from 1: 1, 2, ..., 1999
  REQUIRE(steps.size() == 1999);
  CHECK(steps.front() == 1);
  CHECK(steps.back() == 1999);
}

// An audit of the messages a user meets first: each says what was meant, not only what was found.
TEST_CASE("a key and value joined without a space after ':' are named, block and flow", "[pipeline_loader]") {
  // yaml-cpp reports the block case at the next line ("illegal map value"); the hint names the line.
  const std::string block =
      "system:\n  dimensions: 2\n  N:4096\n  packing_fraction: 0.5\nrun: {steps: 10, dt: 0.01}\n"
      "step: [{stage: fake.integrate}]\n";
  CHECK_THAT(error_of_text(block, {}), StartsWith("inline.yaml:4:") && Contains("invalid YAML") &&
                                           Contains("(line 3: 'N:4096' has no space after ':' — write 'N: 4096')"));
  // The last key of a section: no YAML error, a word where a map should be.
  CHECK_THAT(error_of_text("system:\n  N:4096\nrun: {steps: 10, dt: 0.01}\nstep: [{stage: fake.integrate}]\n", {}),
             Contains("system: expected a map of system settings, got 'N:4096' ('N:4096' has no space after ':': "
                      "write 'N: 4096')"));
  // A URL's '//' is not the case.
  CHECK_THAT(error_of_text("system:\n  N: 4\n  http://x\n  dt: 1\n", {}), Contains("invalid YAML") && !Contains("no space"));
  // In a flow map the joined pair is one unknown key.
  const std::string flow = "system: {N: 10, packing_fraction: 0.5}\nrun: {steps: 10, dt: 0.01}\n"
                           "step: [{stage: fake.integrate, D:1.0}]\n";
  CHECK_THAT(error_of_text(flow, {}),
             Contains("step[0] (fake.integrate).D:1.0: unknown parameter; 'D:1.0' looks like 'D: 1.0' with no "
                      "space after ':'"));
}

TEST_CASE("a value from a fixed set, a YAML 1.1 boolean and a too large integer say what was meant",
          "[pipeline_loader]") {
  auto with = [](const std::string& system, const std::string& run, const std::string& step) {
    return "system: {N: 10, packing_fraction: 0.5" + system + "}\nrun: {steps: 10, dt: 0.01" + run + "}\nstep: [" +
           step + "]\n";
  };
  CHECK_THAT(error_of_text(with("", ", precision: doubel", "{stage: fake.integrate}"), {}),
             Contains("run.precision: expected one of: float, double, got 'doubel'; did you mean 'double'?"));
  CHECK_THAT(error_of_text(with("", "", "{stage: fake.integrate, mode: huen}"), {}),
             Contains("(fake.integrate).mode: expected one of: euler, heun, got 'huen'; did you mean 'heun'?"));
  CHECK_THAT(error_of_text(with(", init: runs/start.h5", "", "{stage: fake.integrate}"), {}),
             Contains("system.init: expected one of: random, triangular_lattice_sample, lattice_sample, or a map "
                      "{from, frame}, got 'runs/start.h5'; to start from a file write init: {from: runs/start.h5, "
                      "frame: -1}"));
  CHECK_THAT(error_of_text(with("", "", "{stage: fake.lawson, verbose: no}"), {}),
             Contains("verbose: expected true or false, got 'no' (write false: YAML 1.2 has no yes/no booleans)"));
  CHECK_THAT(error_of_text(with("", "", "{stage: fake.lawson, verbose: on}"), {}), Contains("(write true: "));
  CHECK_THAT(error_of_text(with("", "", "{stage: fake.integrate}"), {"system.N=1e20"}),
             Contains("system.N: expected an integer >= 1, got '1e20' (out of range: the largest integer is "
                      "9223372036854775807)"));
  CHECK_THAT(error_of_text(with("", "", "{stage: fake.integrate}"), {"run.steps=99999999999999999999"}),
             Contains("(out of range: the largest integer is 9223372036854775807)"));
  CHECK_THAT(error_of_text(with("", "", "{stage: fake.integrate}"), {"run.steps=2.5"}), !Contains("out of range"));
  // The largest is the same however it is written: 2^62 in real notation is a whole number.
  CHECK(ff::PipelineDocument::parse_string(with("", "", "{stage: fake.integrate}"), "t.yaml", {"run.steps=4.6e18"})
            .resolve(registry())
            .run.steps == 4600000000000000000ull);
}

TEST_CASE("an unknown stage is matched by case and by its last part; a misspelt 'stage' is named",
          "[pipeline_loader]") {
  auto step = [](const std::string& entry) {
    return "system: {N: 10, packing_fraction: 0.5}\nrun: {steps: 10, dt: 0.01}\nstep: [" + entry + "]\n";
  };
  const std::string lawson = error_of_text(step("{stage: lawson}"), {});
  CHECK_THAT(lawson, Contains("unknown stage 'lawson'; did you mean 'fake.lawson'?") &&
                         !Contains("is its plugin listed"));
  CHECK_THAT(error_of_text(step("{stage: Fake.Lawson}"), {}), Contains("did you mean 'fake.lawson'?"));
  CHECK_THAT(error_of_text(step("{stage: nothing.like.it}"), {}), Contains("is its plugin listed under 'plugins'?"));
  CHECK(error_of_text(step("{sage: fake.lawson}"), {}) ==
        "inline.yaml:3:9: step[0].sage: unknown key 'sage'; did you mean 'stage'?");
  CHECK_THAT(error_of_text(step("{stage: fake.lawson, at: {log: {first: 1, factor: 1.2}, linear: 5}}"), {}),
             Contains("at: expected one schedule, 'log' ({log: {first: 1, factor: 1.2}}), got 'linear' besides 'log'"));
}

TEST_CASE("overrides: step[i] as messages write it, spaces around '=', a step named without a parameter, "
          "and a stage name that two entries share", "[pipeline_loader]") {
  const auto spec = ff::PipelineDocument::parse_string(kMinimal, "m.yaml", {"step[1].max_rounds=4", "run.dt = 0.5"})
                        .resolve(registry());
  CHECK(spec.step[1].params.integer("max_rounds") == 4);
  CHECK(spec.step[1].set_by == std::vector<std::string>{"step.1.max_rounds=4"});
  CHECK(spec.run.dt == Approx(0.5));
  CHECK(error_of_text(kMinimal, {"step.lawson.a=5"}) ==
        "--set step.lawson.a=5: 'lawson.a' is a step; set one of its parameters: step.lawson.a.<param>=5");
  // good.yaml: fake.integrate at step[0] and step[4], neither with an id of its own (fake.lawson's
  // second entry has one, lawson.second, so the bare fake.lawson means step[2] alone).
  const std::string good = path_of("good");
  CHECK(error_of(good, {"step.fake.integrate.D=2"}) ==
        "--set step.fake.integrate.D=2: 'fake.integrate' is ambiguous: 2 entries have that stage (step[0] id "
        "fake.integrate, step[4] id fake.integrate#2); set one by index (step.0.D=2, step.4.D=2) or by id "
        "(step.fake.integrate#2.D=2)");
  const auto by_id = ff::PipelineDocument::parse(good, {"step.fake.integrate#2.D=2", "step.fake.lawson.max_rounds=9"})
                         .resolve(registry());
  CHECK(by_id.step[4].params.real("D") == Approx(2));
  CHECK(by_id.step[2].params.integer("max_rounds") == 9);
}

TEST_CASE("a plugin not found: a built-in stage library is named, a typo gets a suggestion", "[pipeline_loader]") {
  const std::string dir = "/tmp/ff_plugin_names_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/libflipflow_plugin_abp.so") << "x";
  std::ofstream(dir + "/libflipflow_stage_delaunay.so") << "x";
  CHECK_THROWS_WITH(ff::find_plugin("abpp", {dir}), StartsWith("plugin 'abpp' not found; did you mean 'abp'?"));
  CHECK_THROWS_WITH(ff::find_plugin("delaunay", {dir}),
                    StartsWith("plugin 'delaunay' not found: the delaunay.* stages are built in (") &&
                        Contains("remove 'delaunay' from `plugins:`"));
  std::filesystem::remove_all(dir);
}
