// `pipeline validate` end to end: what it refuses (exit 2, a message naming the file, line and
// key) and what it warns of (exit 0, a warning that says why), one case per mistake.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>

#include "support/cli.h"

namespace fs = std::filesystem;

namespace {
using ff::test::pipeline_exe;
using ff::test::repo_file;

// `pipeline ARGS`, output captured through a per-process log file.
ff::test::CommandResult run(const std::string& args) {
  return ff::test::run_command(pipeline_exe() + " " + args,
                               fs::temp_directory_path() / ("ff_cli_validate_" + std::to_string(::getpid()) + ".log"));
}

fs::path fresh_dir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("ff_cli_validate_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}
}  // namespace

TEST_CASE("pipeline validate: Delaunay stages without the stage they follow are refused, naming it", "[cli]") {
  // Before: flip and lawson made the topology fields themselves, so integrate, flip, lawson was
  // valid and ran with inverted triangles left unrepaired (delaunay.check found them).
  const fs::path file = fresh_dir("order.yaml");
  auto refused = [&](const std::string& steps) {
    std::ofstream(file) << "system: {dimensions: 2, N: 256, packing_fraction: 0.5}\n"
                           "run: {steps: 10, dt: 0.001}\nplugins: [brownian]\n"
                           "step:\n  - {stage: brownian.integrate, D: 1}\n" << steps;
    auto r = run("validate " + file.string());
    INFO(steps << r.out);
    CHECK(r.code == 2);
    return r.out;
  };
  CHECK_THAT(refused("  - {stage: delaunay.flip}\n  - {stage: delaunay.lawson}\n"),
             Catch::Contains(file.filename().string() + ":6:") &&
                 Catch::Contains("step 'delaunay.flip' (delaunay.flip) needs delaunay.detect_inversion earlier"));
  CHECK_THAT(refused("  - {stage: delaunay.detect_inversion}\n  - {stage: delaunay.lawson}\n"),
             Catch::Contains("(delaunay.lawson) needs delaunay.flip or delaunay.build earlier"));
  fs::remove(file);
}

TEST_CASE("pipeline validate: a stage that moves the particles, listed twice alike, draws a warning", "[cli]") {
  // Before: a copied integrator line ran silently, moving every particle twice a step.
  const fs::path file = fresh_dir("twice.yaml");
  auto validate = [&](const std::string& steps) {
    std::ofstream(file) << "system: {dimensions: 2, N: 256, packing_fraction: 0.3}\n"
                           "run: {steps: 10, dt: 0.001}\nplugins: [brownian]\nstep:\n" << steps;
    auto r = run("validate " + file.string());
    INFO(steps << r.out);
    CHECK(r.code == 0);
    return r.out;
  };
  const std::string once = "  - {stage: brownian.integrate, D: 1}\n";
  const std::string warned = validate(once + "  - {stage: observe.msd}\n" + once);
  CHECK_THAT(warned, Catch::Contains("warning: " + file.string() + ":7:") &&  // the second entry's line
                         Catch::Contains("step 'brownian.integrate#2' repeats step 'brownian.integrate' (line 5)") &&
                         Catch::Contains("give this one an `id`"));
  // Meant (its own id), or different parameters: silent.
  CHECK_THAT(validate(once + "  - {stage: brownian.integrate, D: 1, id: second_half}\n"),
             !Catch::Contains("warning"));
  CHECK_THAT(validate(once + "  - {stage: brownian.integrate, D: 2}\n"), !Catch::Contains("warning"));
  fs::remove(file);
}

TEST_CASE("pipeline validate: stages whose walls differ are refused, naming both entries", "[cli][walls]") {
  // Before: exit 0, voronoi.mirror_observer clipping at y while the disks crossed y periodically.
  const std::string slab = repo_file("pipelines/hard-disks-slab-voronoi.yaml").string();
  for (const char* w : {"x", "none"}) {
    auto r = run(std::string("validate ") + slab + " --set step.overlap_correct.walls=" + w);
    INFO(r.out);
    CHECK(r.code == 2);
    CHECK_THAT(r.out, Catch::Contains("hard-disks-slab-voronoi.yaml:32:5: step 'voronoi.mirror_observer' has walls: y") &&
                          Catch::Contains("step 'overlap_correct' (" + slab + ":31:5") &&
                          Catch::Contains(std::string("has walls: ") + w));
  }
  // voronoi.mirror's default (y) counts: walls: x on the correction alone is refused too.
  const fs::path file = fresh_dir("walls_default.yaml");
  std::ofstream(file) << "system: {dimensions: 2, N: 256, packing_fraction: 0.3}\nrun: {steps: 10, dt: 0.0003}\n"
                         "plugins: [brownian]\nstep:\n  - {stage: brownian.integrate, D: 1}\n"
                         "  - {stage: delaunay.detect_inversion}\n  - {stage: delaunay.flip}\n"
                         "  - {stage: delaunay.lawson}\n  - {stage: overlap_correct, walls: x}\n"
                         "  - {stage: voronoi.mirror}\n";
  auto r = run("validate " + file.string());
  INFO(r.out);
  CHECK(r.code == 2);
  CHECK_THAT(r.out, Catch::Contains(":10:5: step 'voronoi.mirror' has walls: y, but step 'overlap_correct'"));
  fs::remove(file);
  // The same walls everywhere: valid, nothing said about them.
  r = run("validate " + slab);
  CHECK(r.code == 0);
  CHECK_THAT(r.out, !Catch::Contains("warning"));
}

TEST_CASE("pipeline validate: voronoi.geometry in a pipeline with walls draws a warning", "[cli][walls]") {
  const std::string hd = repo_file("pipelines/voronoi-hard-disks.yaml").string();
  auto r = run("validate " + hd + " --set step.overlap_correct.walls=y");
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains("warning: " + hd + ":32:5: step 'voronoi.geometry' (voronoi.geometry) makes the "
                                    "cells of the periodic box") &&
                        Catch::Contains("{stage: voronoi.mirror, walls: y}"));
  r = run("validate " + hd);
  CHECK(r.code == 0);
  CHECK_THAT(r.out, !Catch::Contains("warning"));
}

