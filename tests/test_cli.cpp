// The `pipeline` command end to end: run writes a valid H5MD file, bad input exits 2 with a
// located message, outputs are not overwritten without --force, graph prints DOT.
#include <catch2/catch.hpp>
#include <cmath>
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
                         Catch::Contains("\"pass\":{\"steps_per_s\":1,\"particle_steps_per_s\":1,\"host_own_ms\":1,"
                                         "\"median_ms\":2,\"mean_ms\":2,\"rollbacks_per_step\":2,\"dt_limits_per_step\":2,"
                                         "\"metrics_per_step\":2,\"stage_ms\":3,\"stage_host_ms\":1}"));
    // The host's own time a step (pass 1's wall time less its waits for a device): on the CPU
    // nothing waits, so it is the whole step, 1000 / steps_per_s ms.
    auto number = [&](const std::string& key) {
      const std::size_t at = line.find("\"" + key + "\":");
      REQUIRE(at != std::string::npos);
      return std::stod(line.substr(at + key.size() + 3));
    };
    const double own = number("host_own_ms"), period = 1e3 / number("steps_per_s");
    CHECK(own > 0);
    CHECK(std::abs(own - period) <= 1e-4 * period);
    // Each stage's share of it (its acquires, run() and decide()): a part of the step's.
    const std::size_t map = line.find("\"stage_host_ms\":{");
    REQUIRE(map != std::string::npos);
    const std::string stages = line.substr(map, line.find('}', map) - map);
    double in_stages = 0;
    int count = 0;
    for (std::size_t at = stages.find("\":", 17); at != std::string::npos; at = stages.find("\":", at + 2)) {
      in_stages += std::stod(stages.substr(at + 2));
      ++count;
    }
    CHECK(count == 1);  // brownian.integrate, the one compute stage
    CHECK(in_stages > 0);
    CHECK(in_stages <= own * (1 + 1e-6));
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
                          Catch::Contains("use N >= ") && !Catch::Contains("x 84") && !Catch::Contains("on a wall"));
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
