// The observe stages driven alone on hand-made states: observe.h5md (layout, values, float and
// double files, the .partial of a killed or failed run) and observe.msd through it (a
// hand-computed value written to the file). observe.msd's and observe.progress's own tests are in
// their folders.
// Files are checked with h5py: /usr/bin/python3 runs a script and must exit 0.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>

#include "support/h5py.h"
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>

#include "core/backend/device.h"
#include "core/base/error.h"
#include "core/io/h5md_reader.h"
#include "core/io/h5md_writer.h"
#include "core/stage/state.h"
#include "stages/observe/h5md/stage.h"
#include "stages/observe/msd/stage.h"
#include "support/backends.h"
#include "support/test_plugins.h"

#ifdef FLIPFLOW_HAVE_CUDA
#include <cuda_runtime.h>

#include <chrono>
#include <thread>
#endif

using namespace ff;
namespace fs = std::filesystem;

namespace {

// A scratch directory, removed afterwards.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name)
      : path(fs::temp_directory_path() / ("ff_observe_" + std::to_string(getpid()) + "_" + name)) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  std::string operator/(const std::string& f) const { return (path / f).string(); }
};

// Runs `script` with /usr/bin/python3 (numpy, h5py) and the given arguments; its exit status.
int python(const TempDir& dir, const std::string& script, const std::string& args) {
  if (!ff::test::can_check_h5md("h5py check of the written file")) return 0;
  const std::string file = dir / "check.py";
  std::ofstream(file) << "import sys\nimport numpy as np\nimport h5py\n" << script;
  std::fflush(nullptr);
  const int rc = std::system(("/usr/bin/python3 '" + file + "' " + args).c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

// What the core hands an observer: the accepted state's clock, its stats, a metrics slot.
struct Observe {
  RunInfo info;
  RunStats stats;
  Metrics metrics;

  void operator()(Stage& stage, State& s, std::uint64_t step, double time) {
    metrics.clear();
    StepContext ctx{s, info, stats, step, 0, stats.dt, time, Backend::cpu, nullptr, RngKey{}, metrics};
    REQUIRE_FALSE(stage.run(ctx).rollback);
  }
};

// Five disks in an 8 x 8 box; frame f has exactly representable values (checked in Python):
// position = 0.5 + 1.25 i + 0.125 f + 0.5 k, image = f (i - 2) + k, charge = 0.5 i + f,
// triangles (3 x i32, 7 of them, 6 in frame 2) = (j + f, j + 1, j + 2) mod 5 for row j.
constexpr std::size_t kN = 5;

template <class R>
void fill_frame(State& s, int f) {
  // Acquired for writing, as a stage's declared write is: observe.h5md writes a real field that
  // nothing wrote yet (version 0) as NaN in the initial frame.
  for (const char* name : {fields::position, fields::image, "charge"}) s.field(name).acquire(Where::host, Mode::write);
  R* x = s.field(fields::position).host<R>();
  std::int32_t* im = s.field(fields::image).host<std::int32_t>();
  for (std::size_t i = 0; i < kN; ++i)
    for (int k = 0; k < 2; ++k) {
      x[i * 2 + k] = R(0.5 + 1.25 * double(i) + 0.125 * f + 0.5 * k);
      im[i * 2 + k] = f * (int(i) - 2) + k;
    }
  double* q = s.field("charge").host<double>();
  for (std::size_t i = 0; i < kN; ++i) q[i] = 0.5 * double(i) + f;
  Field& tri = s.field("triangles");
  tri.resize(f == 2 ? 6 : 7);
  std::int32_t* t = tri.host<std::int32_t>();
  for (std::size_t j = 0; j < tri.count(); ++j) {
    t[j * 3 + 0] = std::int32_t((j + std::size_t(f)) % kN);
    t[j * 3 + 1] = std::int32_t((j + 1) % kN);
    t[j * 3 + 2] = std::int32_t((j + 2) % kN);
  }
}

std::unique_ptr<State> make_state(Precision p) {
  auto s = std::make_unique<State>(2, p, kN);
  s->box.L[0] = s->box.L[1] = 8.0;
  s->species = {"A", "B"};
  std::int32_t* type = s->field(fields::type).host<std::int32_t>();
  for (std::size_t i = 0; i < kN; ++i) type[i] = std::int32_t(i % 2);
  s->add_particle_field("charge", DType::f64, 1);
  s->add_field("triangles", DType::i32, 3, 7);
  return s;
}

std::unique_ptr<observe::H5mdObserver> make_h5md(const std::string& out_dir, std::vector<std::string> fields,
                                                 const std::string& pipeline_file = "",
                                                 std::function<void(observe::H5mdParams&)> change = {},
                                                 std::FILE* messages = stderr) {
  RunInfo info;
  info.messages = messages;
  info.out_dir = out_dir;
  info.pipeline_file = pipeline_file;
  info.stage_id = "observe.h5md";
  info.steps = 20;
  info.dt = 0.01;
  observe::H5mdParams p = params_from<observe::H5mdParams>(ParamValues::defaults(schema_of<observe::H5mdParams>()));
  p.fields = std::move(fields);
  if (change) change(p);
  return std::make_unique<observe::H5mdObserver>(p, info);
}

// Observes frames 0, 1, 2 at steps 0, 10, 20 (times 0, 0.125, 0.25), with rollbacks 0, 1, 3,
// the metric integrate/flips = 2.5 f and, from frame 2 on only, overlap/iterations = 7.
template <class R>
void observe_three_frames(Stage& stage, State& s, Observe& obs) {
  const std::uint32_t rollbacks[3] = {0, 1, 3};
  obs.stats.dt = 0.01;
  for (int f = 0; f < 3; ++f) {
    fill_frame<R>(s, f);
    obs.stats.rollbacks = rollbacks[f];
    obs.stats.metrics["integrate/flips"] = 2.5 * f;
    if (f == 2) obs.stats.metrics["overlap/iterations"] = 7;
    obs(stage, s, std::uint64_t(10 * f), 0.125 * f);
  }
}

// Checks positions/images/steps/times of the three frames (argv: file, numpy dtype, frames).
const char* kCheckFrames = R"PY(
f = h5py.File(sys.argv[1], "r")
N, F = 5, int(sys.argv[3])
i = np.arange(N)[:, None]; k = np.arange(2)[None, :]
pos = f["particles/all/position"]
assert pos["value"].shape == (F, N, 2), pos["value"].shape
assert pos["value"].dtype == np.dtype(sys.argv[2]), pos["value"].dtype
assert list(pos["step"][()]) == [0, 10, 20][:F], pos["step"][()]
assert pos["step"].dtype == np.int64
assert list(pos["time"][()]) == [0.0, 0.125, 0.25][:F], pos["time"][()]
img = f["particles/all/image"]
assert img["value"].dtype == np.int32 and img["value"].shape == (F, N, 2)
for fr in range(F):
    assert np.array_equal(pos["value"][fr], 0.5 + 1.25 * i + 0.125 * fr + 0.5 * k), (fr, pos["value"][fr])
    assert np.array_equal(img["value"][fr], fr * (i - 2) + k), (fr, img["value"][fr])
)PY";

const char* kCheckLayout = R"PY(
f = h5py.File(sys.argv[1], "r")
N, F = 5, 3
assert list(f["h5md"].attrs["version"]) == [1, 1]
assert f["h5md/creator"].attrs["name"] == b"flipflow"
assert len(f["h5md/creator"].attrs["version"]) > 0 and len(f["h5md/author"].attrs["name"]) > 0
box = f["particles/all/box"]
assert box.attrs["dimension"] == 2
assert list(box.attrs["boundary"]) == [b"periodic", b"periodic"], box.attrs["boundary"]
assert list(box["edges"][()]) == [8.0, 8.0]
sp = f["particles/all/species"]
assert sp.dtype == np.int32 and list(sp[()]) == [0, 1, 0, 1, 0], sp[()]
assert list(sp.attrs["names"]) == [b"A", b"B"]
q = f["particles/all/charge/value"]
assert q.shape == (F, N) and q.dtype == np.float64
assert np.array_equal(q[2], 0.5 * np.arange(N) + 2)
tri = f["connectivity/triangles"]
assert tri["value"].shape == (F, 7, 3) and tri["value"].dtype == np.int32, tri["value"].shape
assert f[tri.attrs["particles_group"]].name == "/particles/all"
j = np.arange(7)
for fr in range(F):
    m = 6 if fr == 2 else 7
    want = np.stack([(j[:m] + fr) % N, (j[:m] + 1) % N, (j[:m] + 2) % N], axis=1)
    assert np.array_equal(tri["value"][fr, :m], want), (fr, tri["value"][fr])
assert list(tri["value"][2, 6]) == [-1, -1, -1]
assert list(tri["step"][()]) == [0, 10, 20]
obs = f["observables"]
assert list(obs["dt/value"][()]) == [0.01] * 3
assert list(obs["rollbacks/value"][()]) == [0, 1, 3]
assert list(obs["rollbacks/step"][()]) == [0, 10, 20]
assert list(obs["integrate/flips/value"][()]) == [0.0, 2.5, 5.0]
assert list(obs["overlap/iterations/step"][()]) == [20]
assert list(obs["overlap/iterations/time"][()]) == [0.25]
assert list(obs["overlap/iterations/value"][()]) == [7.0]
par = f["parameters"]
assert par["pipeline"][()].decode() == open(sys.argv[2]).read()
assert par.attrs["precision"] == sys.argv[3].encode(), par.attrs["precision"]
assert par.attrs["pipeline_file"] == sys.argv[2].encode()
)PY";