TEST_CASE("pipeline validate: voronoi cells written on a schedule their maker skips draw a warning", "[cli][walls]") {
  // Before: observe.h5md every 500 wrote the step-0 cells at step 500, silently.
  const std::string slab = repo_file("pipelines/hard-disks-slab-voronoi.yaml").string();
  auto r = run("validate " + slab + " --set step.observe.h5md.every=500");
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains("warning: " + slab + ":33:5 (with --set step.observe.h5md.every=500): step "
                                    "'observe.h5md' (every 500) reads field 'voronoi.area', which step "
                                    "'voronoi.mirror_observer' (" + slab + ":32:5) writes every 1000"));
  // A multiple of the maker's schedule sees fresh cells in every frame: nothing said.
  r = run("validate " + slab + " --set step.observe.h5md.every=2000");
  CHECK(r.code == 0);
  CHECK_THAT(r.out, !Catch::Contains("warning"));
}

TEST_CASE("pipeline validate: a force that no stage reads draws a warning that says why", "[cli]") {
  // A pair force before abp.integrate, which takes no force: valid, but the force does nothing.
  const fs::path file = fresh_dir("unread_force.yaml");
  const std::string head = "system: {dimensions: 2, N: 256, packing_fraction: 0.3}\nrun: {steps: 10, dt: 0.001}\n"
                           "plugins: [harmonic, abp]\nstep:\n  - {stage: neighbors.verlet, cutoff: 1.0, skin: 0.3}\n";
  std::ofstream(file) << head << "  - {stage: harmonic.forces}\n  - {stage: abp.integrate}\n";
  auto r = run("validate " + file.string());
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains("warning: " + file.string() + ":6:5: step 'harmonic.forces' writes field 'force', "
                                    "which no compute stage reads") &&
                        Catch::Contains("No integrator here takes it: overdamped.integrate does"));
  // Listed after overdamped.integrate, whose drift: auto saw no force yet.
  std::ofstream(file) << head << "  - {stage: overdamped.integrate}\n  - {stage: harmonic.forces}\n";
  r = run("validate " + file.string());
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains(":7:5: step 'harmonic.forces' writes field 'force', which no compute stage reads") &&
                        Catch::Contains("list 'harmonic.forces' first"));
  // An observer that records the force (observe.h5md's fields) does not use it: still said (before,
  // its read silenced the warning, and a trap before brownian.integrate moved nothing unnoticed).
  std::ofstream(file) << head << "  - {stage: harmonic.forces}\n  - {stage: abp.integrate}\n"
                      << "  - {stage: observe.h5md, every: 5, fields: [position, force]}\n";
  r = run("validate " + file.string());
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains(":6:5: step 'harmonic.forces' writes field 'force', which no compute stage reads "
                                    "(observers only record it)"));
  // In the right order, nothing is said.
  std::ofstream(file) << head << "  - {stage: harmonic.forces}\n  - {stage: overdamped.integrate}\n";
  r = run("validate " + file.string());
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK_THAT(r.out, !Catch::Contains("warning"));
  fs::remove(file);
}

