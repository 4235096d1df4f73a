// observe.h5md's frames and observables over time: observables alone (fields: []), frames at
// multiples of frames_every and its warnings, a metric written once at the step it was reported,
// and the writer's refusal of an observable row at or before its series' last step.
#include <catch2/catch.hpp>

#include <cstdio>
#include <string>

#include "core/io/h5md_writer.h"
#include "stages/observe/h5md/test_support.h"

using namespace ff;
using namespace ff::test::h5md;

TEST_CASE("observe.h5md with fields: [] writes the observables alone, at every step it runs", "[observe][h5md]") {
  // The way to a time series finer than the frames (pipelines/boids.yaml's observables.h5).
  TempDir dir("observables_only");
  auto s = make_state(Precision::f64);
  auto stage = make_h5md(dir.path.string(), {});
  stage->configure(*s);
  Observe obs;
  observe_three_frames<double>(*stage, *s, obs);
  stage->finish(*s, true);
  CHECK(python(dir, R"PY(
f = h5py.File(sys.argv[1], "r")
assert "position" not in f["particles/all"], list(f["particles/all"])
m = f["observables/integrate/flips"]
assert list(m["step"][()]) == [0, 10, 20], m["step"][()]
assert list(m["value"][()]) == [0.0, 2.5, 5.0], m["value"][()]
)PY", dir / "trajectory.h5") == 0);
}

TEST_CASE("observe.h5md with frames_every writes frames at its multiples and observables at every run",
          "[observe][h5md]") {
  // Runs at steps 0, 10, 20; frames_every 20: positions at 0 and 20, the observables at all three.
  TempDir dir("frames_every");
  std::FILE* messages = std::tmpfile();
  auto s = make_state(Precision::f64);
  auto stage = make_h5md(
      dir.path.string(), {"position", "image", "triangles"}, "", [](observe::H5mdParams& p) { p.frames_every = 20; },
      messages);
  stage->configure(*s);
  Observe obs;
  observe_three_frames<double>(*stage, *s, obs);
  stage->finish(*s, true);
  CHECK(python(dir, R"PY(
f = h5py.File(sys.argv[1], "r")
N = 5
i = np.arange(N)[:, None]; k = np.arange(2)[None, :]
pos = f["particles/all/position"]
assert list(pos["step"][()]) == [0, 20], pos["step"][()]
assert list(pos["time"][()]) == [0.0, 0.25], pos["time"][()]
assert np.array_equal(pos["value"][1], 0.5 + 1.25 * i + 0.125 * 2 + 0.5 * k), pos["value"][1]
assert list(f["particles/all/image/step"][()]) == [0, 20]
assert list(f["connectivity/triangles/step"][()]) == [0, 20]
obs = f["observables"]
assert list(obs["rollbacks/step"][()]) == [0, 10, 20], obs["rollbacks/step"][()]
assert list(obs["integrate/flips/value"][()]) == [0.0, 2.5, 5.0]
)PY", dir / "trajectory.h5") == 0);
  // Runs 10 steps apart divide 20: nothing to say.
  CHECK(text_of(messages).empty());
}

TEST_CASE("observe.h5md says once when its runs step past frames_every", "[observe][h5md]") {
  TempDir dir("frames_every_warn");
  std::FILE* messages = std::tmpfile();
  auto s = make_state(Precision::f64);
  auto stage = make_h5md(
      dir.path.string(), {"position"}, "", [](observe::H5mdParams& p) { p.frames_every = 15; }, messages);
  stage->configure(*s);
  Observe obs;
  observe_three_frames<double>(*stage, *s, obs);  // steps 0, 10, 20: only 0 is a multiple of 15
  stage->finish(*s, true);
  const std::string text = text_of(messages);
  CHECK(text.find("frames_every: 15 is not a multiple of the 10 steps between its runs at steps 0 and 10") !=
        std::string::npos);
  CHECK(text.find("warning") == text.rfind("warning"));  // once
  CHECK(python(dir, R"PY(
f = h5py.File(sys.argv[1], "r")
assert list(f["particles/all/position/step"][()]) == [0], f["particles/all/position/step"][()]
assert list(f["observables/rollbacks/step"][()]) == [0, 10, 20]
)PY", dir / "trajectory.h5") == 0);
}

TEST_CASE("observe.h5md refuses frames_every without fields or with the MDAnalysis layout", "[observe][h5md]") {
  TempDir dir("frames_every_refused");
  auto s = make_state(Precision::f64);
  auto none = make_h5md(dir.path.string(), {}, "", [](observe::H5mdParams& p) { p.frames_every = 100; });
  CHECK_THROWS_WITH(none->configure(*s), Catch::Contains("frames_every: 100 with fields: []"));
  auto mda = make_h5md(dir.path.string(), {"position"}, "", [](observe::H5mdParams& p) {
    p.frames_every = 100;
    p.layout = "mdanalysis";
  });
  CHECK_THROWS_WITH(mda->configure(*s), Catch::Contains("layout: mdanalysis"));
}

TEST_CASE("observe.h5md writes a metric once, at the step it was reported, not again until it is new",
          "[observe][h5md]") {
  // Before: a metric of a stage that ran every 20 steps was repeated at every frame between,
  // labelled with the frame's step (an MSD read as a staircase). The observer runs at 0, 10, 20,
  // 30; `slow/Z` is reported at steps 0 and 20 only, `fast/flips` at every frame, `late/x` was
  // reported at step 5 (between frames) and first seen at frame 10.
  TempDir dir("stamps");
  auto s = make_state(Precision::f64);
  auto stage = make_h5md(dir.path.string(), {"position"});
  stage->configure(*s);
  Observe obs;
  obs.stats.dt = 0.01;
  for (int f = 0; f < 4; ++f) {
    const std::uint64_t step = 10 * std::uint64_t(f);
    const double time = 0.1 * f;
    fill_frame<double>(*s, f % 3);
    if (f % 2 == 0) {
      obs.stats.metrics["slow/Z"] = 1.5 + f;
      obs.stats.metric_stamps["slow/Z"] = {step, time};
    }
    obs.stats.metrics["fast/flips"] = 2.0 * f;
    obs.stats.metric_stamps["fast/flips"] = {step, time};
    if (f == 1) {
      obs.stats.metrics["late/x"] = 9;
      obs.stats.metric_stamps["late/x"] = {5, 0.05};
    }
    obs(*stage, *s, step, time);
  }
  stage->finish(*s, true);
  CHECK(python(dir, R"PY(
f = h5py.File(sys.argv[1], "r")
o = f["observables"]
assert list(o["slow/Z/step"][()]) == [0, 20], o["slow/Z/step"][()]
assert list(o["slow/Z/value"][()]) == [1.5, 3.5], o["slow/Z/value"][()]
assert list(o["slow/Z/time"][()]) == [0.0, 0.2], o["slow/Z/time"][()]
assert list(o["fast/flips/step"][()]) == [0, 10, 20, 30], o["fast/flips/step"][()]
assert list(o["late/x/step"][()]) == [5] and list(o["late/x/time"][()]) == [0.05], o["late/x/step"][()]
assert list(o["dt/step"][()]) == [0, 10, 20, 30]
assert list(f["particles/all/position/step"][()]) == [0, 10, 20, 30]
)PY", dir / "trajectory.h5") == 0);
}

TEST_CASE("observe.h5md says once when an observer's metric was reported more often than it writes",
          "[observe][h5md]") {
  // observe.msd every 5 steps beside observe.h5md every 10: the values at steps 5, 15, 25 are in
  // no file. The observer runs at 0, 10, 20, 30; msd/msd's reports count 1, 3, 5, 7.
  TempDir dir("lost_reports");
  std::FILE* messages = std::tmpfile();
  auto s = make_state(Precision::f64);
  auto stage = make_h5md(dir.path.string(), {"position"}, "", {}, messages);
  stage->configure(*s);
  Observe obs;
  obs.stats.dt = 0.01;
  for (int f = 0; f < 4; ++f) {
    const std::uint64_t step = 10 * std::uint64_t(f);
    fill_frame<double>(*s, f % 3);
    obs.stats.metrics["msd/msd"] = 4.0 * f;
    obs.stats.metric_stamps["msd/msd"] = {step, 0.1 * f, std::uint64_t(2 * f + 1), true};
    obs.stats.metrics["overlap/iterations"] = 3;  // a compute stage's, every step: sampled, not said
    obs.stats.metric_stamps["overlap/iterations"] = {step, 0.1 * f, 10 * std::uint64_t(f) + 1, false};
    obs(*stage, *s, step, 0.1 * f);
  }
  stage->finish(*s, true);
  const std::string text = text_of(messages);
  CHECK(text.find("writes 'msd/msd' only when it runs itself: 1 value reported between its rows at steps 0 and 10 is not in 'trajectory.h5'") !=
        std::string::npos);
  CHECK(text.find("warning") == text.rfind("warning"));  // once
  CHECK(text.find("overlap/iterations") == std::string::npos);
}

TEST_CASE("H5mdWriter: an observable row at or before its series' last step is not written", "[observe][h5md]") {
  // What keeps a continued run's file whole: a metric it already holds is not appended again.
  TempDir dir("monotonic");
  const std::string file = dir / "m.h5";
  {
    H5mdHeader h;
    H5mdWriter w(file, h);
    w.append_observable("a/x", 0, 0.0, 1.0);
    w.append_observable("a/x", 10, 0.1, 2.0);
    w.append_observable("a/x", 10, 0.1, 3.0);  // dropped: at the last step
    w.append_observable("a/x", 5, 0.05, 4.0);  // dropped: before it
    w.close(true);
  }
  {
    auto w = H5mdWriter::reopen(file, 10, {});
    REQUIRE(w);
    w->append_observable("a/x", 10, 0.1, 5.0);  // dropped: the kept file has step 10
    w->append_observable("a/x", 20, 0.2, 6.0);
    w->close(true);
  }
  CHECK(python(dir, R"PY(
f = h5py.File(sys.argv[1], "r")
x = f["observables/a/x"]
assert list(x["step"][()]) == [0, 10, 20], x["step"][()]
assert list(x["value"][()]) == [1.0, 2.0, 6.0], x["value"][()]
)PY", file) == 0);
}