template <class R>
void h5md_layout(Precision p, const char* numpy_type) {
  TempDir dir(std::string("layout_") + to_string(p));
  const std::string yaml = dir / "pipe.yaml";
  std::ofstream(yaml) << "run: {steps: 20, dt: 0.01}  # Δt\nstep:\n  - {stage: observe.h5md, every: 10}\n";
  auto s = make_state(p);
  auto stage = make_h5md(dir.path.string(), {"position", "image", "charge", "triangles"}, yaml);
  stage->configure(*s);
  Observe obs;
  observe_three_frames<R>(*stage, *s, obs);
  stage->finish(*s, true);

  const std::string file = dir / "trajectory.h5";
  CHECK(fs::exists(file));
  CHECK_FALSE(fs::exists(file + ".partial"));
  CHECK(python(dir, kCheckFrames, "'" + file + "' " + numpy_type + " 3") == 0);
  CHECK(python(dir, kCheckLayout, "'" + file + "' '" + yaml + "' " + to_string(p)) == 0);
}

}  // namespace

TEST_CASE("observe.h5md writes the H5MD layout in double precision", "[observe][h5md]") {
  h5md_layout<double>(Precision::f64, "float64");
}

TEST_CASE("observe.h5md writes positions in float for a float run", "[observe][h5md]") {
  h5md_layout<float>(Precision::f32, "float32");
}