TEST_CASE("pipeline validate: a 2D pipeline made 3D is told what excludes volume in 3D", "[cli]") {
  auto r = run("validate " + repo_file("pipelines/abp.yaml").string() + " --set system.dimensions=3");
  INFO(r.out);
  CHECK(r.code == 2);
  CHECK_THAT(r.out, Catch::Contains("supports dimensions 2 only") &&
                        Catch::Contains("neighbors.verlet + overlap_correct.verlet, as in pipelines/hard-spheres.yaml"));
  // (other stages' messages are unchanged: test_pipeline_loader's bad_dimensions case)
}

TEST_CASE("pipeline validate: the initial state's errors name the file's line of `init`", "[cli]") {
  const fs::path file = fresh_dir("init.yaml");
  auto message = [&](const std::string& system) {
    std::ofstream(file) << "system: " << system << "\nrun: {steps: 2, dt: 0.01}\nplugins: [brownian]\n"
                        << "step:\n  - {stage: brownian.integrate, D: 1}\n";
    auto r = run("validate " + file.string());
    INFO(system << ": " << r.out);
    CHECK(r.code == 2);
    return r.out;
  };
  const std::string name = file.filename().string();
  // A box too small for N: located, and no advice that cannot help.
  const std::string box = message("{dimensions: 2, N: 64, box: [0.1, 0.1]}");
  CHECK_THAT(box, Catch::Contains(name + ":1:9: system.init: random") && Catch::Contains("No packing") &&
                      !Catch::Contains("triangular_lattice_sample"));
  // A missing start file: at the `init` key, saying where a relative path is read from.
  const std::string from = message("{dimensions: 2, N: 64, packing_fraction: 0.3, init: {from: no_such.h5}}");
  CHECK_THAT(from, Catch::Contains(name + ":1:55: system.init.from: the file 'no_such.h5' does not exist") &&
                       Catch::Contains("a relative path is read from the directory the command runs in"));
  // A --set that made the system impossible is named beside the place of `init`.
  std::ofstream(file) << "system: {dimensions: 2, N: 64, packing_fraction: 0.3}\nrun: {steps: 2, dt: 0.01}\n"
                      << "plugins: [brownian]\nstep:\n  - {stage: brownian.integrate, D: 1}\n";
  auto dense = run("validate " + file.string() + " --set system.packing_fraction=0.95");
  INFO(dense.out);
  CHECK(dense.code == 2);
  CHECK_THAT(dense.out, Catch::Contains(name + ":1:9 (with --set system.packing_fraction=0.95): system.init: random"));
  fs::remove(file);
}

TEST_CASE("pipeline validate: a stage's error about a --set value names the --set", "[cli]") {
  auto r = run("validate " + repo_file("pipelines/brownian.yaml").string() +
               " --set 'step.observe.h5md.fields=[position, velocityy]'");
  INFO(r.out);
  CHECK(r.code == 2);
  CHECK_THAT(r.out, Catch::Contains("step 'observe.h5md' (with --set step.observe.h5md.fields=[position, velocityy]):") &&
                        Catch::Contains("no field 'velocityy'"));
}

