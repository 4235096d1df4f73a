// The `pipeline` command end to end: run writes a valid H5MD file, bad input exits 2 with a
// located message, outputs are not overwritten without --force, graph prints DOT.
#include <catch2/catch.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>

#include "support/backends.h"
#include "support/cli.h"
#include "support/h5py.h"

namespace fs = std::filesystem;

namespace {
using ff::test::pipeline_exe;
using ff::test::repo_file;
using ff::test::require_success;

// `pipeline ARGS`, output captured through a per-process log file.
ff::test::CommandResult run(const std::string& args) {
  return ff::test::run_command(pipeline_exe() + " " + args,
                               fs::temp_directory_path() / ("ff_cli_" + std::to_string(::getpid()) + ".log"));
}

fs::path fresh_dir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("ff_cli_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}
}  // namespace

TEST_CASE("pipeline run writes a valid H5MD file; a second run needs --force", "[cli]") {
  const fs::path out = fresh_dir("run");
  const std::string base = "run " + repo_file("pipelines/brownian.yaml").string() +
                           " --device cpu --set run.steps=300 --set system.N=500 --out " + out.string();
  require_success(run(base));
  REQUIRE(fs::exists(out / "trajectory.h5"));
  CHECK_FALSE(fs::exists(out / "trajectory.h5.partial"));
  const std::string check =
      "/usr/bin/python3 -c \"import h5py,sys; f=h5py.File(sys.argv[1],'r'); "
      "assert list(f['h5md'].attrs['version'])==[1,1]; "
      "p=f['particles/all/position']; assert p['value'].shape==(4,500,2), p['value'].shape; "
      "assert list(p['step'][:])==[0,100,200,300]; "
      "assert abs(p['time'][-1]-3.0)<1e-9; "
      "assert f['particles/all/image/value'].shape==(4,500,2); "
      "assert f['particles/all/box/edges'].shape==(2,); "
      "names=[]; f['observables'].visit(names.append); assert any('msd' in n for n in names), names\" " +
      (out / "trajectory.h5").string();
  if (ff::test::can_check_h5md("H5MD layout of the pipeline run")) CHECK(std::system(check.c_str()) == 0);

  auto again = run(base);
  CHECK(again.code == 2);
  CHECK_THAT(again.out, Catch::Contains("exists; use --force"));
  CHECK(run(base + " --force").code == 0);
  fs::remove_all(out);
}

TEST_CASE("pipeline run: a fresh run refuses an earlier run's checkpoints and kept .partial; --force removes them",
          "[cli]") {
  // Before: a fresh run in such a folder pruned its own checkpoints by step against the earlier
  // run's, and a later --resume continued the earlier run's newest (a trajectory with a gap).
  const fs::path out = fresh_dir("earlier");
  const std::string common = "run " + repo_file("pipelines/brownian.yaml").string() +
                             " --device cpu --set system.N=200 --set 'run.checkpoint={every: 100}' --out " + out.string();
  require_success(run(common + " --set run.steps=300"));
  auto names = [&] {
    std::set<std::string> n;
    for (auto& e : fs::directory_iterator(out))
      if (e.path().filename().string().rfind("checkpoint-", 0) == 0) n.insert(e.path().filename().string());
    return n;
  };
  REQUIRE(names() == std::set<std::string>{"checkpoint-000000000200.h5", "checkpoint-000000000300.h5"});
  // As an interrupted run leaves it: the trajectory kept as .partial, its checkpoints.
  fs::rename(out / "trajectory.h5", out / "trajectory.h5.partial");
  auto refused = run(common + " --set run.steps=150");
  INFO(refused.out);
  CHECK(refused.code == 2);
  CHECK_THAT(refused.out, Catch::Contains("holds checkpoints of an earlier run (checkpoint-000000000300.h5 and 1 more)") &&
                              Catch::Contains("--resume"));
  CHECK(names().size() == 2);  // nothing removed without --force
  for (auto& n : names()) fs::remove(out / n);
  auto kept = run(common + " --set run.steps=150");
  INFO(kept.out);
  CHECK(kept.code == 2);
  CHECK_THAT(kept.out, Catch::Contains("trajectory.h5.partial' exists, kept by a run that did not finish"));
  // --force: the earlier checkpoints go, the new run's are all that --resume sees.
  require_success(run(common + " --set run.steps=300 --force"));  // the earlier run again: checkpoints 200, 300
  fs::rename(out / "trajectory.h5", out / "trajectory.h5.partial");
  require_success(run(common + " --set run.steps=150 --force"));
  CHECK(names() == std::set<std::string>{"checkpoint-000000000100.h5", "checkpoint-000000000150.h5"});
  auto resumed = run(common + " --set run.steps=200 --resume");
  INFO(resumed.out);
  CHECK(resumed.code == 0);
  CHECK_THAT(resumed.out, Catch::Contains("at step 150"));
  // The trajectory gone (moved away): the resumed run starts a new file at the checkpoint, warns,
  // and the file records where it starts.
  fs::remove(out / "trajectory.h5");
  auto lost = run(common + " --set run.steps=300 --resume");
  INFO(lost.out);
  CHECK(lost.code == 0);
  CHECK_THAT(lost.out, Catch::Contains("neither") && Catch::Contains("a new file starts at step 200"));
  const std::string starts =
      "/usr/bin/python3 -c \"import h5py,sys; f=h5py.File(sys.argv[1],'r'); a=f['parameters'].attrs; "
      "assert a['first_step'] in ('200', b'200'), a['first_step']; "
      "assert list(f['particles/all/position/step'][:])==[300], list(f['particles/all/position/step'][:])\" " +
      (out / "trajectory.h5").string();
  if (ff::test::can_check_h5md("where a resumed run's new file starts")) CHECK(std::system(starts.c_str()) == 0);
  // Continuing from an older checkpoint of the folder: the newer one is not its past (pruned by
  // step, it would delete the continuation's own). Refused until it is moved away.
  REQUIRE(names() == std::set<std::string>{"checkpoint-000000000200.h5", "checkpoint-000000000300.h5"});
  const std::string older = common + " --resume " + (out / "checkpoint-000000000200.h5").string();
  auto mixed = run(older + " --set run.steps=250");
  INFO(mixed.out);
  CHECK(mixed.code == 2);
  CHECK_THAT(mixed.out, Catch::Contains("holds checkpoints that are not the past of step 200") &&
                            Catch::Contains("checkpoint-000000000300.h5"));
  fs::rename(out / "checkpoint-000000000300.h5", out / "later.h5");
  require_success(run(older + " --set run.steps=250"));
  CHECK(names() == std::set<std::string>{"checkpoint-000000000200.h5", "checkpoint-000000000250.h5"});
  fs::remove_all(out);
}

TEST_CASE("pipeline bench and run refuse counts and sizes that are not whole numbers in range", "[cli]") {
  const std::string bench = "bench " + repo_file("pipelines/brownian.yaml").string() + " --device cpu --results " +
                            fresh_dir("bench_results").string();
  // Before: "64abc" ran N = 64, "2^70" ran N = 64, "-64" wrapped, and --steps -1 ran for ever.
  for (const char* bad : {"64abc", "2^70", "-64", "0", "1e3", "2^", "64,,128"}) {
    auto r = run(bench + " --sizes '" + bad + "' --steps 1");
    INFO("--sizes '" << bad << "': " << r.out);
    CHECK(r.code == 2);
    CHECK_THAT(r.out, Catch::Contains("--sizes") && Catch::Contains("is not a size"));
  }
  for (const char* bad : {"--steps=-1", "--steps=0", "--warmup=-1", "--threads=-3"}) {
    auto r = run(bench + " --sizes 64 " + bad);
    INFO(bad << ": " << r.out);
    CHECK(r.code == 2);
  }
  auto threads = run("run " + repo_file("pipelines/brownian.yaml").string() + " --device cpu --threads -3 --out " +
                     fresh_dir("threads").string());
  INFO(threads.out);
  CHECK(threads.code == 2);
  CHECK_THAT(threads.out, Catch::Contains("--threads must be 0"));
  // Options that did nothing before: a misspelt device for validate, --allow-changes without
  // --resume, an empty --out.
  const std::string file = repo_file("pipelines/brownian.yaml").string();
  for (const std::string& bad : {"validate " + file + " --device bogus", "graph " + file + " --device gpu",
                                 "run " + file + " --device cpu --allow-changes --out " + fresh_dir("allow").string(),
                                 "run " + file + " --device cpu --out ''"}) {
    auto r = run(bad);
    INFO(bad << ": " << r.out);
    CHECK(r.code == 2);
  }
  auto ok = run(bench + " --sizes 64,2^7 --steps 2 --warmup 0");
  INFO(ok.out);
  CHECK(ok.code == 0);
  CHECK_THAT(ok.out, Catch::Contains("\n64 ") && Catch::Contains("\n128 "));
  fs::remove_all(fresh_dir("bench_results"));
}

TEST_CASE("pipeline bench: JSON lines tell runs apart; the terminal names the passes, the observers left out and "
          "the results file",
          "[cli]") {
  // Before: a run with --set run.precision=float wrote the same keys as one without, the terminal
  // spoke of one timed pass, and observers were dropped without a word.
  const fs::path results = fresh_dir("bench_keys");
  const std::string bench = "bench " + repo_file("pipelines/brownian.yaml").string() +
                            " --device cpu --threads 1 --sizes 64 --steps 2 --warmup 1 --results " + results.string();
  auto plain = run(bench);
  INFO(plain.out);
  REQUIRE(plain.code == 0);
  auto floated = run(bench + " --set run.precision=float --set run.seed=7");
  INFO(floated.out);
  REQUIRE(floated.code == 0);
  const fs::path jsonl = results / "brownian-cpu.jsonl";
  CHECK_THAT(plain.out,
             Catch::Contains("double precision: 1 warm-up steps, then three passes of 2 steps per size") &&
                 Catch::Contains("steps/s: pass 1 (back-to-back); median ms, metrics: pass 2 (each step waited for); "
                                 "per stage: pass 3 (profiled)") &&
                 Catch::Contains("observers left out (the compute step is timed): observe.msd, observe.h5md, "
                                 "observe.progress\n") &&
                 Catch::Contains("JSON lines appended to " + jsonl.string() + "\n"));
  CHECK_THAT(floated.out, Catch::Contains("float precision"));

  std::ifstream in(jsonl);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  REQUIRE(lines.size() == 2);
  for (const std::string& line : lines) {
    INFO(line);
    // The keys scripts in bench/ and tools/bench/ read, unchanged.
    for (const char* kept : {"\"N\":64,", "\"steps\":2,", "\"device\":\"1 CPU threads\"", "\"ranks\":1,",
                             "\"median_ms\":", "\"steps_per_s\":", "\"stage_ms\":{", "\"metrics_per_step\":{"})
      CHECK_THAT(line, Catch::Contains(kept));
    CHECK_THAT(line, Catch::Contains("\"threads\":1,") && Catch::Contains("\"warmup\":1,") &&
                         Catch::Contains("\"passes\":[\"back-to-back\",\"each step waited for\",\"profiled\"]") &&
                         Catch::Contains("\"pass\":{\"steps_per_s\":1,\"particle_steps_per_s\":1,\"median_ms\":2,"
                                         "\"mean_ms\":2,\"rollbacks_per_step\":2,\"dt_limits_per_step\":2,"
                                         "\"metrics_per_step\":2,\"stage_ms\":3}"));
    const std::size_t commit = line.find("\"commit\":\"");
    REQUIRE(commit != std::string::npos);
    CHECK(line[commit + 10] != '"');  // a commit (or "unknown"), never empty
  }
  CHECK_THAT(lines[0], Catch::Contains("\"precision\":\"double\"") && Catch::Contains("\"seed\":42,") &&
                           Catch::Contains("\"overrides\":[],"));
  CHECK_THAT(lines[1], Catch::Contains("\"precision\":\"float\"") && Catch::Contains("\"seed\":7,") &&
                           Catch::Contains("\"overrides\":[\"run.precision=float\",\"run.seed=7\"],"));

  // Nothing left out, nothing said.
  const fs::path file = results / "compute-only.yaml";
  std::ofstream(file) << "system: {dimensions: 2, N: 64, packing_fraction: 0.3}\n"
                         "run: {steps: 10, dt: 0.001}\nplugins: [brownian]\n"
                         "step:\n  - {stage: brownian.integrate, D: 1}\n";
  auto bare = run("bench " + file.string() + " --device cpu --steps 1 --warmup 0 --results " + results.string());
  INFO(bare.out);
  CHECK(bare.code == 0);
  CHECK_THAT(bare.out, !Catch::Contains("observers left out") && Catch::Contains("per stage: pass 3"));
  fs::remove_all(results);
}

TEST_CASE("pipeline run: an output that is not a file name is refused at validate; a subfolder is made", "[cli]") {
  CHECK(run("validate " + repo_file("pipelines/brownian.yaml").string() + " --set step.observe.h5md.file=").code == 2);
  for (const char* bad : {".", "..", "sub/", "sub/.."}) {
    auto r = run("validate " + repo_file("pipelines/brownian.yaml").string() + " --set step.observe.h5md.file=" + bad);
    INFO(bad << ": " << r.out);
    CHECK(r.code == 2);
    CHECK_THAT(r.out, Catch::Contains("is not a file name") && Catch::Contains("brownian.yaml:"));
  }
  const fs::path out = fresh_dir("subfolder");
  require_success(run("run " + repo_file("pipelines/brownian.yaml").string() +
                      " --device cpu --set run.steps=10 --set system.N=64 --set step.observe.h5md.file=deep/er/t.h5 --out " +
                      out.string()));
  CHECK(fs::exists(out / "deep" / "er" / "t.h5"));
  fs::remove_all(out);
}

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
                                    "which no stage reads") &&
                        Catch::Contains("No integrator here takes it: overdamped.integrate does"));
  // Listed after overdamped.integrate, whose drift: auto saw no force yet.
  std::ofstream(file) << head << "  - {stage: overdamped.integrate}\n  - {stage: harmonic.forces}\n";
  r = run("validate " + file.string());
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains(":7:5: step 'harmonic.forces' writes field 'force', which no stage reads") &&
                        Catch::Contains("list 'harmonic.forces' first"));
  // In the right order, nothing is said.
  std::ofstream(file) << head << "  - {stage: harmonic.forces}\n  - {stage: overdamped.integrate}\n";
  r = run("validate " + file.string());
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK_THAT(r.out, !Catch::Contains("warning"));
  fs::remove(file);
}

