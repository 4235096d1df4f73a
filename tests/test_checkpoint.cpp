// Checkpoints and --resume end to end (the `pipeline` command): a run of 2n steps equals n steps
// + --resume + n steps in every dataset of its H5MD file (and its CSV files), for ABP, hard
// disks with rollbacks in the second half, the phoretic short-range model (a Verlet list) and a
// pipeline of `every:` observers (runs stopped by signals, killed or failed:
// test_checkpoint_signals.cpp); a continuation that takes the run's own --set arguments; and the refusals (changed N, changed stages, changed
// parameters without --allow-changes, a corrupt and a truncated checkpoint), each exit 2, with
// the previous checkpoint still resuming (a corrupt or truncated newest one in the folder is
// skipped).
//
// Runs on the CPU; FLIPFLOW_TEST_DEVICE=cuda runs the same on the GPU (skipped without one).
#include <catch2/catch.hpp>
#include <hdf5.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "core/backend/device.h"
#include "support/cli.h"
#include "support/checkpoint_runs.h"
#include "support/h5md_files.h"

namespace fs = std::filesystem;

using namespace ff::test;
using namespace ff::test::checkpoint_runs;

TEST_CASE("checkpoint continuation: ABP, n + resume + n steps equal 2n steps in every H5MD dataset", "[checkpoint]") {
  if (!device_available()) return;
  check_continuation(abp_case(), 60, "abp");
}

TEST_CASE("checkpoint continuation: --resume takes the run's own --set arguments, so it gives only what changes",
          "[checkpoint]") {
  // Before: a run made with --set system.N=400 was refused on --resume without that --set again
  // ("the pipeline's structure differs"), with advice to start a new run from a frame.
  if (!device_available()) return;
  Case c = abp_case();
  c.sets.back() = "run.checkpoint={every: 25,\n keep: 2}";  // a value over two lines is recorded and taken whole
  const std::uint64_t n = 60;
  const fs::path one = fresh_dir("inherit_one"), two = fresh_dir("inherit_two");
  require_success(pipeline(run_args(c, one, 2 * n)));
  require_success(pipeline(run_args(c, two, n)));
  auto resumed = require_success(pipeline("run " + c.file + " --set run.steps=" + std::to_string(2 * n) + " --out " +
                                          two.string() + " --resume"));
  CHECK_THAT(resumed.out, Catch::Contains("resuming") && Catch::Contains("N = 400"));
  CHECK(require_same_h5md(one / c.h5, two / c.h5) >= 4);
  // Its checkpoints record the sets it ran with (the earlier run's, then its own), once each.
  const std::vector<fs::path> written = checkpoints(two);
  REQUIRE(!written.empty());
  const std::string sets = text_dataset(written.back(), "pipeline/overrides");
  INFO(written.back().string() << " pipeline/overrides: " << sets);
  CHECK_THAT(sets, Catch::Contains("system.N=400") && Catch::Contains("run.steps=" + std::to_string(2 * n)));
  std::size_t steps_sets = 0;
  for (std::size_t at = sets.find("run.steps="); at != std::string::npos; at = sets.find("run.steps=", at + 1)) ++steps_sets;
  CHECK(steps_sets == 1);
  // A second continuation inherits from the first's checkpoint in turn.
  auto again = require_success(pipeline("run " + c.file + " --set run.steps=" + std::to_string(3 * n) + " --out " +
                                        two.string() + " --resume"));
  CHECK_THAT(again.out, Catch::Contains("N = 400"));
  fs::remove_all(one);
  fs::remove_all(two);
  // A file valid only with the run's --set (D: -1 refused): the continuation's own load waits for
  // the checkpoint's sets (before: refused at the first load, naming D).
  const fs::path dir = fresh_dir("inherit_fix");
  fs::create_directories(dir);
  std::ofstream(dir / "fix.yaml") << "system: {dimensions: 2, N: 100, packing_fraction: 0.2, init: random}\n"
                                     "run: {steps: 20, dt: 0.001, checkpoint: {every: 10}}\nplugins: [brownian]\n"
                                     "step:\n  - {stage: brownian.integrate, D: -1}\n"
                                     "  - {stage: observe.h5md, every: 10, file: t.h5, fields: [position]}\n";
  const std::string file = (dir / "fix.yaml").string(), out = (dir / "out").string();
  require_success(pipeline("run " + file + " --set step.brownian.integrate.D=1 --out " + out));
  CHECK(pipeline("run " + file + " --set run.steps=40 --out " + (dir / "fresh").string()).code == 2);
  require_success(pipeline("run " + file + " --set run.steps=40 --resume --out " + out));
  fs::remove_all(dir);
}

