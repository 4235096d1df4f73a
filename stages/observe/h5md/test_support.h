// What stages/observe/h5md's tests share: a scratch directory, an h5py check of the written file,
// a five-disk state whose frames hold exactly representable values, and the observer driven
// through three frames (test_h5md.cpp: layout and values; test_h5md_series.cpp: frames and
// observables over time; test_h5md_failures.cpp: killed, failed and full-disk runs).
// Files are checked with h5py: /usr/bin/python3 runs a script and must exit 0.
#pragma once
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/stage/state.h"
#include "stages/observe/h5md/stage.h"
#include "support/h5py.h"
#include "support/temp_dir.h"

namespace ff::test::h5md {

namespace fs = std::filesystem;


using ff::test::TempDir;

// Runs `script` with /usr/bin/python3 (numpy, h5py) and the given arguments; its exit status.
inline int python(const TempDir& dir, const std::string& script, const std::string& args) {
  if (!ff::test::can_check_h5md("h5py check of the written file")) return 0;
  const std::string file = dir / "check.py";
  std::ofstream(file) << "import sys\nimport numpy as np\nimport h5py\n" << script;
  std::fflush(nullptr);
  const int rc = std::system(("/usr/bin/python3 '" + file + "' " + args).c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

// Everything written to `messages` (a std::tmpfile() handed to the observer), which is closed.
inline std::string text_of(std::FILE* messages) {
  std::fflush(messages);
  std::rewind(messages);
  std::string text;
  char buf[4096];
  for (std::size_t got; (got = std::fread(buf, 1, sizeof buf, messages)) > 0;) text.append(buf, got);
  std::fclose(messages);
  return text;
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

inline std::unique_ptr<State> make_state(Precision p) {
  auto s = std::make_unique<State>(2, p, kN);
  s->box.L[0] = s->box.L[1] = 8.0;
  s->species = {"A", "B"};
  std::int32_t* type = s->field(fields::type).host<std::int32_t>();
  for (std::size_t i = 0; i < kN; ++i) type[i] = std::int32_t(i % 2);
  s->add_particle_field("charge", DType::f64, 1);
  s->add_field("triangles", DType::i32, 3, 7);
  return s;
}

inline std::unique_ptr<observe::H5mdObserver> make_h5md(const std::string& out_dir, std::vector<std::string> fields,
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
inline constexpr const char* kCheckFrames = R"PY(
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

}  // namespace ff::test::h5md