// A real field that nothing has written when the initial frame is taken (a force, voronoi.area:
// the steps compute them) is NaN in it, "not computed", not the zeros it was allocated with; from
// its first write on it holds its values. An integer field keeps its zeros.
TEST_CASE("observe.h5md writes NaN for a real field not computed yet in the initial frame", "[observe][h5md]") {
  TempDir dir("not_yet");
  auto s = make_state(Precision::f64);
  s->add_particle_field("late", DType::f64, 2);
  s->add_particle_field("late_count", DType::i32, 1);
  auto stage = make_h5md(dir.path.string(), {"position", "late", "late_count"});
  stage->configure(*s);
  Observe obs;
  fill_frame<double>(*s, 0);
  obs(*stage, *s, 0, 0.0);
  fill_frame<double>(*s, 1);
  Field& late = s->field("late");
  late.acquire(Where::host, Mode::write);
  for (std::size_t i = 0; i < late.size(); ++i) late.host<double>()[i] = 0.25 * double(i);
  obs(*stage, *s, 10, 0.125);
  stage->finish(*s, true);
  const char* check = R"PY(
import sys, h5py, numpy as np
f = h5py.File(sys.argv[1], "r")
late = f["particles/all/late/value"][()]
count = f["particles/all/late_count/value"][()]
pos = f["particles/all/position/value"][()]
assert late.shape == (2, 5, 2), late.shape
assert np.isnan(late[0]).all(), late[0]
assert np.array_equal(late[1].ravel(), 0.25 * np.arange(10)), late[1]
assert (count[0] == 0).all(), count[0]
assert not np.isnan(pos).any()
print("ok")
)PY";
  CHECK(python(dir, check, "'" + (dir / "trajectory.h5") + "'") == 0);
}