TEST_CASE("checkpoint continuation: hard disks with rollbacks in the second half, and g(r)", "[checkpoint]") {
  if (!device_available()) return;
  // Δt = 0.05 at η = 0.5 makes detect_inversion ask for a rollback every few steps (19 in 120),
  // and Δt regrowing after 5 good steps keeps the controller's streak in play at the checkpoint.
  Case c{repo_file("pipelines/hard-disks.yaml").string(),
         {"system.N=400", "run.dt=0.05", "run.dt_grow_after=5", "step.observe.gr.from_step=0",
          "step.observe.gr.every=5",
          "step.observe.h5md.every=10",
          "step.observe.progress.every=1000", "run.checkpoint={every: 30}"},
         "trajectory.h5",
         {"gr.csv"}};
  const std::uint64_t n = 60;
  check_continuation(c, n, "hard_disks");
  // The rollbacks the test relies on: some in the second half (their count grows after step n).
  const fs::path out = fresh_dir("hard_disks_rollbacks");
  require_success(pipeline(run_args(c, out, 2 * n)));
  const double at_n = observable_at(out / c.h5, "rollbacks", std::int64_t(n));
  const double at_end = last_observable(out / c.h5, "rollbacks");
  INFO("rollbacks at step " << n << ": " << at_n << ", at the end: " << at_end);
  CHECK(at_end > at_n);
  // Scratch fields (detect_inversion's Lawson candidates: rewritten every step before they are
  // read, their contents between steps left in thread order) are not in a checkpoint, so two
  // identical runs write the same fields; the carried state is.
  const std::vector<fs::path> written = checkpoints(out);
  REQUIRE(!written.empty());
  const hid_t file = H5Fopen(written.back().string().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(H5Lexists(file, "/fields", H5P_DEFAULT) > 0);
  CHECK(H5Lexists(file, "/fields/position", H5P_DEFAULT) > 0);
  CHECK(H5Lexists(file, "/fields/delaunay.halfedge", H5P_DEFAULT) > 0);
  CHECK(H5Lexists(file, "/fields/delaunay.lawson_candidates", H5P_DEFAULT) == 0);
  H5Fclose(file);
  fs::remove_all(out);
}

TEST_CASE("checkpoint continuation: phoretic short range (a Verlet list carried across)", "[checkpoint]") {
  if (!device_available()) return;
  Case c{repo_file("pipelines/phoretic-c0-short.yaml").string(),
         {"system.N=400", "step.observe.h5md.every=10", "step.observe.progress.every=1000",
          "run.checkpoint={every: 50}"},
         "phoretic-c0-short.h5",
         {}};
  check_continuation(c, 50, "phoretic");
}

TEST_CASE("checkpoint continuation: 3D hard spheres (Verlet list rebuilt inside overlap_correct.verlet)",
          "[checkpoint]") {
  if (!device_available()) return;
  Case c{repo_file("pipelines/hard-spheres.yaml").string(),
         {"system.N=1000", "run.dt=0.001", "step.observe.gr.from_step=0", "step.observe.h5md.every=10",
          "step.observe.progress.every=1000", "run.checkpoint={every: 40}"},
         "trajectory.h5",
         {"gr.csv"}};
  check_continuation(c, 50, "hard_spheres");
}

TEST_CASE("checkpoint continuation: observers on `every:` schedules the checkpoint falls between", "[checkpoint]") {
  if (!device_available()) return;
  const fs::path dir = fresh_dir("every_pipeline");
  const fs::path file = dir / "every.yaml";
  std::ofstream(file) << R"(system: {dimensions: 2, N: 300, packing_fraction: 0.3, init: random}
run: {steps: 100, dt: 0.001, seed: 7, checkpoint: {every: 13, keep: 3}}
plugins: [brownian]
step:
  - {stage: delaunay.sort}
  - {stage: brownian.integrate, D: 1.0}
  - {stage: delaunay.detect_inversion}
  - {stage: delaunay.flip}
  - {stage: delaunay.lawson}
  - {stage: overlap_correct}
  - {stage: observe.msd, every: 3}
  - {stage: observe.gr, every: 5, r_max: 3.0, bins: 60}
  - {stage: observe.clusters, every: 7, bond: 1.2}
  - {stage: observe.clusters, id: sizes_long, every: 6, bond: 1.2, file: clusters_long.csv,
     sizes_file: cluster_sizes_long.csv, sizes_layout: long}
  - {stage: observe.h5md, every: 4, file: every.h5, fields: [position, image]}
)";
  check_continuation(Case{file.string(), {}, "every.h5",
                          {"gr.csv", "clusters.csv", "cluster_sizes.csv", "cluster_sizes_long.csv"}},
                     50, "every");
  fs::remove_all(dir);
}