TEST_CASE("pipeline run: a run that rolled back says which stages asked, and when Δt stayed short", "[cli]") {
  // Hard disks at Δt 0.5: particles pass through each other and detect_inversion asks for
  // rollbacks; with dt_grow_after 1000 Δt never grows back within the 40 steps.
  const fs::path out = fresh_dir("rollback_sources");
  auto r = run("run " + repo_file("pipelines/hard-disks.yaml").string() + " --device cpu --out " + out.string() +
               " --set system.N=256 --set run.dt=0.5 --set run.steps=40 --set run.dt_grow_after=1000");
  INFO(r.out);
  REQUIRE(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains("rollbacks: step 'delaunay.detect_inversion' asked for ") &&
                        Catch::Contains("(the last: delaunay.detect_inversion: "));
  CHECK_THAT(r.out, Catch::Contains("warning: the simulated time ") &&
                        Catch::Contains("of the 20 that 40 steps of run.dt = 0.5 make") &&
                        Catch::Contains("run.dt_grow_after = 1000"));
  // Without rollbacks, nothing of the kind.
  auto calm = run("run " + repo_file("pipelines/hard-disks.yaml").string() + " --device cpu --force --out " +
                  out.string() + " --set system.N=256 --set run.steps=20");
  INFO(calm.out);
  REQUIRE(calm.code == 0);
  CHECK_THAT(calm.out, Catch::Contains("rollbacks 0") && !Catch::Contains("asked for") &&
                           !Catch::Contains("warning: the simulated time"));
  fs::remove_all(out);
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

TEST_CASE("pipeline COMMAND --help lists the command's options and exits 0", "[cli]") {
  for (const char* command : {"run", "validate", "graph", "bench", "sweep"}) {
    auto r = run(std::string(command) + " --help");
    INFO(command << ": " << r.out);
    CHECK(r.code == 0);
    CHECK_THAT(r.out, Catch::Contains("--set") && Catch::Contains("--device"));
    // Its usage line, with the file as the positional argument it is (it was listed as --file).
    CHECK_THAT(r.out, Catch::StartsWith(std::string("usage: pipeline ") + command + " FILE.yaml") &&
                          !Catch::Contains("--file"));
  }
  CHECK_THAT(run("sweep --help").out, Catch::Contains("Exit codes") && Catch::Contains("extend"));
  CHECK_THAT(run("bench --help").out,
             Catch::Contains("--results") && Catch::Contains("steps/s come from pass 1 (back-to-back") &&
                 Catch::Contains("median ms and metrics per step from pass 2") &&
                 Catch::Contains("ms per stage from pass 3 (profiled"));
  CHECK_THAT(run("run --help").out, Catch::Contains("--resume"));
  CHECK(run("describe --help").code == 0);
}

TEST_CASE("pipeline describe suggests the stage meant by a typo", "[cli]") {
  auto r = run("describe brownian.integrat");
  INFO(r.out);
  CHECK(r.code == 2);
  CHECK_THAT(r.out, Catch::Contains("unknown stage 'brownian.integrat'; did you mean 'brownian.integrate'?"));
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

TEST_CASE("pipeline describe lists a pair force's fields, though it cannot be configured alone", "[cli]") {
  // A pair force needs neighbors.verlet before it; describe still lists what it reads and writes.
  auto r = run("describe harmonic.forces");
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains("not configured alone") && Catch::Contains("\n    force ") &&
                        Catch::Contains("neighbors.list") && Catch::Contains("(configured alone it says: needs a neighbors.verlet"));
  CHECK_THAT(run("describe observe.progress").out, Catch::Contains("    none"));
}

TEST_CASE("pipeline run: a large system says when its set-up and its triangulation start and end", "[cli]") {
  // Before: 10^6 particles on a CPU were silent for minutes between the command and the first
  // progress line (random placement near jamming, then CGAL's build at the first step).
  const fs::path out = fresh_dir("large");
  auto r = run("run " + repo_file("pipelines/hard-disks.yaml").string() +
               " --set system.N=100000 --set run.steps=1 --device cpu --out " + out.string());
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains("setting up 100000 particles") && Catch::Contains("set up in ") &&
                        Catch::Contains("delaunay: triangulating 100000 points") && Catch::Contains("triangulated in "));
  auto small = run("run " + repo_file("pipelines/hard-disks.yaml").string() +
                   " --set system.N=400 --set run.steps=1 --device cpu --out " + out.string() + " --force");
  CHECK_THAT(small.out, !Catch::Contains("setting up") && !Catch::Contains("triangulating"));
  fs::remove_all(out);
}

