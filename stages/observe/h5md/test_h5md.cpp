// observe.h5md driven alone on hand-made states: the H5MD layout and values in float and double
// files, fields not computed yet in the initial frame, the declared reads, configure's errors,
// the plugin's registration, observe.msd through the file, and the CUDA writer's wait for a late
// device copy. Frames and observables over time: test_h5md_series.cpp; killed, failed and
// full-disk runs: test_h5md_failures.cpp. observe.msd's and observe.progress's own tests are in
// their folders.
#include <catch2/catch.hpp>

#include <cstring>
#include <fstream>

#include "core/backend/device.h"
#include "core/base/error.h"
#include "core/io/h5md_reader.h"
#include "core/io/h5md_writer.h"
#include "stages/observe/h5md/test_support.h"
#include "stages/observe/msd/stage.h"
#include "support/backends.h"
#include "support/test_plugins.h"

#ifdef FLIPFLOW_HAVE_CUDA
#include <cuda_runtime.h>

#include <chrono>
#include <thread>
#endif

using namespace ff;
using namespace ff::test::h5md;

namespace {

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

#ifdef FLIPFLOW_HAVE_CUDA
// On CUDA observe.h5md queues a frame's device-to-host copy on the step's stream and hands the
// frame to the writer thread at once; the writer waits for the frame's StreamMark before it
// writes. The frame moves through the writer's queue in between, and until session 33 a moved
// StreamMark forgot that it was recorded: the writer then wrote whatever the recycled pinned
// buffer held when the copy was late (test_checkpoint's resumed runs on an H200 wrote one frame of
// 2 001 with the values of an earlier one, twice in six sessions). Here the copy waits behind a
// sleeping host function on its stream, so a writer that does not wait writes zeros.
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