TEST_CASE("checkpoint: refusals exit 2 naming the difference; the previous checkpoint still resumes",
          "[checkpoint]") {
  if (!device_available()) return;
  Case c = abp_case();
  c.sets.back() = "run.checkpoint={every: 20, keep: 2}";
  const fs::path ref = fresh_dir("refuse_ref"), out = fresh_dir("refuse");
  require_success(pipeline(run_args(c, ref, 80)));
  require_success(pipeline(run_args(c, out, 40)));
  const auto files = checkpoints(out);
  REQUIRE(files.size() == 2);  // steps 20 and 40: keep 2
  CHECK(files[1].filename() == "checkpoint-000000000040.h5");

  // A structural change: N.
  auto n = pipeline(run_args(c, out, 80) + " --set system.N=401 --resume");
  CHECK(n.code == 2);
  CHECK_THAT(n.out, Catch::Contains("system.N: the checkpoint has 400, the pipeline 401"));

  // A structural change: the stage list.
  const fs::path extra = out / "extra-stage.yaml";
  {
    std::string text = file_text(c.file);
    const std::string msd = "  - {stage: observe.msd, every: 100}\n";
    REQUIRE(text.find(msd) != std::string::npos);
    text.replace(text.find(msd), msd.size(), msd + "  - {stage: observe.msd, id: msd2, every: 100}\n");
    std::ofstream(extra) << text;
  }
  Case changed = c;
  changed.file = extra.string();
  auto stages = pipeline(run_args(changed, out, 80) + " --resume");
  CHECK(stages.code == 2);
  CHECK_THAT(stages.out, Catch::Contains("stages: the checkpoint has 9, the pipeline 10"));
  CHECK_THAT(stages.out, Catch::Contains("structure differs"));

  // A parameter change needs --allow-changes.
  auto param = pipeline(run_args(c, out, 80) + " --set step.abp.integrate.v0=2 --resume");
  CHECK(param.code == 2);
  CHECK_THAT(param.out, Catch::Contains("step.abp.integrate.v0: 1 -> 2"));
  CHECK_THAT(param.out, Catch::Contains("--allow-changes"));

  // A corrupt checkpoint: one value changed, the checksum no longer matches.
  const fs::path saved = out / "saved.h5";
  fs::copy_file(files[1], saved);
  {
    hid_t f = H5Fopen(files[1].c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    REQUIRE(f >= 0);
    hid_t d = H5Dopen2(f, "clock/time", H5P_DEFAULT);
    const double t = 123.0;
    REQUIRE(H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, &t) >= 0);
    H5Dclose(d);
    H5Fclose(f);
  }
  auto corrupt = pipeline(run_args(c, out, 80) + " --resume " + files[1].string());
  CHECK(corrupt.code == 2);
  CHECK_THAT(corrupt.out, Catch::Contains("fails its checksum"));

  // A truncated checkpoint.
  fs::copy_file(saved, out / "truncated.h5");
  fs::resize_file(out / "truncated.h5", fs::file_size(saved) / 2);
  auto truncated = pipeline(run_args(c, out, 80) + " --resume " + (out / "truncated.h5").string());
  CHECK(truncated.code == 2);
  CHECK_THAT(truncated.out, Catch::Contains("truncated"));
  fs::remove(out / "truncated.h5");
  fs::remove(saved);

  // The directory: the corrupt newest is skipped with a warning, the one before resumes, and
  // the result is still the uninterrupted run's (frames after step 20 are dropped and redone).
  auto resumed = require_success(pipeline(run_args(c, out, 80) + " --resume"));
  CHECK_THAT(resumed.out, Catch::Contains("fails its checksum"));
  CHECK_THAT(resumed.out, Catch::Contains("at step 20"));
  require_same_h5md(ref / c.h5, out / c.h5);

  // A truncated newest checkpoint in the directory (a crash while the disk filled up, a copy cut
  // short): skipped with a warning like the corrupt one, the one before it resumes, same files.
  {
    const auto now = checkpoints(out);
    REQUIRE(now.size() == 2);  // steps 60 and 80, written by the run that just finished
    REQUIRE(now[1].filename() == "checkpoint-000000000080.h5");
    fs::resize_file(now[1], fs::file_size(now[1]) * 2 / 3);
    auto again = require_success(pipeline(run_args(c, out, 80) + " --resume"));
    CHECK_THAT(again.out, Catch::Contains("truncated"));
    CHECK_THAT(again.out, Catch::Contains("at step 60"));
    CHECK(fs::exists(out / "checkpoint-000000000080.h5.invalid"));
    require_same_h5md(ref / c.h5, out / c.h5);
  }

  // Extending the finished run with a changed parameter: allowed with --allow-changes, recorded.
  require_success(pipeline(run_args(c, out, 100) + " --set step.abp.integrate.v0=2 --resume --allow-changes"));
  CHECK_THAT(parameter_attribute(out / c.h5, "/parameters/history/2", "changes"),  // 0, 1: the resumes above
             Catch::Contains("step.abp.integrate.v0: 1 -> 2"));
  fs::remove_all(ref);
  fs::remove_all(out);
}