TEST_CASE("observe.h5md declares host reads of what it writes", "[observe][h5md]") {
  auto s = make_state(Precision::f64);
  auto stage = make_h5md("", {"position", "charge"});
  stage->configure(*s);
  const auto a = stage->accesses();
  REQUIRE(a.size() == 3);  // the fields, and `type` for /particles/all/species
  for (auto& x : a) {
    CHECK(x.where == Where::host);
    CHECK(x.mode == Mode::read);
  }
  CHECK(a[0].field == "position");
  CHECK(a[1].field == "charge");
  CHECK(a[2].field == "type");
  CHECK(stage->outputs() == std::vector<std::string>{"trajectory.h5"});
}

TEST_CASE("observe.h5md rejects an unknown field in configure, naming the fields it has", "[observe][h5md]") {
  auto s = make_state(Precision::f64);
  auto stage = make_h5md("", {"position", "velocity"});
  try {
    stage->configure(*s);
    FAIL("configure accepted an unknown field");
  } catch (const InputError& e) {
    const std::string m = e.what();
    CHECK(m.find("'velocity'") != std::string::npos);
    CHECK(m.find("position") != std::string::npos);
    CHECK(m.find("charge") != std::string::npos);
  }
  s->add_field("edge_lengths", DType::f64, 1, 3);  // neither per particle nor triangles
  auto other = make_h5md("", {"edge_lengths"});
  CHECK_THROWS_AS(other->configure(*s), InputError);
  auto twice = make_h5md("", {"image", "image"});
  CHECK_THROWS_AS(twice->configure(*s), InputError);
}

TEST_CASE("A killed observe.h5md run leaves a readable .partial with the frames written", "[observe][h5md]") {
  TempDir dir("killed");
  const std::string file = dir / "trajectory.h5";
  std::fflush(nullptr);
  const pid_t child = fork();
  REQUIRE(child >= 0);
  if (child == 0) {  // the "run": three frames on disk, then killed before finish()
    try {
      auto s = make_state(Precision::f64);
      auto stage = make_h5md(dir.path.string(), {"position", "image"});
      stage->configure(*s);
      Observe obs;
      observe_three_frames<double>(*stage, *s, obs);
      stage->drain();
      std::raise(SIGKILL);
    } catch (...) {
    }
    _exit(3);
  }
  int status = 0;
  REQUIRE(waitpid(child, &status, 0) == child);
  REQUIRE(WIFSIGNALED(status));
  REQUIRE(WTERMSIG(status) == SIGKILL);
  CHECK_FALSE(fs::exists(file));
  REQUIRE(fs::exists(file + ".partial"));
  CHECK(python(dir, kCheckFrames, "'" + file + ".partial' float64 3") == 0);
}

TEST_CASE("observe.h5md keeps the .partial when the run does not complete", "[observe][h5md]") {
  TempDir dir("failed");
  const std::string file = dir / "trajectory.h5";
  auto s = make_state(Precision::f64);
  Observe obs;
  SECTION("finish(completed = false)") {
    auto stage = make_h5md(dir.path.string(), {"position", "image"});
    stage->configure(*s);
    observe_three_frames<double>(*stage, *s, obs);
    stage->finish(*s, false);
  }
  SECTION("destroyed without finish(): queued frames are still written") {
    auto stage = make_h5md(dir.path.string(), {"position", "image"});
    stage->configure(*s);
    observe_three_frames<double>(*stage, *s, obs);
  }
  CHECK_FALSE(fs::exists(file));
  REQUIRE(fs::exists(file + ".partial"));
  CHECK(python(dir, kCheckFrames, "'" + file + ".partial' float64 3") == 0);
}

