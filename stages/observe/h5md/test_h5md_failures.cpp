// observe.h5md and its writer when a run does not end well: a killed run's readable .partial, a
// failed or abandoned run's kept .partial, an unwritable path, a disk that fills up during the
// run, and a frame refused before it begins when the disk has no room for it.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>

#include <csignal>
#include <filesystem>

#include "core/base/error.h"
#include "core/io/h5md_reader.h"
#include "core/io/h5md_writer.h"
#include "stages/observe/h5md/test_support.h"

using namespace ff;
using namespace ff::test::h5md;

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