TEST_CASE("pipeline validate: a misspelt field, plugin or --set form says what was meant", "[cli]") {
  const std::string file = repo_file("pipelines/brownian.yaml").string();
  auto field = run("validate " + file + " --set 'step.observe.h5md.fields=[positon, image]'");
  INFO(field.out);
  CHECK(field.code == 2);
  CHECK_THAT(field.out, Catch::Contains("no field 'positon' to write; did you mean 'position'? (fields available: "));
  auto plugin = run("validate " + file + " --set 'plugins=[brownain]'");
  INFO(plugin.out);
  CHECK(plugin.code == 2);
  CHECK_THAT(plugin.out, Catch::Contains("plugins[0]: plugin 'brownain' not found; did you mean 'brownian'?"));
  auto builtin = run("validate " + file + " --set 'plugins=[brownian, delaunay]'");
  INFO(builtin.out);
  CHECK(builtin.code == 2);
  CHECK_THAT(builtin.out, Catch::Contains("plugins[1]: plugin 'delaunay' not found: the delaunay.* stages are built in") &&
                              Catch::Contains("remove 'delaunay' from `plugins:`"));
  // "--set KEY VALUE": the value is left over as a second file.
  auto spaced = run("validate " + file + " --set run.steps 100");
  INFO(spaced.out);
  CHECK(spaced.code == 2);
  CHECK_THAT(spaced.out, Catch::Contains("'100' is an extra argument; did you mean --set run.steps=100?"));
  CHECK_THAT(run("validate --set run.steps 100 " + file).out,
             Catch::Contains("'100' is an extra argument; did you mean --set run.steps=100?"));
  auto second = run("validate " + file + " --device cpu other.yaml");
  CHECK_THAT(second.out, Catch::Contains("'other.yaml' is an extra argument: the command takes one pipeline file"));
}

TEST_CASE("pipeline validate: a stage of a plugin on the path but not listed names the plugin to list", "[cli]") {
  const fs::path file = fresh_dir("unlisted.yaml");
  std::ofstream(file) << "system: {dimensions: 2, N: 256, packing_fraction: 0.5}\nrun: {steps: 10, dt: 0.001}\n"
                         "plugins: [brownian]\nstep:\n  - {stage: neighbors.verlet, cutoff: 1.0, skin: 0.3}\n"
                         "  - {stage: harmonic.forces}\n  - {stage: overdamped.integrate}\n";
  auto r = run("validate " + file.string());
  INFO(r.out);
  CHECK(r.code == 2);
  CHECK_THAT(r.out, Catch::Contains(file.filename().string() + ":6:") &&
                        Catch::Contains("plugin 'harmonic' is on the plugin path but not in this pipeline's "
                                        "`plugins:` list: add 'harmonic' to it"));
  fs::remove(file);
}

TEST_CASE("pipeline validate: good file exits 0, broken file exits 2 with file:line:column", "[cli]") {
  auto good = run("validate " + repo_file("pipelines/brownian.yaml").string());
  INFO(good.out);
  CHECK(good.code == 0);
  CHECK_THAT(good.out, Catch::Contains("valid") && Catch::Contains("brownian.integrate"));

  const fs::path bad = fs::temp_directory_path() / ("ff_bad_" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(bad) << "system: {dimensions: 2, N: 100, packing_fraction: 0.3}\n"
                        "run: {steps: 10, dt: -0.1}\n"
                        "step:\n  - {stage: core.noop}\n";
  auto r = run("validate " + bad.string());
  INFO(r.out);
  CHECK(r.code == 2);
  CHECK_THAT(r.out, Catch::Contains(bad.string() + ":2:") && Catch::Contains("run.dt"));

  // Three mistakes in three places: three error lines, each located, in one go.
  std::ofstream(bad) << "system: {dimensions: 2, N: 100, packing_fraction: 0.3}\n"
                        "run: {steps: 10, dt: -0.1}\n"
                        "step:\n  - {stage: core.noop, evry: 2}\n  - {stage: core.nop}\n";
  auto three = run("validate " + bad.string());
  INFO(three.out);
  CHECK(three.code == 2);
  CHECK_THAT(three.out, Catch::Contains("error: " + bad.string() + ":2:22: run.dt: expected a real number > 0") &&
                            Catch::Contains("error: " + bad.string() + ":5:13: step[1].stage: unknown stage 'core.nop'") &&
                            Catch::Contains("error: " + bad.string() + ":4:24: step[0] (core.noop).evry: unknown parameter"));
  fs::remove(bad);
}