TEST_CASE("observe.h5md: a completed run without frames still leaves its file", "[observe][h5md]") {
  TempDir dir("empty");
  auto s = make_state(Precision::f64);
  auto stage = make_h5md(dir.path.string(), {"position"});
  stage->configure(*s);
  stage->finish(*s, true);
  CHECK(python(dir, R"PY(
f = h5py.File(sys.argv[1], "r")
assert f["particles/all/position/value"].shape == (0, 5, 2)
assert list(f["particles/all/species"][()]) == [0, 1, 0, 1, 0]
)PY", dir / "trajectory.h5") == 0);
}

TEST_CASE("H5mdWriter: an unwritable path is a RunError naming the file", "[observe][h5md]") {
  try {
    H5mdWriter w("/nonexistent-flipflow-dir/x.h5", H5mdHeader{});
    FAIL("created a file in a directory that does not exist");
  } catch (const RunError& e) {
    CHECK(std::string(e.what()).find("/nonexistent-flipflow-dir/x.h5.partial") != std::string::npos);
  }
}

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
  std::fflush(messages);
  CHECK(std::ftell(messages) == 0);
  std::fclose(messages);
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
  std::rewind(messages);
  std::string text(4096, '\0');
  text.resize(std::fread(text.data(), 1, text.size(), messages));
  std::fclose(messages);
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
  std::rewind(messages);
  std::string text(4096, '\0');
  text.resize(std::fread(text.data(), 1, text.size(), messages));
  std::fclose(messages);
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

TEST_CASE("observe.msd matches a hand-computed value and reaches the H5MD file", "[observe][msd]") {
  const Precision p = GENERATE(Precision::f32, Precision::f64);
  TempDir dir(std::string("msd_") + to_string(p));
  State s(2, p, 3);
  s.box.L[0] = s.box.L[1] = 10.0;
  auto set = [&](std::vector<double> x, std::vector<std::int32_t> im) {
    s.field(fields::position).acquire(Where::host, Mode::write);
    for (std::size_t i = 0; i < x.size(); ++i) {
      if (p == Precision::f32) s.field(fields::position).host<float>()[i] = float(x[i]);
      else s.field(fields::position).host<double>()[i] = x[i];
      s.field(fields::image).host<std::int32_t>()[i] = im[i];
    }
  };
  observe::Msd msd;
  auto h5md = make_h5md(dir.path.string(), {}, "");
  h5md->configure(s);
  Observe obs;
  auto both = [&](std::uint64_t step) {
    obs(msd, s, step, 0.5 * double(step));
    for (auto& [k, v] : obs.metrics.values()) obs.stats.metrics["msd/" + k] = v;  // as the core does
    obs(*h5md, s, step, 0.5 * double(step));
  };
  set({1, 1, 5, 5, 2, 3}, {0, 0, 0, 0, 0, 0});
  both(0);
  CHECK(obs.stats.metrics.at("msd/msd") == 0.0);
  // p0 crosses the left edge: (9.5, 1) with image (-1, 0) is (-0.5, 1) unwrapped: |d|² = 2.25.
  // p1 moves up by 2: 4. p2 sits at (2, 3) with image (1, -1): (12, -7), |d|² = 100 + 100.
  set({9.5, 1, 5, 7, 2, 3}, {-1, 0, 0, 0, 1, -1});
  both(4);
  CHECK(obs.stats.metrics.at("msd/msd") == (2.25 + 4.0 + 200.0) / 3.0);
  h5md->finish(s, true);
  CHECK(python(dir, R"PY(
f = h5py.File(sys.argv[1], "r")
m = f["observables/msd/msd"]
assert list(m["step"][()]) == [0, 4] and list(m["time"][()]) == [0.0, 2.0]
assert list(m["value"][()]) == [0.0, 68.75], m["value"][()]
)PY", dir / "trajectory.h5") == 0);
}

TEST_CASE("stage_observe registers three observers, for CUDA runs too", "[observe][plugin]") {
  const auto registry = test::registry_of({"observe"});
  const Registry& r = *registry;
  for (const char* name : {"observe.h5md", "observe.progress", "observe.msd"}) {
    INFO(name);
    const auto& e = r.get(name);
    CHECK(e.decl.observer);
    CHECK(e.factories.count(Backend::cpu) == 1);
    CHECK(e.factories.count(Backend::cuda) == (built_with_cuda() ? 1u : 0u));
  }
  const auto defaults = ParamValues::defaults(r.get("observe.h5md").decl.params);
  CHECK(defaults.string("file") == "trajectory.h5");
  CHECK(defaults.strings("fields") == std::vector<std::string>{"position", "image"});
  CHECK(defaults.boolean("observables"));
  RunInfo info;
  auto stage = r.create("observe.h5md", Backend::cpu, defaults, info);
  CHECK(stage->outputs() == std::vector<std::string>{"trajectory.h5"});
  CHECK(ParamValues::defaults(r.get("observe.progress").decl.params).real("interval") == 10.0);
}

// A full disk during output (issue 19, item 6): the write that does not fit fails with a
// RunError naming the file, and every frame flushed before it reads back unchanged from
// the kept .partial. The disk is "full" by RLIMIT_FSIZE (writes past the limit fail with EFBIG;
// SIGXFSZ ignored), which any user may lower and raise back to the hard limit.
//
// The failed flush leaves a superblock that claims space it could not write; close() extends
// the file to it by a hole (core/io/h5md_writer.cpp), else HDF5 would refuse the whole file.
TEST_CASE("H5mdWriter on a full disk: a clear error, and every earlier frame stays readable",
          "[observe][h5md]") {
  rlimit old{};
  REQUIRE(getrlimit(RLIMIT_FSIZE, &old) == 0);
  const auto dir = std::filesystem::temp_directory_path() / ("ff_h5md_full_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "full.h5").string();
  const std::size_t n = 1000;
  auto frame_values = [&](int k) {
    std::vector<double> p(2 * n);
    for (std::size_t i = 0; i < p.size(); ++i) p[i] = double(k) * 1000.0 + double(i) * 0.5;
    return p;
  };
  ff::H5mdHeader h;
  h.dim = 2;
  h.edges[0] = h.edges[1] = 10.0;
  int written = 0;
  std::string error;
  {
    ff::H5mdWriter w(path, h);
    w.add_particle_element("position", ff::DType::f64, n, 2);
    for (; written < 3; ++written) {
      w.append_particle_element("position", written, 0.1 * written, frame_values(written).data());
      w.flush();
    }
    const auto size = std::uintmax_t(std::filesystem::file_size(w.partial_path()));
    void (*previous)(int) = std::signal(SIGXFSZ, SIG_IGN);
    rlimit full = old;
    full.rlim_cur = rlim_t(size + 3 * 2 * n * sizeof(double) + 4096);  // room for about three more frames
    if (old.rlim_max != RLIM_INFINITY && full.rlim_cur > old.rlim_max) full.rlim_cur = old.rlim_max;
    REQUIRE(setrlimit(RLIMIT_FSIZE, &full) == 0);
    try {
      for (; written < 100; ++written) {
        w.append_particle_element("position", written, 0.1 * written, frame_values(written).data());
        w.flush();
      }
    } catch (const ff::RunError& e) {
      error = e.what();
    }
    // The limit goes before close(): on a full disk close() can still extend the file by a
    // hole (no blocks), which RLIMIT_FSIZE, counting length and not blocks, would refuse.
    REQUIRE(setrlimit(RLIMIT_FSIZE, &old) == 0);
    std::signal(SIGXFSZ, previous);
    try {
      w.close(false);  // as observe.h5md's finish() does for a failed run
    } catch (const ff::RunError&) {
    }
  }
  INFO(error);
  CHECK_THAT(error, Catch::Contains("full.h5.partial") && Catch::Contains("failed"));
  CHECK(written >= 3);
  CHECK(written < 100);
  // Every frame whose append and flush returned is there, bit for bit.
  for (int k = 0; k < written; ++k) {
    INFO("frame " << k << " of " << written);
    const ff::H5mdFrame f = ff::read_h5md_frame(path + ".partial", k);
    CHECK(f.step == k);
    CHECK(f.position == frame_values(k));
  }
  std::filesystem::remove_all(dir);
}

#ifdef FLIPFLOW_HAVE_CUDA
// On CUDA observe.h5md queues a frame's device-to-host copy on the step's stream and hands the
// frame to the writer thread at once; the writer waits for the frame's StreamMark before it
// writes. The frame moves through the writer's queue in between, and until session 33 a moved
// StreamMark forgot that it was recorded: the writer then wrote whatever the recycled pinned
// buffer held when the copy was late (test_checkpoint's resumed runs on an H200 wrote one frame of
// 2 001 with the values of an earlier one, twice in six sessions). Here the copy waits behind a
// sleeping host function on its stream, so a writer that does not wait writes zeros.
TEST_CASE("H5mdWriter refuses to begin a frame the disk has no room for, and the file stays whole",
          "[observe][h5md]") {
  // A frame begun on a nearly full disk fails mid-write and may leave a file HDF5 cannot read or
  // close (a segfault at exit in the failure audit of session 34): check_space stops before it.
  // The disk's real free space against a frame larger than any disk: refused.
  const auto dir = std::filesystem::temp_directory_path() / ("ff_h5md_space_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "space.h5").string();
  const std::size_t n = 100;
  std::vector<double> p(2 * n, 0.5);
  ff::H5mdHeader h;
  h.dim = 2;
  h.edges[0] = h.edges[1] = 10.0;
  std::string error;
  {
    ff::H5mdWriter w(path, h);
    w.add_particle_element("position", ff::DType::f64, n, 2);
    w.check_space(p.size() * sizeof(double));  // a frame of this size fits
    w.append_particle_element("position", 0, 0.0, p.data());
    w.flush();
    try {
      w.check_space(std::uint64_t(1) << 60);
    } catch (const ff::RunError& e) {
      error = e.what();
    }
    w.close(false);
  }
  INFO(error);
  CHECK_THAT(error, Catch::Contains("space.h5.partial") && Catch::Contains("KiB free, less than the next frame needs") &&
                        Catch::Contains("--resume"));
  const ff::H5mdFrame f = ff::read_h5md_frame(path + ".partial", 0);
  CHECK(f.position == p);
  std::filesystem::remove_all(dir);
}

TEST_CASE("observe.h5md on CUDA writes a frame after its device copy, however late the copy", "[observe][h5md][cuda]") {
  if (!ff::test::have_cuda("observe.h5md's writer waiting for a late device copy")) return;
  TempDir dir("late_copy");
  const std::string path = dir / "late.h5";
  const std::size_t n = 64;
  std::vector<double> values(2 * n);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = 1.0 + 0.25 * double(i);
  const std::size_t bytes = values.size() * sizeof(double);
  void* device = nullptr;
  REQUIRE(cudaMalloc(&device, bytes) == cudaSuccess);
  REQUIRE(cudaMemcpy(device, values.data(), bytes, cudaMemcpyHostToDevice) == cudaSuccess);
  cudaStream_t stream = nullptr;
  REQUIRE(cudaStreamCreateWithFlags(&stream, cudaStreamNonBlocking) == cudaSuccess);
  {
    ff::H5mdHeader h;
    h.dim = 2;
    h.edges[0] = h.edges[1] = 10.0;
    auto writer = std::make_unique<ff::H5mdWriter>(path, h);
    writer->add_particle_element("position", ff::DType::f64, n, 2);
    observe::AsyncFrameWriter async(std::move(writer), observe::H5mdObserver::queue_depth);
    observe::Frame frame = async.take();
    frame.step = 7;
    frame.time = 0.07;
    frame.fields.resize(1);
    observe::FieldFrame& out = frame.fields[0];
    out.name = "position";
    out.count = n;
    out.bytes = HostBuffer(true);
    out.bytes.resize(bytes);
    std::memset(out.bytes.data(), 0, bytes);
    auto hold = [](void*) { std::this_thread::sleep_for(std::chrono::milliseconds(300)); };
    REQUIRE(cudaLaunchHostFunc(stream, hold, nullptr) == cudaSuccess);
    copy_device_to_host_async(out.bytes.data(), device, bytes, reinterpret_cast<CUstream_st*>(stream));
    frame.ready.record(reinterpret_cast<CUstream_st*>(stream));
    async.submit(std::move(frame));
    async.close(true);
  }
  REQUIRE(cudaStreamSynchronize(stream) == cudaSuccess);
  cudaStreamDestroy(stream);
  cudaFree(device);
  const ff::H5mdFrame f = ff::read_h5md_frame(path, 0);
  CHECK(f.step == 7);
  CHECK(f.position == values);
}
#endif