TEST_CASE("system.init.from starts a run from an H5MD frame: positions, images, species, orientations, box",
          "[checkpoint][init]") {
  if (!device_available()) return;
  const fs::path dir = fresh_dir("init_from");
  const fs::path file = dir / "source.yaml";
  std::ofstream(file) << R"(system: {dimensions: 2, N: 300, packing_fraction: 0.3, init: random,
         types: [{name: A, fraction: 0.5}, {name: B, fraction: 0.5, diameter: 1.2}]}
run: {steps: 30, dt: 0.01, seed: 3}
plugins: [abp]
step:
  - {stage: abp.integrate, v0: 1.0, Dr: 0.5, D: 0.1}
  - {stage: observe.h5md, every: 10, file: source.h5, fields: [position, image, orientation, type]}
)";
  require_success(pipeline("run " + file.string() + " --out " + (dir / "a").string()));
  // The second run starts from frame -1 (step 30) and writes its first frame at its step 0.
  require_success(pipeline("run " + file.string() + " --out " + (dir / "b").string() +
                           " --set 'system.init={from: " + (dir / "a" / "source.h5").string() +
                           ", frame: -1}' --set run.steps=10"));
  const auto a = datasets(dir / "a" / "source.h5"), b = datasets(dir / "b" / "source.h5");
  for (const char* element : {"position", "image", "orientation", "type"}) {
    INFO(element);
    const Dataset& va = a.at(std::string("particles/all/") + element + "/value");
    const Dataset& vb = b.at(std::string("particles/all/") + element + "/value");
    REQUIRE(va.shape.size() >= 2);
    REQUIRE(va.shape[0] == 4);  // steps 0, 10, 20, 30
    const std::size_t frame_bytes = va.bytes.size() / va.shape[0];
    REQUIRE(vb.bytes.size() >= frame_bytes);
    CHECK(std::equal(va.bytes.end() - std::ptrdiff_t(frame_bytes), va.bytes.end(), vb.bytes.begin()));
  }
  CHECK(a.at("particles/all/box/edges").bytes == b.at("particles/all/box/edges").bytes);
  // A frame out of range and a wrong N are refused with the key named.
  auto bad = pipeline("run " + file.string() + " --out " + (dir / "c").string() + " --set 'system.init={from: " +
                      (dir / "a" / "source.h5").string() + ", frame: 7}'");
  CHECK(bad.code == 2);
  CHECK_THAT(bad.out, Catch::Contains("frame 7 is out of range"));
  auto wrong_n = pipeline("run " + file.string() + " --out " + (dir / "d").string() + " --set system.N=301" +
                          " --set 'system.init={from: " + (dir / "a" / "source.h5").string() + "}'");
  CHECK(wrong_n.code == 2);
  CHECK_THAT(wrong_n.out, Catch::Contains("has 300 particles; system.N is 301"));
  fs::remove_all(dir);
}

TEST_CASE("h5md comparison: a differing dataset is reported by its first differing frame, step and entry",
          "[checkpoint]") {
  // What a failed comparison above prints instead of the datasets' bytes.
  Dataset a, b, steps;
  a.shape = {5, 4, 2};  // 5 frames of 4 particles x 2 int32
  a.bytes.assign(5 * 4 * 2 * 4, 0);
  b = a;
  b.bytes[3 * 32 + 2 * 8 + 4] = 1;  // frame 3, particle 2, component 1: entry 5
  b.bytes[4 * 32] = 7;              // frame 4, entry 0
  steps.shape = {5};
  for (std::int64_t k = 0; k < 5; ++k) {
    const std::int64_t s = 10 * k;
    const auto* p = reinterpret_cast<const unsigned char*>(&s);
    steps.bytes.insert(steps.bytes.end(), p, p + sizeof s);
  }
  const std::map<std::string, Dataset> series{{"particles/all/image/step", steps}};
  CHECK(first_difference("particles/all/image/value", a, a, series) == "");
  CHECK(first_difference("particles/all/image/value", a, b, series) ==
        "2 of 5 frames differ; the first is frame 3 (step 30), from its entry 5 (byte 20 of 32)");
  // Without a step series (or for a dataset that is not a series' value): the frame alone.
  CHECK(first_difference("observables/x", a, b, {}) ==
        "2 of 5 frames differ; the first is frame 3, from its entry 5 (byte 20 of 32)");
  Dataset shorter = a;
  shorter.bytes.resize(32);
  CHECK(first_difference("particles/all/image/value", a, shorter, series) == "160 bytes against 32");
}