TEST_CASE("pipeline run: too few disks in a slab are told in the user's N and box, an input error", "[cli][walls]") {
  // Before: N = 3 gave exit 1 with the doubled box's N = 6 in 64 x 84, and a particle "on a wall".
  const fs::path out = fresh_dir("slab_sparse");
  for (const char* n : {"3", "12"}) {
    auto r = run("run " + repo_file("pipelines/hard-disks-slab-voronoi.yaml").string() + " --set system.N=" + n +
                 " --set run.steps=10 --device cpu --force --out " + out.string());
    INFO(r.out);
    CHECK(r.code == 2);
    CHECK_THAT(r.out, Catch::Contains(std::string("with N = ") + n + " in a 64 x 42 box") &&
                          Catch::Contains("use N >= ") && !Catch::Contains("84") && !Catch::Contains("on a wall"));
  }
  fs::remove_all(out);
}

TEST_CASE("pipeline run: two steps writing one file are refused, naming both", "[cli]") {
  auto r = run("validate " + repo_file("pipelines/hard-disks.yaml").string() + " --set step.observe.gr.file=trajectory.h5");
  INFO(r.out);
  CHECK(r.code == 2);
  CHECK_THAT(r.out, Catch::Contains("writes 'trajectory.h5', which step 'observe.gr'") &&
                        Catch::Contains("give one of them another file name"));
  // A file outside the output folder: allowed, with a warning (a sweep's runs would share it).
  for (const char* file : {"../gr.csv", "/tmp/ff_gr.csv"}) {
    auto outside = run("validate " + repo_file("pipelines/hard-disks.yaml").string() + " --set step.observe.gr.file=" + file);
    INFO(outside.out);
    CHECK(outside.code == 0);
    CHECK_THAT(outside.out, Catch::Contains(std::string("warning: ")) &&
                                Catch::Contains(std::string("step 'observe.gr' writes '") + file + "', outside the output folder"));
  }
  CHECK_THAT(run("validate " + repo_file("pipelines/hard-disks.yaml").string()).out, !Catch::Contains("outside the output folder"));
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

TEST_CASE("pipeline graph prints DOT; stages and describe list the stages", "[cli]") {
  auto g = run("graph " + repo_file("pipelines/bench-noop-fork.yaml").string());
  CHECK(g.code == 0);
  CHECK_THAT(g.out, Catch::StartsWith("digraph step {") && Catch::Contains("n0 -> n2;"));
  auto s = run("stages");
  CHECK(s.code == 0);
  CHECK_THAT(s.out, Catch::Contains("brownian.integrate") && Catch::Contains("observe.h5md"));
  auto d = run("describe brownian.integrate");
  CHECK(d.code == 0);
  CHECK_THAT(d.out, Catch::Contains("position") && Catch::Contains("readwrite"));
  CHECK(run("describe no.such.stage").code == 2);
  CHECK(run("frobnicate").code == 2);
}

TEST_CASE("--device cuda without a GPU is an input error, not a silent CPU run", "[cli]") {
  if (ff::cuda_device_available()) {
    SUCCEED("a GPU is present");
    return;
  }
  const fs::path out = fresh_dir("nocuda");
  auto rr = run("run " + repo_file("pipelines/brownian.yaml").string() + " --device cuda --out " + out.string());
  CHECK(rr.code == 2);
  CHECK_THAT(rr.out, Catch::Contains("--device cuda"));
  CHECK_FALSE(fs::exists(out));
}
